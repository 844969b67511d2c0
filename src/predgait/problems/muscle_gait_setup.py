"""What the muscle-driven 2D gait NLP is built from: plant, bounds, initial guess.

* :func:`plant_2d_gait`: the predgait model of an OpenSim planar gait model
  (:func:`predgait.models.osim_model.build_model`), its DeGrooteFregly2016 muscles
  (:class:`predgait.dynamics.muscles.MuscleSet`), the smooth path lengths
  (:mod:`predgait.dynamics.muscle_paths`), the lumbar CoordinateActuator and the
  SmoothSphereHalfSpaceForce contacts (:mod:`predgait.dynamics.smooth_contact`).
* :data:`MOCO_BOUNDS`: the coordinate bounds of Moco's example2DWalking (OpenSim
  coordinate values: rad, m); :data:`PHYSIOLOGICAL_BOUNDS` widens the joint ones to
  normal walking's range (Moco's knee bound of -50 deg is below the 60-65 deg of normal
  swing flexion; its hip -10 deg and ankle -15 deg bounds are above normal terminal-stance
  hip extension and toe-off plantarflexion: Winter 2009, Perry 1992).
* :func:`reference_guess`: the coordinates of a storage file (the example's
  referenceCoordinates.sto) on the nodes, 6 Hz low-pass (as Moco's TabOpLowPassFilter(6)),
  speeds and accelerations from a cubic spline.
"""

from __future__ import annotations

import math

import numpy as np

from predgait.errors import InputError
from predgait.problems.muscle_gait import Bounds, Trajectory
from predgait.problems.muscle_gait_dynamics import MusclePlant, Sphere

DEG = math.pi / 180.0
#: Moco's bounds (benchmarks/opensim_moco_2d_walking.py): OpenSim coordinate -> (low, high).
MOCO_BOUNDS = {
    "pelvis_tilt": (-20 * DEG, -10 * DEG), "pelvis_tx": (0.0, 1.0), "pelvis_ty": (0.75, 1.25),
    "hip_flexion_l": (-10 * DEG, 60 * DEG), "hip_flexion_r": (-10 * DEG, 60 * DEG),
    "knee_angle_l": (-50 * DEG, 0.0), "knee_angle_r": (-50 * DEG, 0.0),
    "ankle_angle_l": (-15 * DEG, 25 * DEG), "ankle_angle_r": (-15 * DEG, 25 * DEG),
    "lumbar": (0.0, 20 * DEG),
}
#: Joint ranges of normal walking (hip -30..60, knee -100..0, ankle -35..30 deg), the rest
#: as Moco's.
PHYSIOLOGICAL_BOUNDS = {
    **MOCO_BOUNDS,
    **{f"hip_flexion_{s}": (-30 * DEG, 60 * DEG) for s in "lr"},
    **{f"knee_angle_{s}": (-100 * DEG, 0.0) for s in "lr"},
    **{f"ankle_angle_{s}": (-35 * DEG, 30 * DEG) for s in "lr"},
}
#: Moco's default speed bounds (rad/s, m/s) and a wide acceleration bound (rad/s^2).
SPEED_BOUND = 50.0
ACCELERATION_BOUND = 1000.0
#: Activation and excitation of the guess.
GUESS_ACTIVATION = 0.05


