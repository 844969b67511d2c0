"""Forward dynamics of the 35-DOF whole body driven by its own 3D inverse dynamics.

Thesis 2.3.2 and 2.4 (Figs. 2.4.2-2.4.3): the ADAMS/Android body was driven by the
joint moments or the joint motions found in the inverse problem; with the pelvis
orientation and all joints kinematic it walked, with the pelvis orientation free it
fell at t = 0.55 s. Here the same experiments run on the Pinocchio body of
:mod:`predgait.dynamics.inverse3d_trial` through :mod:`predgait.dynamics.partitioned`:

* pelvis ``prescribed`` (follows the measured motion), ``translation`` (orientation
  prescribed, position free: the thesis' stable case) or ``free`` (6 DOF);
* joints driven by the inverse-dynamics ``moments`` or ``kinematic`` (the IK angles);
* ground: the ``measured`` plate wrenches on the foot each plate was assigned to in
  inverse dynamics, or ``contact`` springs at the foot sole points
  (:class:`~predgait.dynamics.contact.ImpactContact` with Coulomb friction).

Prescribed coordinates follow exactly the q, v, a inverse dynamics used (splines of the
samples); moments and plate wrenches are splined alike. A run stops at a
fall: the pelvis dropping more than ``pelvis_drop`` below the measured height, a pelvis
Cardan angle (obliquity X, tilt Y, rotation Z) or a joint angle deviating more than a
limit from the measured one.
"""

from __future__ import annotations

import enum
from collections.abc import Mapping
from dataclasses import dataclass, field, replace

import numpy as np
import pinocchio as pin

from predgait.analysis.deviation3d import deviations3d
from predgait.dynamics.contact import ImpactContact
from predgait.dynamics.drivers import SampledHistory
from predgait.dynamics.external import Load
from predgait.dynamics.falls import FallLimit
from predgait.dynamics.forces import GroundContact, JointFeedback, JointTorques, MeasuredLoads
from predgait.dynamics.integrators import IntegratorOptions, Status
from predgait.dynamics.inverse3d import FEET, sole_points
from predgait.dynamics.motion import MotionHistory
from predgait.dynamics.partitioned import PartitionedSystem, simulate_partitioned
from predgait.errors import InputError, SimulationDiverged
from predgait.models.fullbody import CONTACTS
from predgait.models.loading3d import Model3D

PELVIS_ANGLES = ("pelvis obliquity", "pelvis tilt", "pelvis rotation")  # Cardan X, Y, Z
#: Foot contact law of ``ground = "contact"`` per sole point: linear spring 2e5 N/m
#: (about 2 mm under half the body weight on two points), damping 2e3 N s/m reached at
#: 1 mm, Coulomb friction 0.8 ramped over 0.05 m/s of slip.
DEFAULT_CONTACT = ImpactContact(stiffness=2e5, exponent=1.0, damping=2e3, damping_depth=1e-3,
                                friction=0.8, slip_transition=0.05)


class PelvisMode(enum.Enum):
    """How the pelvis (free-flyer root) moves."""

    PRESCRIBED = "prescribed"
    TRANSLATION = "translation"
    FREE = "free"


class JointMode(enum.Enum):
    """What drives the 29 joint coordinates."""

    MOMENTS = "moments"
    KINEMATIC = "kinematic"


class GroundMode(enum.Enum):
    """Where the ground reaction comes from."""

    MEASURED = "measured"
    CONTACT = "contact"


