"""``kind = "fullbody_tracking"``: the whole body made dynamically consistent, then held.

Problem file (problems/fullbody_tracking.toml): ``[trial]`` and ``[contact]`` as in
``kind = "fullbody"`` (:mod:`predgait.workflows.forward3d_spec`), ``[window]`` (start,
end in trial time; default the first right gait cycle), ``[weights]``
(:class:`~predgait.problems.fullbody_tracking.TrackingWeights`), ``[solver]`` and
``[feedback]`` (:data:`~predgait.dynamics.floating_lqr.FLOATING_WEIGHTS`, the RK4 step
of the re-simulation).

Steps: whole-body IK + ID of the trial, the tracking problem on the marker frames of the
window (:mod:`predgait.problems.fullbody_tracking`), then the forward engine
re-simulating the free body on its contact law from the solution's first state, driven
by the solved joint torques, with and without the time-varying LQR feedback
(:mod:`predgait.simulations.fullbody_feedback`).

Files: ``kinematics3d.sto`` (corrected pelvis position m, pelvis Cardan angles and joint
angles deg), ``corrected_moments3d.sto`` (joint torques N m, pelvis residual),
``contact_forces.sto`` (N on each sole point), ``feedback_gains.npz`` (times, gains
K(t) (m, 29, 70) float32 on the state error (pin.difference(q_ref, q), v - v_ref), the
reference), ``resimulated_kinematics3d.sto`` (the run with feedback), ``summary.json``,
``tracking.png`` and the stick figure.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from predgait.dynamics.floating_lqr import FLOATING_WEIGHTS
from predgait.dynamics.lqr import BrysonWeights
from predgait.errors import InputError
from predgait.models.fullbody import BALLS, CONTACTS, SOLE_EDGES
from predgait.problemfile import Table
from predgait.problems.fullbody_tracking import (
    TrackingData,
    TrackingSolution,
    TrackingWeights,
    point_positions,
)
from predgait.problems.fullbody_tracking_stage import point_feet
from predgait.simulations.forward3d import (
    ContactSettings,
    FullbodyDrive,
    ground_source,
    measured_ground,
)
from predgait.workflows.forward3d_spec import TrialSpec, parse_contact, parse_trial

#: Plate force above which a foot is loaded, N.
LOAD_THRESHOLD = 20.0


@dataclass(frozen=True)
class TrackingSpec:
    """A parsed ``fullbody_tracking`` problem."""

    trial: TrialSpec
    contact: ContactSettings
    window: tuple[float, float] | None
    weights: TrackingWeights
    contact_height: float
    stride: int
    fade_nodes: int
    max_iter: int
    feedback: BrysonWeights
    step: float
    source: str
    solver: str = "ipopt"
    convex_iterations: int = 0


def parse_tracking(table: Table) -> TrackingSpec:
    """TrackingSpec from a problem file (errors name the file, key and line)."""
    table.check_keys(("kind", "trial", "contact", "window", "weights", "solver", "feedback"))
    window = table.table("window")
    window.check_keys(("start", "end", "contact_height", "stride", "fade_nodes"))
    start = window.number("start", None, low=0, unit="s")
    end = window.number("end", None, low=0, unit="s")
    if (start is None) != (end is None):
        raise window.error("start", "give both start and end (s, trial time) or neither "
                                    "(the first right gait cycle).")
    if start is not None and end <= start:
        raise window.error("end", f"end {end:g} s is not after start {start:g} s.")
    weights = table.table("weights")
    defaults = TrackingWeights()
    weights.check_keys(tuple(vars(defaults)))
    solver = table.table("solver")
    solver.check_keys(("max_iter", "name", "convex_iterations"))
    name = solver.get("name", str, "ipopt")
    if name not in ("ipopt", "fatrop"):
        raise solver.error("name", f"{name!r}: use \"ipopt\" (default) or \"fatrop\".")
    feedback = table.table("feedback")
    fb = {k: v for k, v in vars(FLOATING_WEIGHTS).items() if v is not None}
    feedback.check_keys((*fb, "step"))
    contact = parse_contact(table)
    unknown = [f for f in contact.frames if f not in CONTACTS + SOLE_EDGES + BALLS]
    if unknown:
        raise table.table("contact").error(
            "frames", f"{', '.join(map(repr, unknown))}: not a sole point of the body; "
            f"use some of {', '.join(CONTACTS + SOLE_EDGES + BALLS)}.")
    return TrackingSpec(
        trial=parse_trial(table), contact=contact,
        window=None if start is None else (start, end),
        weights=TrackingWeights(**{k: weights.number(k, v, low=1e-9)
                                   for k, v in vars(defaults).items()}),
        contact_height=window.number("contact_height", 0.03, low=0.0, high=0.2, unit="m"),
        stride=int(window.number("stride", 1, low=1, high=50)),
        fade_nodes=int(window.number("fade_nodes", 3, low=0, high=50)),
        max_iter=int(solver.number("max_iter", 200, low=1, high=5000)),
        feedback=replace(FLOATING_WEIGHTS, **{k: feedback.number(k, v, low=1e-6)
                                              for k, v in fb.items()}),
        step=feedback.number("step", 1e-4, low=1e-6, high=5e-3, unit="s"),
        source=str(table.path), solver=name,
        convex_iterations=int(solver.number("convex_iterations", 0, low=0, high=5000)))


def gait_cycle(drive: FullbodyDrive, stances) -> tuple[float, float]:
    """First right gait cycle: heel strike to the next right heel strike, s."""
    starts = sorted(s.start for s in stances if s.side == "r" and s.start > drive.time[0])
    if len(starts) < 2:
        raise InputError(f"{drive.source}: fewer than two right heel strikes on the plates; "
                         "give [window] start and end.")
    return starts[0], starts[1]


def foot_cop(drive: FullbodyDrive, plate_z: float) -> tuple[np.ndarray, np.ndarray,
                                                             np.ndarray]:
    """Each foot's plate force (n, 2, 3) N, COP (n, 2, 3) m on z = plate_z, free moment (n, 2).

    From the foot wrench about the origin (F, M): M = cop x F + T e_z.
    """
    n = drive.time.size
    force, cop, free = np.zeros((n, 2, 3)), np.zeros((n, 2, 3)), np.zeros((n, 2))
    for j, side in enumerate("rl"):
        wrench = drive.foot_wrench[side]
        f, m = wrench[:, :3], wrench[:, 3:]
        on = f[:, 2] > 1.0
        fz = np.where(on, f[:, 2], 1.0)
        x = np.where(on, (plate_z * f[:, 0] - m[:, 1]) / fz, np.nan)
        y = np.where(on, (m[:, 0] + plate_z * f[:, 1]) / fz, np.nan)
        force[:, j] = f
        cop[:, j] = np.column_stack([x, y, np.full(n, plate_z)])
        free[:, j] = np.where(on, m[:, 2] - (x * f[:, 1] - y * f[:, 0]), 0.0)
    # Unloaded feet: COP anywhere (its moment is multiplied by zero force); keep finite.
    return force, np.nan_to_num(cop), free


def foot_cop_from_points(model, q: np.ndarray, forces: np.ndarray, points, plate_z: float
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each foot's force (n, 2, 3) N, COP (n, 2, 3) and free moment (n, 2) N m from points.

    From lab forces (n, P, 3) on the sole ``points`` at the configurations q (n, 36): what
    plates with their surface at z = plate_z (m) under each foot would measure (COP 0
    under an unloaded foot).
    """
    n = q.shape[0]
    feet = np.array(point_feet(tuple(points)))
    xyz = point_positions(model, q, tuple(points))
    force, cop, free = np.zeros((n, 2, 3)), np.zeros((n, 2, 3)), np.zeros((n, 2))
    for j in (0, 1):
        total = forces[:, feet == j].sum(axis=1)
        moment = np.cross(xyz[:, feet == j], forces[:, feet == j]).sum(axis=1)
        fz = np.where(total[:, 2] > 1e-9, total[:, 2], np.inf)
        x = (plate_z * total[:, 0] - moment[:, 1]) / fz
        y = (moment[:, 0] + plate_z * total[:, 1]) / fz
        force[:, j] = total
        cop[:, j] = np.column_stack([x, y, np.full(n, plate_z)])
        free[:, j] = np.where(np.isfinite(fz), moment[:, 2] - (x * total[:, 1] - y * total[:, 0]),
                              0.0)
    return force, cop, free