def plant_2d_gait(osim):
    """(MusclePlant, OsimPlanarModel) of a model read by :func:`read_osim`."""
    from predgait.dynamics.joint_springs import JointSpring
    from predgait.dynamics.muscle_paths import smooth_paths
    from predgait.dynamics.muscles import MuscleSet
    from predgait.dynamics.smooth_contact import SmoothSphereContact
    from predgait.models.osim_model import build_model

    planar = build_model(osim)
    model = planar.model
    muscles = MuscleSet.from_osim(osim)
    paths = smooth_paths(planar, on_model_q=True)
    if tuple(paths.muscle_names) != tuple(muscles.names):
        raise InputError(f"{osim.source}: the path fits' muscles {paths.muscle_names} are not "
                         f"the muscle set's {muscles.names}.")
    if len(osim.actuators) != 1:
        raise InputError(f"{osim.source}: expected one CoordinateActuator (the lumbar), "
                         f"found {len(osim.actuators)}.")
    lumbar = osim.actuators[0]
    row = planar.osim_coordinates.index(lumbar.coordinate) \
        if lumbar.coordinate in planar.osim_coordinates[3:] else None
    if row is None:
        raise InputError(f"{osim.source}, line {lumbar.line}: CoordinateActuator "
                         f"'{lumbar.name}' drives '{lumbar.coordinate}', not a joint "
                         "coordinate of the model.")
    spheres, laws = [], []
    for contact in osim.contacts:
        sphere = next(s for s in osim.spheres if s.name == contact.sphere)
        link, location = planar.point_on_body(sphere.body, sphere.location)
        spheres.append(Sphere(contact.name, link, tuple(float(x) for x in location),
                              float(sphere.radius)))
        laws.append(SmoothSphereContact.from_osim(contact, float(sphere.radius)))
    springs = tuple(JointSpring(s.coordinate, s.stiffness, s.rest_length, s.viscosity)
                    for s in osim.springs if s.applies_force)
    excitation = (min(m.min_control for m in osim.muscles),
                  max(m.max_control for m in osim.muscles))
    plant = MusclePlant(model=model, osim=osim, muscle_names=muscles.names,
                        muscle_set=muscles, paths=paths, lumbar_row=row,
                        lumbar_optimal_force=float(lumbar.optimal_force),
                        lumbar_control_range=(float(lumbar.min_control),
                                              float(lumbar.max_control)),
                        excitation_range=excitation, spheres=tuple(spheres),
                        contacts=tuple(laws), springs=springs,
                        coordinates=tuple(planar.osim_coordinates),
                        signs=tuple(float(s) for s in planar.signs))
    return plant, planar


def compliant_rows(names: tuple[str, ...], chosen, where: str = "") -> tuple[int, ...]:
    """Rows of the muscles whose tendons are compliant, from a problem file's choice.

    Args:
        names: the model's muscle names (``soleus_r``, ``soleus_l``, ...).
        chosen: ``"all"``, or muscle names: a name without its side (``"soleus"``) means
            both sides' muscles; a sided name (``"soleus_r"``) needs its other side too
            (a half stride with left/right symmetry pairs them).
        where: the file and key, for messages.

    Raises:
        InputError: an unknown muscle, or a sided name without its pair.
    """
    if isinstance(chosen, str):
        if chosen != "all":
            raise InputError(f"{where}: compliant_tendons = {chosen!r}: give \"all\" or a "
                             "list of muscle names.")
        return tuple(range(len(names)))
    rows = set()
    for name in chosen:
        hits = [i for i, n in enumerate(names) if n == name or n in (f"{name}_r", f"{name}_l")]
        if not hits:
            raise InputError(f"{where}: no muscle named {name!r}; the model's muscles: "
                             f"{', '.join(names)} (or a name without _r/_l for both sides).")
        rows.update(hits)
    from predgait.problems.muscle_gait import mirror_rows

    mirror = mirror_rows(names)
    alone = sorted(names[i] for i in rows if int(mirror[i]) not in rows)
    if alone:
        raise InputError(f"{where}: compliant tendons for {', '.join(alone)} but not the "
                         "other side's: the symmetric half stride pairs left and right; name "
                         "the muscle without its side for both.")
    return tuple(sorted(rows))


def coordinate_bounds(planar, ranges: dict[str, tuple[float, float]]) -> np.ndarray:
    """(nq, 2) model-coordinate bounds from OpenSim coordinate ranges (rad, m).

    Coordinates not in ``ranges`` keep the model's own range.
    """
    names = tuple(planar.osim_coordinates)
    own = {n: planar.osim.coordinate(n).range for n in names}
    low = np.array([ranges.get(n, own[n])[0] for n in names])
    high = np.array([ranges.get(n, own[n])[1] for n in names])
    unknown = sorted(set(ranges) - set(names))
    if unknown:
        raise InputError(f"bounds on {', '.join(unknown)}: the model's coordinates are "
                         f"{', '.join(names)}.")
    a, b = planar.q_from_osim(low), planar.q_from_osim(high)
    return np.column_stack([np.minimum(a, b), np.maximum(a, b)])