@dataclass(frozen=True)
class Mode:
    """One simulation set-up: a name, the three choices and the joints kept kinematic.

    ``kinematic_joints`` mixes moments and motions (thesis 2.3.2): joints whose name
    starts with one of these (e.g. "ankle", "knee_r_z") follow the IK when the other
    joints are driven by moments. ``feedback_kp`` (N m/rad) adds PD feedback toward the
    measured angles on the moment-driven joints, each damped at ``feedback_damping_ratio``
    of its own inertia (:meth:`~predgait.dynamics.partitioned.JointFeedback.damped`).
    ``step`` (s) replaces the problem's fixed integrator step for this mode (None: keep
    it); contact runs need a finer one than the plates (see :meth:`integrator`).
    """

    name: str = "main"
    pelvis: PelvisMode = PelvisMode.PRESCRIBED
    joints: JointMode = JointMode.MOMENTS
    ground: GroundMode = GroundMode.MEASURED
    kinematic_joints: tuple[str, ...] = ()
    feedback_kp: float = 0.0
    feedback_damping_ratio: float = 1.0
    step: float | None = None

    def integrator(self, options: IntegratorOptions) -> IntegratorOptions:
        """``options`` with this mode's step, if it has one.

        On sole springs the stick phase of the friction ramp (mu N / slip_transition,
        ~2.6e4 N s/m at 1600 N, 0.8 and 0.05 m/s) is a stiff mode: RK4 at 1 ms lets it
        grow into full Coulomb sliding where the converged run sticks (contact forces off
        by up to 1.4 kN on subject01; tests/test_fullbody_convergence.py).
        """
        return options if self.step is None else replace(options, step=self.step)


#: Default fall criteria: the pelvis 0.1 m below or a pelvis Cardan angle 30 deg from the
#: measured motion, or a joint 45 deg from it (problem keys pelvis_drop, pelvis_angle_deg,
#: joint_deg).
FULLBODY_FALL = FallLimit(base_drop=0.1, base_angle_deg=30.0, joint_deviation_deg=45.0)
#: Names of the fall events in the whole body's results.
_CRITERIA = {"base height": "pelvis height", "joint deviation": "joint angle"}


@dataclass(frozen=True)
class ContactSettings:
    """Foot-ground contact of ``ground = "contact"``.

    Attributes:
        contact: Point contact law, one per frame.
        frames: Model frames in contact (default the heel and toe sole points).
        ground_z: m, floor height; None = estimated from the measured motion.
        belt_velocity: m/s along X of the ground surface (treadmill belt); None =
            estimated from the measured motion (:func:`measured_ground`).
    """

    contact: ImpactContact = DEFAULT_CONTACT
    frames: tuple[str, ...] = CONTACTS
    ground_z: float | None = None
    belt_velocity: float | None = None


@dataclass(frozen=True, eq=False)
class FullbodyDrive:
    """Measured whole-body motion and its inverse dynamics, the input of re-synthesis.

    Attributes:
        model: The body inverse dynamics used.
        time: (n,) s. q: (n, nq). v, a: (n, nv) (Pinocchio's velocities).
        tau: (n, nv) inverse-dynamics generalised forces (rows 6.. joint moments, N m).
        foot_wrench: Side ("r"/"l") -> (n, 6) ground wrench on that foot in the lab,
            force (N) then moment about the lab origin (N m).
        heel_strikes: Times at which a foot starts a stance, s.
        source: Provenance text.
        calibration: How the marker frames were calibrated and the mass found (the
            inverse result's provenance: ``marker_calibration``,
            ``foot_flat_calibration``, ``mass_from``: "given" or "plates"; and
            ``plates_weigh_kg``, :func:`~predgait.data.body_weight.plate_body_mass`).
    """

    model: Model3D
    time: np.ndarray
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    tau: np.ndarray
    foot_wrench: Mapping[str, np.ndarray]
    heel_strikes: tuple[float, ...] = ()
    source: str = ""
    calibration: Mapping[str, object] = field(default_factory=dict)

    @classmethod
    def from_inverse(cls, result) -> FullbodyDrive:
        """From a :class:`~predgait.dynamics.inverse3d_trial.Inverse3DResult`."""
        if result.sides is None:
            raise InputError("the inverse result has no plate-to-foot assignment (sides).")
        starts = sorted({s.start for s in result.stances if s.start > result.ik.time[0]})
        return cls(result.model, result.ik.time, result.q, result.v, result.a,
                   result.dynamics.tau, foot_wrenches(result.plates, result.sides),
                   tuple(starts), str(result.provenance.get("trial", "")),
                   {k: result.provenance.get(k) for k in ("marker_calibration",
                                                          "foot_flat_calibration",
                                                          "mass_from")}
                   | {"plates_weigh_kg": None if result.plate_mass is None
                      else round(result.plate_mass.mass, 1)})


