"""OpenSim's own numbers for the 2D gait model, written once as committed CSV tables.

Run with the OpenSim 4.6 Python (the peer; predgait never imports opensim), from anywhere:

    OMP_NUM_THREADS=1 $OPENSIM_PYTHON tests/reference/osim2d/make_reference.py \
        [--model PATH/2D_gait.osim] [--tables NAME,...]

(``--tables``: a comma-separated subset of muscle_geometry, muscle_force, contact_force,
model_frames, contact_parameters; default all these; ``gait_contact`` also needs
``--moco-solution gaitTracking_solution_fullcycle.sto``, Moco's tracking solution of
example2DWalking as ``benchmarks/opensim_moco_2d_walking.py --write`` writes it). Values
are written with 12 significant digits.

It reads ``2D_gait.osim`` (default: ``../shared/data/opensim_moco_2d_walking/`` beside the
repository, i.e. opensim-core's Moco example2DWalking model) and writes, next to this script,
each table whole (to a temporary file, then renamed). Samples come from a seeded generator,
so a rerun on the same OpenSim gives the same files. Every quantity is in OpenSim's frames
(ground: X forward, Y up, Z right) and SI units (m, rad, m/s, rad/s, N, N m); predgait's lab
frame is p_predgait = (x, -z, y)_opensim. Coordinates keep OpenSim's names and values.

Tables (one header row; ``nan`` never appears):

``muscle_geometry.csv``: one row per pose (200): ``pose`` (id), ``kind`` (``random``: uniform
    within every coordinate's range; ``conditional``: a spanned coordinate 0.01 rad inside or
    outside a ConditionalPathPoint range boundary; ``knee_sweep``: both knees across their range,
    where rect_fem and vasti have MovingPathPoints), the 10 coordinate values, then per muscle
    ``<muscle>.length`` (GeometryPath length, m) and ``<muscle>.moment_arm.<coordinate>`` (m,
    OpenSim's ``Muscle.computeMomentArm``, = -dl/dq) for each coordinate it spans (those with
    a non-zero moment arm at some pose).
``muscle_force.csv``: one row per (state, muscle), 30 states x 18 muscles: ``state``,
    ``muscle``, the 10 coordinate values (pelvis ones 0) and their speeds ``<coordinate>.speed``
    (rad/s or m/s), ``activation``, then DeGrooteFregly2016Muscle's outputs at that state
    (realized to Dynamics; every muscle is ignore_tendon_compliance = true, rigid tendon):
    ``length`` (muscle-tendon, m), ``lengthening_speed`` (m/s), ``tendon_force`` (N),
    ``fiber_length`` (m), ``normalized_fiber_length``, ``fiber_velocity`` (m/s),
    ``normalized_fiber_velocity`` (per max_contraction_velocity * optimal_fiber_length),
    ``active_force_length_multiplier``, ``force_velocity_multiplier``,
    ``passive_force_multiplier``, ``pennation_angle`` (rad), ``active_fiber_force``,
    ``passive_fiber_elastic_force``, ``passive_fiber_damping_force``, ``fiber_force`` (N).
``contact_force.csv``: one row per sampled state of one SmoothSphereHalfSpaceForce:
    ``force`` (element name), ``body`` (the sphere's body), ``radius`` (m), ``kind``
    (``translation``: every speed but pelvis_tx/ty zero, so the sphere translates;
    ``rotation``: pelvis_tilt and ankle speeds too, so the contact point's velocity differs from
    the centre's), the 10 coordinates and 10 speeds that make the state (the sphere's height is
    set through pelvis_ty), then, read back from OpenSim: ``center_x/y/z`` (sphere centre in
    ground), ``center_vx/vy/vz`` (its velocity in ground), ``omega_x/y/z`` (the sphere body's
    angular velocity in ground), ``origin_x/y/z`` (the sphere body's origin in ground), and
    ``penetration`` = radius - center_y (m, > 0 in the floor; the floor is y = 0, normal +Y),
    and OpenSim's ``getRecordValues``: ``force_x/y/z`` (force on the sphere's body, ground
    frame, N) and ``torque_x/y/z`` (torque on it about the body's origin, N m; the force acts
    at Simbody's contact point, centre - (radius - penetration / 2) * normal).
``contact_parameters.csv``: one row per SmoothSphereHalfSpaceForce: ``force``, ``sphere``,
    ``body``, ``radius`` (m), ``location_x/y/z`` (sphere centre in the body frame, m) and the
    element's properties as OpenSim 4.6 holds them after reading the file: ``stiffness``
    (N/m^2), ``dissipation`` (s/m), ``static_friction``, ``dynamic_friction``,
    ``viscous_friction`` (s/m), ``transition_velocity`` (m/s), ``constant_contact_force``,
    ``hertz_smoothing`` (1/m), ``hunt_crossley_smoothing`` (s/m). (The file's
    ``derivative_smoothing`` is an old name OpenSim 4.6 ignores: constant_contact_force is its
    default 1e-5; a file value of 1e-3 there leaves it at 1e-5.)
``gait_contact.csv``: every second state (101) of Moco's example2DWalking tracking solution
    (full cycle): ``time``, the 10 coordinates and speeds, then per SmoothSphereHalfSpaceForce
    ``<force>.center_x/y/z``, ``.center_vx/vy/vz``, ``.omega_x/y/z`` (as in contact_force.csv)
    and ``.force_x/y/z`` (getRecordValues: force on the sphere's body, ground frame, N).
``model_frames.csv``: at 6 poses, one row per body, contact sphere and the whole model:
    ``pose``, ``kind`` (``body``, ``sphere``, ``model``), ``name``, the 10 coordinates,
    ``x/y/z`` (body origin, sphere centre or model COM in ground, m), ``com_x/y/z`` (body COM in
    ground; model: the model COM), ``mass`` (kg; model: total), and for bodies ``r00..r22``,
    the body's rotation matrix to ground (row-major; sphere and model rows: identity).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import opensim as osim
from peer_csv import write_table

HERE = Path(__file__).resolve().parent
DEFAULT_MODEL = HERE.parents[3] / "shared" / "data" / "opensim_moco_2d_walking" / "2D_gait.osim"
SEED = 20261204
TABLES = ("muscle_geometry", "muscle_force", "contact_force", "model_frames",
          "contact_parameters", "gait_contact")
JOINT_COORDS = (
    "hip_flexion_l", "hip_flexion_r", "knee_angle_l", "knee_angle_r",
    "ankle_angle_l", "ankle_angle_r", "lumbar",
)






class Peer:
    """The model, its state and the components the tables read."""

    def __init__(self, model_path: Path):
        self.model = osim.Model(str(model_path))
        self.state = self.model.initSystem()
        self.coords = [c for c in self.model.getCoordinateSet()]
        self.names = [c.getName() for c in self.coords]
        self.by_name = dict(zip(self.names, self.coords, strict=True))
        self.muscles = [
            osim.DeGrooteFregly2016Muscle.safeDownCast(c)
            for c in self.model.getComponentsList()
            if c.getConcreteClassName() == "DeGrooteFregly2016Muscle"
        ]
        self.contacts = [
            osim.SmoothSphereHalfSpaceForce.safeDownCast(c)
            for c in self.model.getComponentsList()
            if c.getConcreteClassName() == "SmoothSphereHalfSpaceForce"
        ]

    def set(self, q: dict, u: dict | None = None) -> None:
        """Set every coordinate (missing ones 0) and speed, then realize velocity."""
        for name, coord in self.by_name.items():
            coord.setValue(self.state, float(q.get(name, 0.0)), False)
        for name, coord in self.by_name.items():
            coord.setSpeedValue(self.state, float((u or {}).get(name, 0.0)))
        self.model.realizeVelocity(self.state)

    def ranges(self) -> dict:
        return {n: (c.getRangeMin(), c.getRangeMax()) for n, c in self.by_name.items()}


def _vec(v) -> list[float]:
    return [v.get(0), v.get(1), v.get(2)]


def _conditional_points(peer: Peer) -> list[tuple[str, float, float]]:
    """(coordinate name, range min, range max) of every ConditionalPathPoint."""
    out = []
    for comp in peer.model.getComponentsList():
        if comp.getConcreteClassName() == "ConditionalPathPoint":
            point = osim.ConditionalPathPoint.safeDownCast(comp)
            coord = point.getConnectee("coordinate").getName()
            out.append((coord, point.get_range(0), point.get_range(1)))
    return out


def _poses(peer: Peer, rng: np.random.Generator) -> list[tuple[str, dict]]:
    ranges = peer.ranges()
    poses: list[tuple[str, dict]] = []

    def random_pose() -> dict:
        q = {n: rng.uniform(*ranges[n]) for n in JOINT_COORDS}
        q["pelvis_tilt"] = rng.uniform(-0.5, 0.5)
        q["pelvis_tx"] = rng.uniform(-1.0, 1.0)
        q["pelvis_ty"] = rng.uniform(0.7, 1.1)
        return q

    for _ in range(140):
        poses.append(("random", random_pose()))
    # 0.01 rad inside and outside each ConditionalPathPoint range boundary that lies inside the
    # coordinate's range (both sides, other coordinates random).
    for coord, lo, hi in sorted(set(_conditional_points(peer))):
        cmin, cmax = ranges[coord]
        for bound in (lo, hi):
            for offset in (-0.01, 0.01):
                value = bound + offset
                if cmin <= value <= cmax:
                    for _ in range(2):
                        q = random_pose()
                        q[coord] = value
                        poses.append(("conditional", q))
    # Both knees across their range (MovingPathPoints of rect_fem and vasti).
    n_sweep = 200 - len(poses)
    lo, hi = ranges["knee_angle_r"]
    for value in np.linspace(lo, hi, n_sweep):
        q = random_pose()
        q["knee_angle_r"] = value
        q["knee_angle_l"] = lo + hi - value
        poses.append(("knee_sweep", q))
    return poses


def muscle_geometry(peer: Peer, rng: np.random.Generator) -> tuple[list[str], list[list]]:
    poses = _poses(peer, rng)
    arms = {}
    for _, q in poses:
        peer.set(q)
        for m in peer.muscles:
            for c in JOINT_COORDS:
                arms[(m.getName(), c)] = max(
                    arms.get((m.getName(), c), 0.0),
                    abs(m.computeMomentArm(peer.state, peer.by_name[c])),
                )
    spans = {
        m.getName(): [c for c in JOINT_COORDS if arms[(m.getName(), c)] > 1e-9]
        for m in peer.muscles
    }
    header = ["pose", "kind", *peer.names]
    for m in peer.muscles:
        header.append(f"{m.getName()}.length")
        header += [f"{m.getName()}.moment_arm.{c}" for c in spans[m.getName()]]
    rows = []
    for i, (kind, q) in enumerate(poses):
        peer.set(q)
        row = [str(i), kind, *[q.get(n, 0.0) for n in peer.names]]
        for m in peer.muscles:
            row.append(m.getLength(peer.state))
            row += [
                m.computeMomentArm(peer.state, peer.by_name[c]) for c in spans[m.getName()]
            ]
        rows.append(row)
    return header, rows


FORCE_OUTPUTS = (
    "tendon_force", "fiber_length", "normalized_fiber_length", "fiber_velocity",
    "normalized_fiber_velocity", "active_force_length_multiplier",
    "force_velocity_multiplier", "passive_force_multiplier", "pennation_angle",
    "active_fiber_force", "passive_fiber_elastic_force", "passive_fiber_damping_force",
    "fiber_force",
)


def muscle_force(peer: Peer, rng: np.random.Generator) -> tuple[list[str], list[list]]:
    ranges = peer.ranges()
    header = [
        "state", "muscle", *peer.names, *[f"{n}.speed" for n in peer.names], "activation",
        "length", "lengthening_speed", *FORCE_OUTPUTS,
    ]
    rows = []
    for k in range(30):
        q = {n: rng.uniform(*ranges[n]) for n in JOINT_COORDS}
        # Isometric states first, then joint speeds up to 4 and 12 rad/s (fibre speeds
        # beyond max_contraction_velocity on the faster ones).
        scale = 0.0 if k < 4 else (4.0 if k < 18 else 12.0)
        u = {n: scale * rng.uniform(-1.0, 1.0) for n in JOINT_COORDS}
        activations = rng.uniform(0.0, 1.0, len(peer.muscles))
        if k == 0:
            activations[:] = 0.0
        peer.set(q, u)
        for m, a in zip(peer.muscles, activations, strict=True):
            m.setActivation(peer.state, float(a))
        peer.model.realizeDynamics(peer.state)
        for m in peer.muscles:
            values = [
                m.getTendonForce(peer.state), m.getFiberLength(peer.state),
                m.getNormalizedFiberLength(peer.state), m.getFiberVelocity(peer.state),
                m.getNormalizedFiberVelocity(peer.state),
                m.getActiveForceLengthMultiplier(peer.state),
                m.getForceVelocityMultiplier(peer.state),
                m.getPassiveForceMultiplier(peer.state), m.getPennationAngle(peer.state),
                m.getActiveFiberForce(peer.state), m.getPassiveFiberElasticForce(peer.state),
                m.getPassiveFiberDampingForce(peer.state), m.getFiberForce(peer.state),
            ]
            rows.append([
                str(k), m.getName(), *[q.get(n, 0.0) for n in peer.names],
                *[u.get(n, 0.0) for n in peer.names], m.getActivation(peer.state),
                m.getLength(peer.state), m.getLengtheningSpeed(peer.state), *values,
            ])
    return header, rows


def _sphere(force):
    sphere = osim.ContactSphere.safeDownCast(force.getConnectee("sphere"))
    return sphere, sphere.getFrame()


def _set_height(peer: Peer, force, q: dict, u: dict, height: float) -> None:
    """Move pelvis_ty until the sphere centre is at ``height`` (the PlanarJoint translation
    is along ground Y, so one step is exact; iterate to be sure)."""
    sphere, frame = _sphere(force)
    q = dict(q)
    for _ in range(20):
        peer.set(q, u)
        y = frame.findStationLocationInGround(peer.state, sphere.get_location()).get(1)
        if abs(y - height) < 1e-14:
            break
        q["pelvis_ty"] += height - y
    peer.set(q, u)
    return q


def contact_force(peer: Peer, rng: np.random.Generator) -> tuple[list[str], list[list]]:
    header = [
        "force", "body", "radius", "kind", *peer.names, *[f"{n}.speed" for n in peer.names],
        "center_x", "center_y", "center_z", "center_vx", "center_vy", "center_vz",
        "omega_x", "omega_y", "omega_z", "origin_x", "origin_y", "origin_z", "penetration",
        "force_x", "force_y", "force_z", "torque_x", "torque_y", "torque_z",
    ]
    depths = (-0.01, -0.005, -0.002, -0.001, -0.0003, 0.0, 0.0003, 0.001, 0.002, 0.005,
              0.01, 0.015, 0.02)
    # (penetration rate = -vy, slip = vx), m/s: normal speed both signs incl. the
    # Hunt-Crossley cut-off at -2/(3 c) = -1/3 m/s; slip both signs, below and above the
    # 0.2 m/s transition velocity.
    motions = ((0.0, 0.0), (0.1, 0.0), (-0.1, 0.0), (-0.3, 0.0), (-0.4, 0.0), (0.5, 0.05),
               (0.0, 0.1), (0.0, -0.1), (0.05, 0.19), (-0.05, -0.21), (0.2, 0.5),
               (0.0, -1.0), (0.3, 0.02), (-0.2, -0.005))
    rows = []
    for force in peer.contacts:
        sphere, frame = _sphere(force)
        radius = sphere.getRadius()
        body = frame.findBaseFrame().getName()
        cases = [("translation", d, {"pelvis_tx": vx, "pelvis_ty": -rate}, {})
                 for d in depths for rate, vx in motions]
        for _ in range(24):
            q = {"pelvis_tilt": rng.uniform(-0.3, 0.3)}
            side = "r" if body.endswith("_r") else "l"
            q[f"ankle_angle_{side}"] = rng.uniform(-0.4, 0.3)
            u = {"pelvis_tx": rng.uniform(-1.0, 1.0), "pelvis_ty": rng.uniform(-0.5, 0.5),
                 "pelvis_tilt": rng.uniform(-3.0, 3.0),
                 f"ankle_angle_{side}": rng.uniform(-6.0, 6.0)}
            cases.append(("rotation", rng.uniform(-0.005, 0.02), u, q))
        for kind, depth, u, q0 in cases:
            q = _set_height(peer, force, {"pelvis_ty": 0.0, **q0}, u, radius - depth)
            peer.model.realizeDynamics(peer.state)
            state = peer.state
            centre = frame.findStationLocationInGround(state, sphere.get_location())
            vcentre = frame.findStationVelocityInGround(state, sphere.get_location())
            base = frame.findBaseFrame()
            omega = base.getVelocityInGround(state).get(0)
            origin = base.getPositionInGround(state)
            record = force.getRecordValues(state)
            values = [record.get(i) for i in range(6)]
            rows.append([
                force.getName(), body, radius, kind, *[q.get(n, 0.0) for n in peer.names],
                *[u.get(n, 0.0) for n in peer.names], *_vec(centre), *_vec(vcentre),
                *_vec(omega), *_vec(origin), radius - centre.get(1), *values,
            ])
    return header, rows


def model_frames(peer: Peer, rng: np.random.Generator) -> tuple[list[str], list[list]]:
    ranges = peer.ranges()
    header = ["pose", "kind", "name", *peer.names, "x", "y", "z", "com_x", "com_y", "com_z",
              "mass", *[f"r{i}{j}" for i in range(3) for j in range(3)]]
    identity = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
    poses = [{}]
    for _ in range(5):
        q = {n: rng.uniform(*ranges[n]) for n in JOINT_COORDS}
        q.update(pelvis_tilt=rng.uniform(-0.5, 0.5), pelvis_tx=rng.uniform(-1.0, 1.0),
                 pelvis_ty=rng.uniform(0.7, 1.1))
        poses.append(q)
    rows = []
    for k, q in enumerate(poses):
        peer.set(q)
        state = peer.state
        qv = [q.get(n, 0.0) for n in peer.names]
        for body in peer.model.getBodySet():
            rot = body.getTransformInGround(state).R()
            com = body.findStationLocationInGround(state, body.getMassCenter())
            rows.append([
                str(k), "body", body.getName(), *qv, *_vec(body.getPositionInGround(state)),
                *_vec(com), body.getMass(), *[rot.get(i, j) for i in range(3) for j in range(3)],
            ])
        for force in peer.contacts:
            sphere, frame = _sphere(force)
            centre = frame.findStationLocationInGround(state, sphere.get_location())
            rows.append([str(k), "sphere", sphere.getName(), *qv, *_vec(centre), *_vec(centre),
                         0.0, *identity])
        com = peer.model.calcMassCenterPosition(state)
        rows.append([str(k), "model", peer.model.getName(), *qv, *_vec(com), *_vec(com),
                     peer.model.getTotalMass(state), *identity])
    return header, rows


CONTACT_PROPERTIES = (
    "stiffness", "dissipation", "static_friction", "dynamic_friction", "viscous_friction",
    "transition_velocity", "constant_contact_force", "hertz_smoothing",
    "hunt_crossley_smoothing",
)


def contact_parameters(peer: Peer, rng: np.random.Generator) -> tuple[list[str], list[list]]:
    del rng
    header = ["force", "sphere", "body", "radius", "location_x", "location_y", "location_z",
              *CONTACT_PROPERTIES]
    rows = []
    for force in peer.contacts:
        sphere, frame = _sphere(force)
        values = [getattr(force, f"get_{name}")() for name in CONTACT_PROPERTIES]
        rows.append([force.getName(), sphere.getName(), frame.findBaseFrame().getName(),
                     sphere.getRadius(), *_vec(sphere.get_location()), *values])
    return header, rows


def gait_contact(peer: Peer, rng: np.random.Generator, solution: Path | None = None):
    """Every second state of a Moco solution, each sphere's kinematics and contact force."""
    del rng
    if solution is None:
        raise SystemExit("gait_contact needs --moco-solution PATH (a Moco solution .sto)")
    table = osim.TimeSeriesTable(str(solution))
    labels = list(table.getColumnLabels())
    paths = {c.getName(): c.getAbsolutePathString() for c in peer.coords}
    header = ["time", *peer.names, *[f"{n}.speed" for n in peer.names]]
    for force in peer.contacts:
        header += [f"{force.getName()}.{k}" for k in (
            "center_x", "center_y", "center_z", "center_vx", "center_vy", "center_vz",
            "omega_x", "omega_y", "omega_z", "force_x", "force_y", "force_z")]
    times = table.getIndependentColumn()
    rows = []
    for i in range(0, table.getNumRows(), 2):
        row = table.getRowAtIndex(i)
        value = {n: row[labels.index(f"{paths[n]}/value")] for n in peer.names}
        speed = {n: row[labels.index(f"{paths[n]}/speed")] for n in peer.names}
        peer.set(value, speed)
        out = [times[i], *value.values(), *speed.values()]
        for force in peer.contacts:
            sphere, frame = _sphere(force)
            record = force.getRecordValues(peer.state)
            out += [*_vec(frame.findStationLocationInGround(peer.state, sphere.get_location())),
                    *_vec(frame.findStationVelocityInGround(peer.state, sphere.get_location())),
                    *_vec(frame.findBaseFrame().getVelocityInGround(peer.state).get(0)),
                    *[record.get(k) for k in range(3)]]
        rows.append(out)
    return header, rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", type=Path, default=DEFAULT_MODEL)
    parser.add_argument("--tables", default=",".join(TABLES[:-1]))
    parser.add_argument("--moco-solution", type=Path, default=None)
    args = parser.parse_args()
    peer = Peer(args.model)
    builders = {"muscle_geometry": muscle_geometry, "muscle_force": muscle_force,
                "contact_force": contact_force, "model_frames": model_frames,
                "contact_parameters": contact_parameters,
                "gait_contact": lambda p, r: gait_contact(p, r, args.moco_solution)}
    for name in args.tables.split(","):
        # One generator per table, so regenerating one table leaves the others unchanged.
        rng = np.random.default_rng([SEED, TABLES.index(name)])
        header, rows = builders[name](peer, rng)
        write_table(HERE / f"{name}.csv", header, rows)
        print(f"{name}.csv: {len(rows)} rows x {len(header)} columns")


if __name__ == "__main__":
    main()