def tracking_data(drive: FullbodyDrive, plate_z: float, window: tuple[float, float], *,
                  contact: ContactSettings, contact_height: float = 0.03,
                  stride: int = 1, fade_nodes: int = 3) -> TrackingData:
    """The problem's nodes (every ``stride``-th marker frame of ``window``, s), what they track.

    The contact points are ``contact.frames``. A sole point is in contact when its foot
    is loaded (plate force above :data:`LOAD_THRESHOLD`) and its measured height is
    within ``contact_height`` (m) of the floor
    (:func:`~predgait.simulations.forward3d.measured_ground`). The measured joint
    moments (the drive's inverse dynamics) are the torque cost's target.

    The foot-moment cost is taken about the plates' COP on the contacts' floor: the
    point where each plate's line of action meets z = floor (issue 27). The plates'
    wrench is unchanged (the same force, and about any point the same moment); only the
    point moves, from the plates' COP plane ``plate_z`` (m, reported) to the plane the
    model's soles stand on. On subject01 the floor (median lowest sole point, 0.0293 m)
    lies 36.8 mm above the plates' COP plane (-0.0075 m): the marker-placed soles are
    that far above the plates (shoe soles), and no still loaded frame sets them onto the
    plates (foot flat), so the floor stays the soles' and the moment comes to it.
    """
    points = tuple(contact.frames)
    feet = list(point_feet(points))
    ground_z, belt = measured_ground(drive, points, threshold=LOAD_THRESHOLD)
    source = ground_source(drive)
    if contact.ground_z is not None:
        ground_z, source = contact.ground_z, "[contact] ground_z"
    belt = belt if contact.belt_velocity is None else contact.belt_velocity
    keep = np.flatnonzero((drive.time >= window[0] - 1e-9) & (drive.time <= window[1] + 1e-9))
    keep = keep[::stride]
    heights = point_positions(drive.model, drive.q[keep], points)[:, :, 2]
    force, cop, free = foot_cop(drive, ground_z)
    loaded = force[keep][:, feet, 2] > LOAD_THRESHOLD
    law = contact.contact
    return TrackingData(drive.time[keep], drive.q[keep], drive.v[keep], drive.a[keep],
                        loaded & (heights < ground_z + contact_height), force[keep],
                        cop[keep], free[keep], ground_z, belt, stiffness=law.stiffness,
                        friction=law.friction, slip_transition=law.slip_transition,
                        points=points, tau=drive.tau[keep, 6:], fade_nodes=fade_nodes,
                        floor_source=source, plate_z=plate_z)