def foot_wrenches(plates, sides: np.ndarray) -> dict[str, np.ndarray]:
    """Sum the plates on each foot as (n, 6) lab wrenches about the origin (N, N m).

    The wrench of a plate is its force F at its COP plus its free moment:
    (F, cop x F + free_moment), the load inverse dynamics applied.
    """
    n = sides.shape[1]
    out = {s: np.zeros((n, 6)) for s in FEET}
    for p, plate in enumerate(plates):
        moment = np.cross(plate.cop, plate.force) + plate.free_moment
        for s in FEET:
            on = sides[p] == s
            out[s][on, :3] += plate.force[on]
            out[s][on, 3:] += moment[on]
    return out


def _foot_flat_floors(drive: FullbodyDrive) -> list[float]:
    """The plates' surface (m) each foot was levelled on (foot flat), if any."""
    return [f["floor_z_m"] for f in (drive.calibration.get("foot_flat_calibration")
                                      or {}).values() if isinstance(f, dict)]


def ground_source(drive: FullbodyDrive) -> str:
    """Where :func:`measured_ground`'s floor height comes from, in words."""
    if _foot_flat_floors(drive):
        return "plates' surface (feet levelled on it: foot flat)"
    return "median lowest sole point of the measured motion"


def measured_ground(drive: FullbodyDrive, frames=CONTACTS, *, threshold: float = 20.0
                    ) -> tuple[float, float]:
    """Floor height (m) and belt velocity along X (m/s) seen in the measured motion.

    Floor: the plates' surface when the feet were levelled on it (foot flat,
    ``drive.calibration``), else the median over frames of the lowest contact frame (a
    sole is on the floor; a rigid foot's toe dipping at push-off biases it low: 5 mm on
    walking5). Belt: median X velocity of the loaded feet's sole mid-points (vertical load
    above ``threshold`` N); about 0 over ground, the belt speed on a treadmill.
    """
    model = drive.model
    floor = _foot_flat_floors(drive)
    if not floor:
        pm, data = model.pin_model, model.pin_model.createData()
        ids = [model.frame_id(f) for f in frames]
        for row in drive.q:
            pin.framesForwardKinematics(pm, data, row)
            floor.append(min(data.oMf[i].translation[2] for i in ids))
    soles = sole_points(model, drive.q)
    speeds = [np.gradient(soles[s][:, 0], drive.time)[w[:, 2] > threshold]
              for s, w in drive.foot_wrench.items()]
    speeds = np.concatenate(speeds)
    return float(np.median(floor)), float(np.median(speeds)) if speeds.size else 0.0


def free_rows(mode: Mode, joint_names) -> list[int]:
    """Velocity rows integrated in ``mode``."""
    pelvis = {PelvisMode.PRESCRIBED: [], PelvisMode.TRANSLATION: [0, 1, 2],
              PelvisMode.FREE: list(range(6))}[mode.pelvis]
    unknown = [k for k in mode.kinematic_joints
               if not any(n.startswith(k) for n in joint_names)]
    if unknown:
        raise InputError(f"variant {mode.name!r}: kinematic joint {unknown[0]!r} matches no "
                         f"joint; joints: {', '.join(joint_names)}.")
    joints = [6 + i for i, n in enumerate(joint_names) if mode.joints is JointMode.MOMENTS
              and not n.startswith(tuple(mode.kinematic_joints))]
    if not pelvis and not joints:
        raise InputError(f"variant {mode.name!r}: pelvis prescribed and joints kinematic "
                         "leaves nothing to simulate; free the pelvis or drive the joints "
                         "by moments.")
    return pelvis + joints