def bounds_for(plant: MusclePlant, planar, ranges: dict, duration: tuple[float, float]
               ) -> Bounds:
    """The NLP's box bounds: coordinate ranges, Moco's speed bounds, controls' ranges."""
    nq = plant.model.nq
    speed = np.tile([-SPEED_BOUND, SPEED_BOUND], (nq, 1))
    accel = np.tile([-ACCELERATION_BOUND, ACCELERATION_BOUND], (nq, 1))
    return Bounds(q=coordinate_bounds(planar, ranges), v=speed, a=accel, duration=duration,
                  activation=plant.excitation_range, excitation=plant.excitation_range,
                  lumbar=plant.lumbar_control_range)


def reference_guess(planar, storage, plant: MusclePlant, intervals: int,
                    cutoff: float = 6.0) -> tuple[Trajectory, np.ndarray]:
    """(guess, q_ref (N+1, nq)) from a storage of OpenSim coordinate values.

    Columns are matched by coordinate name (``/jointset/hip_r/hip_flexion_r/value`` or
    ``hip_flexion_r``); pelvis_tx starts at 0. A coordinate without a column (a joint the
    reference's model does not have, e.g. a toe joint) stays at its default value. A
    MocoTrajectory (e.g. Moco's own solution) also gives the activations
    (``/<muscle>/activation``), excitations (``/<muscle>``) and the lumbar control; it is not
    low-passed.
    """
    from scipy.interpolate import CubicSpline

    from predgait.data import lowpass

    names = tuple(planar.osim_coordinates)
    columns = {}
    for label, values in storage.columns.items():
        parts = label.strip("/").split("/")
        key = parts[-2] if len(parts) >= 2 and parts[-1] == "value" else parts[-1]
        if key in names:
            columns[key] = values * (DEG if storage.in_degrees and "_t" not in key else 1.0)
    t = storage.time - storage.time[0]
    missing = [n for n in names if n not in columns]
    if len(missing) > len(names) // 2:
        raise InputError(f"{storage.source}: no column for {', '.join(missing)}; give a "
                         "storage of the model's coordinates (OpenSim names).")
    for n in missing:        # a joint the reference does not have (e.g. a toe joint)
        columns[n] = np.full(t.size, planar.osim.coordinate(n).default_value)
    rate = (t.size - 1) / t[-1]
    values = np.column_stack([columns[n] for n in names])
    muscles = [f"/{m}/activation" for m in plant.muscle_names]
    trajectory = all(m in storage.columns for m in muscles)
    values = lowpass(values, rate, cutoff) if cutoff and not trajectory else values
    q_rows = np.array([planar.q_from_osim(row) for row in values])
    q_rows[:, 0] -= q_rows[0, 0]
    spline = CubicSpline(t, q_rows, axis=0)
    nodes = np.linspace(0.0, t[-1], intervals + 1)
    m = plant.n_muscles
    act = exc = np.full((intervals + 1, m), GUESS_ACTIVATION)
    lumbar = np.zeros(intervals + 1)
    if trajectory:
        def at_nodes(label):
            return np.interp(nodes, t, storage.columns[label])

        act = np.column_stack([at_nodes(c) for c in muscles])
        exc = np.column_stack([at_nodes(f"/{m}") if f"/{m}" in storage.columns
                               else act[:, i] for i, m in enumerate(plant.muscle_names)])
        name = f"/{plant.osim.actuators[0].name}"
        lumbar = at_nodes(name) if name in storage.columns else lumbar
    guess = Trajectory(float(t[-1]), spline(nodes), spline(nodes, 1), spline(nodes, 2),
                       act, exc, lumbar)
    return guess, guess.q.copy()