def plate_height(inverse) -> float:
    """Median COP height of the loaded plate samples, m (the floor of the plates)."""
    heights = [p.cop[p.force[:, 2] > LOAD_THRESHOLD, 2] for p in inverse.plates]
    heights = np.concatenate(heights) if heights else np.zeros(1)
    return float(np.median(heights)) if heights.size else 0.0


#: The sagittal joints of the issue-27 yardstick (corrected against measured moments).
SAGITTAL = ("hip_r_y", "hip_l_y", "knee_r_y", "knee_l_y", "ankle_r_y", "ankle_l_y")


def torque_deviation(model, data: TrackingData, solution: TrackingSolution) -> dict:
    """Corrected minus measured joint torques (``data.tau``), N m, per joint.

    ``rms_n_m``, ``peak_n_m`` (largest |corrected - measured|), ``node_change_n_m``
    (largest |tau_k+1 - tau_k| of the corrected torque) and ``measured_node_change_n_m``;
    ``spike_n_m``: the largest corrected |torque| above the measured peak of its joint;
    ``sagittal_rms_n_m_per_kg`` on :data:`SAGITTAL`; ``worst``: the joint and value of
    each measure's maximum.
    """
    names, mass = model.joint_names, model.total_mass()
    corrected, measured = solution.tau[:, 6:], data.tau
    error = corrected - measured

    def per_joint(values):
        return {n: float(values[i]) for i, n in enumerate(names)}

    out = {
        "rms_n_m": per_joint(np.sqrt(np.mean(error**2, axis=0))),
        "peak_n_m": per_joint(np.abs(error).max(axis=0)),
        "node_change_n_m": per_joint(np.abs(np.diff(corrected, axis=0)).max(axis=0)),
        "measured_node_change_n_m": per_joint(np.abs(np.diff(measured, axis=0)).max(axis=0)),
        "spike_n_m": per_joint(np.abs(corrected).max(axis=0) - np.abs(measured).max(axis=0)),
    }
    out["sagittal_rms_n_m_per_kg"] = {n: out["rms_n_m"][n] / mass for n in SAGITTAL}
    out["worst"] = {key: dict(zip(("joint", "value"), max(out[key].items(),
                                                          key=lambda item: item[1]),
                                  strict=True))
                    for key in ("rms_n_m", "peak_n_m", "node_change_n_m", "spike_n_m",
                                "sagittal_rms_n_m_per_kg")}
    return out