def build_system(drive: FullbodyDrive, mode: Mode, *, contact: ContactSettings | None = None
                 ) -> tuple[PartitionedSystem, MotionHistory, GroundContact | None]:
    """The partitioned system of ``mode`` and the measured motion history it follows."""
    model, nv = drive.model, drive.model.nv
    history = MotionHistory(model, drive.time, drive.q, drive.v, drive.a)
    forces, ground = [], None
    if mode.joints is JointMode.MOMENTS:
        torque = SampledHistory(drive.time, drive.tau[:, 6:], name="joint moments")
        forces.append(JointTorques(np.arange(6, nv), torque))
    if mode.ground is GroundMode.MEASURED:
        forces.append(MeasuredLoads(model, _measured_loads(drive)))
    else:
        contact = contact or ContactSettings()
        z, belt = measured_ground(drive, contact.frames)
        z = z if contact.ground_z is None else contact.ground_z
        belt = belt if contact.belt_velocity is None else contact.belt_velocity
        ground = GroundContact(model, contact.frames, contact.contact, ground_z=z,
                               belt_velocity=belt)
        forces.append(ground)
    free = free_rows(mode, model.joint_names)
    driven = [i for i in free if i >= 6]
    if mode.feedback_kp and driven:
        forces.append(JointFeedback.damped(model, driven, history, mode.feedback_kp,
                                           mode.feedback_damping_ratio,
                                           history(drive.time[0])[0]))
    system = PartitionedSystem(model, free, history, forces)
    return system, history, ground


def _measured_loads(drive: FullbodyDrive):
    """Foot wrenches splined like the moments (so the two stay consistent in between)."""
    wrench = {s: SampledHistory(drive.time, w, name=f"ground wrench on foot_{s}")
              for s, w in drive.foot_wrench.items() if np.any(w)}

    def loads(t, data):
        rows = {side: w(t) for side, w in wrench.items()}
        return [Load(f"foot_{side}", row[:3], np.zeros(3), row[3:])
                for side, row in rows.items() if row.any()]

    return loads


def fastest_growth(system: PartitionedSystem, t: float, x: np.ndarray, *,
                   eps: float = 1e-6) -> tuple[float, str]:
    """Fastest linear growth at (t, x): largest Re(eigenvalue) of df/dx, 1/s.

    Positive = unstable, 1/rate the e-folding time. Returns it with the state leading
    its eigenvector. df/dx by central differences of the right-hand side.
    """
    n = x.size
    jac = np.empty((n, n))
    for i in range(n):
        step = np.zeros(n)
        step[i] = eps
        jac[:, i] = (system(t, x + step) - system(t, x - step)) / (2 * eps)
    values, vectors = np.linalg.eig(jac)
    k = int(np.argmax(values.real))
    lead = int(np.argmax(np.abs(vectors[: system.nqf, k])))
    return float(values[k].real), system.state_names()[lead]


@dataclass(frozen=True, eq=False)
class Forward3DRun:
    """One simulated mode.

    Attributes:
        mode: What was simulated.
        t: (n,) s. q: (n, nq) simulated configurations. measured: (n, nq) at ``t``.
        status: COMPLETED, EVENT (fell) or DIVERGED.
        time_to_fall: s after the start (None if it did not fall).
        fall_criterion: What fell (event name, joint named), or None.
        message: How the run ended.
        deviation: :func:`~predgait.analysis.deviation3d.deviations3d` of the run.
        growth: (rate 1/s, leading state) of :func:`fastest_growth` at the start.
        ground_z, belt_velocity: m, m/s, floor of contact runs (None for measured loads).
        feedback_peak: Joint -> peak |PD feedback torque| along the run, N m (joints
            under ``feedback_kp`` only).
        measured_peak: Joint -> peak |inverse-dynamics moment| at the run's times, N m
            (the same joints): the drive the feedback corrects.
    """

    mode: Mode
    t: np.ndarray
    q: np.ndarray
    measured: np.ndarray
    status: Status
    time_to_fall: float | None
    fall_criterion: str | None
    message: str
    deviation: dict
    growth: tuple[float, str]
    ground_z: float | None = None
    belt_velocity: float | None = None
    feedback_peak: Mapping[str, float] = field(default_factory=dict)
    measured_peak: Mapping[str, float] = field(default_factory=dict)


def feedback_peaks(system: PartitionedSystem, drive: FullbodyDrive, run
                   ) -> tuple[dict[str, float], dict[str, float]]:
    """Peak |PD feedback| (N m) along ``run`` and peak |measured moment| per fed-back joint.

    Empty when ``system`` has no :class:`JointFeedback`. The measured moment is the
    inverse dynamics' ``drive.tau`` interpolated at the run's times.
    """
    law = next((f for f in system.forces if isinstance(f, JointFeedback)), None)
    if law is None or not len(run.t):
        return {}, {}
    torque = np.array([law.torque(t, q, v) for t, q, v in zip(run.t, run.q, run.v,
                                                                strict=True)])
    names = [drive.model.joint_names[row - 6] for row in law.rows]
    measured = [np.interp(run.t, drive.time, drive.tau[:, row]) for row in law.rows]
    return ({n: float(np.max(np.abs(torque[:, i]))) for i, n in enumerate(names)},
            {n: float(np.max(np.abs(m))) for n, m in zip(names, measured, strict=True)})


def simulate_fullbody(drive: FullbodyDrive, mode: Mode, t_span: tuple[float, float], *,
                      options: IntegratorOptions | None = None,
                      fall: FallLimit = FULLBODY_FALL, contact: ContactSettings | None = None,
                      band_deg: float = 5.0, band_m: float = 0.05,
                      progress: bool = False) -> Forward3DRun:
    """Simulate ``mode`` over ``t_span`` (s, trial time) from the measured state.

    A divergence is reported as status "diverged" with what was computed until then.
    Default integrator: RK4, 1 ms.
    """
    options = options or IntegratorOptions()
    t0, t1 = (float(t) for t in t_span)
    if not drive.time[0] <= t0 < t1 <= drive.time[-1] + 1e-9:
        raise InputError(f"simulation {t0:g}..{t1:g} s is outside the trial "
                         f"{drive.time[0]:.3f}..{drive.time[-1]:.3f} s.")
    system, history, ground = build_system(drive, mode, contact=contact)
    q0, v0, _ = history(t0)
    x0 = system.state(q0, v0)
    growth = fastest_growth(system, t0, x0)
    try:
        run = simulate_partitioned(system, (t0, t1), x0, options=options,
                                   events=fall.events(system, lambda t: history(t)[0]),
                                   progress=progress)
    except SimulationDiverged as exc:
        run = exc.partial
    measured = np.array([history(t)[0] for t in run.t])
    criterion, fall_time = None, run.time_to_fall
    if run.status is Status.EVENT:
        criterion = _CRITERIA.get(run.event.removeprefix("fall: "),
                                  run.event.removeprefix("fall: "))
        if criterion == "joint angle":
            worst = np.argmax(np.abs(run.q[-1, 7:] - measured[-1, 7:]))
            criterion = f"joint angle {drive.model.joint_names[worst]}"
    dev = deviations3d(run.t, run.q, measured, drive.model.joint_names,
                       band_deg=band_deg, band_m=band_m)
    return Forward3DRun(mode, run.t, run.q, measured, run.status, fall_time, criterion,
                        run.message, dev, growth,
                        *((ground.ground_z, ground.belt_velocity) if ground else (None, None)),
                        *feedback_peaks(system, drive, run))