#: The joints that hold the pelvis in the sagittal plane.
PELVIS_SAGITTAL = ("hip_r_y", "hip_l_y", "lumbar_y")


def pelvis_moment_share(drive, data: TrackingData, solution: TrackingSolution) -> dict:
    """How much of the hips' and lumbar's correction the measured data force, N m RMS.

    The measured moments leave a pelvis residual (inverse dynamics: RNEA with the plates,
    rows 0-5, pelvis frame); the solution has none, so the corrections of the joints on
    the pelvis, summed over :data:`PELVIS_SAGITTAL`, must cancel its sagittal moment My.
    ``residual_my``: RMS of My; ``correction_sum``: of the summed corrections;
    ``left``: of their sum + My (what the corrected motion and forces took up).
    """
    my = drive.tau[np.isin(drive.time, data.time), 4]
    names = drive.model.joint_names
    total = sum(solution.tau[:, 6 + names.index(n)] - data.tau[:, names.index(n)]
                for n in PELVIS_SAGITTAL)

    def rms(x):
        return float(np.sqrt(np.mean(x**2)))

    return {"residual_my": rms(my), "correction_sum": rms(total), "left": rms(total + my)}


def deviations(model, data: TrackingData, solution: TrackingSolution) -> dict:
    """How far the solution moved from the measured data (angles, GRF, COP)."""
    from predgait.kinematics.ik3d import pelvis_cardan

    joint_names, body_weight = model.joint_names, model.total_mass() * model.gravity
    points = point_positions(model, solution.q, solution.points)
    point_foot = np.array(point_feet(solution.points))

    joints = np.degrees(solution.q[:, 7:] - data.q[:, 7:])
    pelvis = np.degrees(pelvis_cardan(solution.q) - pelvis_cardan(data.q))
    feet = solution.foot_forces()
    grf = feet - data.force
    cop_shift = {}
    for j, side in enumerate("rl"):
        loaded = data.force[:, j, 2] > LOAD_THRESHOLD
        solved = feet[:, j, 2] > 1.0
        both = loaded & solved
        if not both.any():
            continue
        pts = points[:, point_foot == j]
        weights = solution.forces[:, point_foot == j, 2]
        cop = (pts[both] * weights[both, :, None]).sum(axis=1) / weights[both].sum(axis=1)[
            :, None]
        shift = np.linalg.norm((cop - data.cop[both, j])[:, :2], axis=1)
        cop_shift[side] = {"rms_m": float(np.sqrt(np.mean(shift**2))),
                           "max_m": float(shift.max())}
    return {
        "joint_rms_deg": {n: float(np.sqrt(np.mean(joints[:, i] ** 2)))
                          for i, n in enumerate(joint_names)},
        "all_joints_rms_deg": float(np.sqrt(np.mean(joints**2))),
        "pelvis_angle_rms_deg": {n: float(np.sqrt(np.mean(pelvis[:, i] ** 2)))
                                 for i, n in enumerate(("obliquity", "tilt", "rotation"))},
        "pelvis_position_rms_m": float(np.sqrt(np.mean(
            (solution.q[:, :3] - data.q[:, :3]) ** 2))),
        "grf_rms_percent_bw": {f"{side}_{axis}": float(
            100 * np.sqrt(np.mean(grf[:, j, i] ** 2)) / body_weight)
            for j, side in enumerate("rl") for i, axis in enumerate("xyz")},
        "grf_peak_difference_percent_bw": {f"{side}_z": float(
            100 * (feet[:, j, 2].max() - data.force[:, j, 2].max()) / body_weight)
            for j, side in enumerate("rl")},
        "cop_shift": cop_shift,
        "torque": None if data.tau is None else torque_deviation(model, data, solution),
    }
