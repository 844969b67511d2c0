"""Predicted vs baseline muscle-driven gait, and what published findings the change matches.

Each leg's curves start at that leg's own heel strike (the foot's vertical force rising
through :data:`~predgait.problems.muscle_gait_stride.STANCE_THRESHOLD_N`) and are resampled
to 0..100 % of the stride, so a change of timing is not taken for a change of shape.
Clinical signs: hip flexion (thigh vs trunk) and knee flexion (-knee_angle) positive,
ankle dorsiflexion positive (OpenSim's ankle_angle); :mod:`predgait.kinematics.osim2d_angles`.

:func:`finding` decides, from the numbers, whether the predicted change reproduces or
contradicts the published finding for the scenario's kind of edit:

* knee fused: Hanada E, Kerrigan DC (2001) Arch Phys Med Rehabil 82:1251-1254, about
  +23 % energy per distance with one knee immobilised in extension;
* ankle spring (AFO): Ploeger HE et al. (2019) Gait Posture 70:303-310 (stiff AFOs: 6-8
  deg less ankle motion), Vanderpool MT et al. (2008) Arch Phys Med Rehabil 89:1083 and
  Huang TP et al. (2015) J Biomech 48:2457 (restricting the ankle raises metabolic cost);
* plantarflexor weakness / contracture: Ong CF et al. (2019) PLOS Comput Biol
  15:e1006993 (severe weakness: heel walking, less push-off; contracture: toe walking
  with more stance hip and knee flexion);
* rectus femoris transfer: the operation's aim, more swing knee flexion (Delp SL et al.
  1994 J Biomech 27:1201; Asakawa DS et al. 2002/2004).
"""

from __future__ import annotations

import numpy as np

from predgait.kinematics.osim2d_angles import LEG_ANGLES, leg_angles_deg
from predgait.problems.muscle_gait_stride import STANCE_THRESHOLD_N

#: Joints compared (hip: thigh vs trunk; kinematics.osim2d_angles).
JOINTS = tuple(LEG_ANGLES)
#: Hanada & Kerrigan 2001: knee immobilised in extension, energy cost per distance, %.
HANADA_COST_PERCENT = 23.0
#: Ploeger et al. 2019: ankle motion lost with stiff AFOs, deg.
PLOEGER_RANGE_DEG = (6.0, 8.0)
#: A baseline whose peak swing knee flexion reaches this, deg, has no stiff-knee gait for a
#: rectus femoris transfer to relieve (normal 60-65 deg, Perry & Burnfield 2010, Gait
#: Analysis 2nd ed.; a stiff-knee gait is defined by a reduced, delayed peak; 55: our margin).
STIFF_KNEE_PEAK_DEG = 55.0


def _onset(fz: np.ndarray) -> int:
    on = fz > STANCE_THRESHOLD_N
    onsets = np.flatnonzero(on & ~np.roll(on, 1))
    return int(onsets[0]) if onsets.size else 0


def leg_measures(stride, plant, planar, side: str) -> dict:
    """Curves (101 samples, deg / BW) and measures of one leg from its own heel strike."""
    from predgait.analysis.human_likeness import loading_response_flexion, resample_stride

    column = 0 if side == "r" else 1
    fz_all = stride.foot_fz(plant)
    k = _onset(fz_all[:-1, column])
    n = stride.t.size - 1

    def rolled(values):
        body = np.asarray(values)[:-1]
        return np.concatenate([body[k:], body[:k + 1]])

    curves = {j: resample_stride(stride.t, rolled(c))
              for j, c in leg_angles_deg(planar, stride.q, side).items()}
    weight = plant.model.total_mass() * plant.model.gravity
    fz = resample_stride(stride.t, rolled(fz_all[:, column]) / weight)
    on = fz > STANCE_THRESHOLD_N / weight
    off = np.flatnonzero(on[:-1] & ~on[1:])
    toe_off = int(off[0] + 1) if off.size else 60
    names = [s.name for s in plant.spheres]
    own = [i for i, s in enumerate(names) if s.endswith(f"_{side}")]
    first = stride.grf[k % n:k % n + 3, own, 2].sum(axis=0)
    contact = names[own[int(np.argmax(first))]]
    stance = slice(0, max(toe_off, 2))
    return {"curves": curves, "vertical_grf_bw": fz, "toe_off_percent": toe_off,
            "initial_contact": "heel" if "heel" in contact.lower() else "forefoot",
            "ankle_at_initial_contact_deg": float(curves["ankle"][0]),
            "ankle_at_toe_off_deg": float(curves["ankle"][min(toe_off, 100)]),
            "min_ankle_deg": float(curves["ankle"].min()),
            "stance_mean_hip_flexion_deg": float(curves["hip"][stance].mean()),
            "stance_mean_knee_flexion_deg": float(curves["knee"][stance].mean()),
            "loading_knee_flexion_deg": loading_response_flexion(curves["knee"]),
            "swing_knee_flexion_peak_deg": float(curves["knee"][toe_off:].max()
                                                 if toe_off < 100 else curves["knee"].max()),
            "peak_vertical_grf_bw": float(fz.max()),
            "push_off_peak_bw": float(fz[max(toe_off // 2, 1):max(toe_off, 2)].max()),
            "ranges_deg": {j: float(c.max() - c.min()) for j, c in curves.items()}}


def cost_and_forces(pred) -> dict:
    """Bhargava 2004 cost of transport (J/kg/m) of the stride, effort, peak muscle forces."""
    from predgait.dynamics.metabolics import stride_cost_of_transport

    plant, stride = pred.plant, pred.stride
    mass = plant.model.total_mass()
    cot, _ = stride_cost_of_transport(stride, plant.muscle_set, plant.paths, body_mass=mass)
    fmax = np.array([m.max_isometric_force for m in plant.muscle_set.muscles])
    peak = stride.force.max(axis=0)
    return {"cost_of_transport_j_kg_m": float(cot), "effort": float(pred.gait.terms["effort"]),
            "peak_muscle_force_n": {n: float(f) for n, f in
                                    zip(plant.muscle_names, peak, strict=True)},
            "peak_muscle_force_fraction": {n: float(f) for n, f in
                                           zip(plant.muscle_names, peak / fmax, strict=True)}}


def _percent(new: float, old: float) -> float:
    return float(100.0 * (new / old - 1.0)) if old else float("nan")


def compare(baseline, edited) -> dict:
    """Predicted vs baseline: per leg, kinematics RMS change and ranges, GRF, cost, effort."""
    out = {"legs": {}, "baseline": cost_and_forces(baseline), "edited": cost_and_forces(edited)}
    for side in ("r", "l"):
        b = leg_measures(baseline.stride, baseline.plant, baseline.planar, side)
        e = leg_measures(edited.stride, edited.plant, edited.planar, side)
        scalars = [k for k in b if k not in ("curves", "vertical_grf_bw", "ranges_deg")]
        out["legs"][side] = {
            "rms_change_deg": {j: float(np.sqrt(np.mean((e["curves"][j] - b["curves"][j]) ** 2)))
                               for j in JOINTS},
            "range_deg": {j: {"baseline": b["ranges_deg"][j], "edited": e["ranges_deg"][j]}
                          for j in JOINTS},
            **{k: {"baseline": b[k], "edited": e[k]} for k in scalars}}
    bs, es = baseline.stride, edited.stride
    for name, get in (("speed_m_s", lambda s: s.distance / s.duration),
                      ("stride_length_m", lambda s: s.distance),
                      ("stride_time_s", lambda s: s.duration),
                      ("cadence_steps_min", lambda s: 120.0 / s.duration)):
        out[name] = {"baseline": float(get(bs)), "edited": float(get(es))}
    for key in ("cost_of_transport_j_kg_m", "effort"):
        out[f"{key.split('_j_')[0]}_change_percent"] = _percent(out["edited"][key],
                                                                out["baseline"][key])
    return out


def scenario_kind(edits) -> str | None:
    """The published-finding family of a scenario's edits (None: no claim)."""
    from predgait.scenarios.muscle_edits import (
        CoordinateLimit,
        JointSpring,
        MuscleEditKind,
        ParameterEdit,
        Transfer,
    )

    plantarflexors = ("soleus", "gastroc")
    for edit in edits:
        if isinstance(edit, CoordinateLimit) and edit.fused and "knee" in edit.coordinate:
            return "knee_fusion"
        if isinstance(edit, JointSpring) and "ankle" in edit.coordinate:
            return "afo"
        if isinstance(edit, Transfer) and edit.muscle.startswith("rect_fem"):
            return "rectus_transfer"
    for edit in edits:
        if isinstance(edit, ParameterEdit) and all(m.startswith(plantarflexors)
                                                   for m in edit.muscles):
            if edit.kind is MuscleEditKind.MAX_ISOMETRIC_FORCE and edit.scale < 1:
                return "plantarflexor_weakness"
            if edit.kind in (MuscleEditKind.PASSIVE_FIBER_STRAIN,
                             MuscleEditKind.TENDON_SLACK_LENGTH,
                             MuscleEditKind.OPTIMAL_FIBER_LENGTH):
                return "plantarflexor_contracture"
    return None


def finding(kind: str | None, c: dict) -> str:
    """ONE sentence: which published finding the predicted change reproduces or contradicts."""
    cost = c["cost_of_transport_change_percent"]
    right = c["legs"]["r"]
    if kind == "knee_fusion":
        if 0.5 * HANADA_COST_PERCENT <= cost <= 2.0 * HANADA_COST_PERCENT:
            verdict = "reproduces"
        elif cost > 0:
            verdict = "reproduces the direction, not the size, of"
        else:
            verdict = "contradicts"
        return (f"Cost of transport {cost:+.1f} % with the right knee fused: {verdict} "
                f"Hanada & Kerrigan 2001 (about +{HANADA_COST_PERCENT:.0f} % with one knee "
                "immobilised in extension).")
    if kind == "afo":
        rng = right["range_deg"]["ankle"]
        lost = rng["baseline"] - rng["edited"]
        ankle = "reproduces" if lost >= 3.0 else "contradicts"
        metab = "reproduces" if cost > 0 else "contradicts"
        return (f"Ankle range {lost:.1f} deg smaller ({ankle} Ploeger 2019's 6-8 deg with "
                f"stiff AFOs) and cost of transport {cost:+.1f} % ({metab} the rise "
                "Vanderpool 2008 / Huang 2015 measured with the ankle restricted).")
    if kind == "plantarflexor_weakness":
        heel = right["initial_contact"]["edited"] == "heel"
        push = (right["push_off_peak_bw"]["edited"] < right["push_off_peak_bw"]["baseline"]
                - 0.03)
        plantar = right["min_ankle_deg"]["edited"] > right["min_ankle_deg"]["baseline"] + 2.0
        verdict = ("reproduces" if heel and push and plantar else
                   "partly reproduces" if heel and (push or plantar) else "contradicts")
        return (f"Initial contact on the {right['initial_contact']['edited']}, push-off "
                "vertical GRF "
                f"{right['push_off_peak_bw']['baseline']:.2f} -> "
                f"{right['push_off_peak_bw']['edited']:.2f} BW, least ankle angle "
                f"{right['min_ankle_deg']['baseline']:+.1f} -> "
                f"{right['min_ankle_deg']['edited']:+.1f} deg: {verdict} Ong et al. 2019's "
                "heel walking without push-off under severe plantarflexor weakness (their "
                "slower speed is not testable here: the speed is imposed at "
                f"{c['speed_m_s']['edited']:.2f} m/s).")
    if kind == "plantarflexor_contracture":
        toe = (right["initial_contact"]["edited"] == "forefoot"
               or right["ankle_at_initial_contact_deg"]["edited"]
               < right["ankle_at_initial_contact_deg"]["baseline"] - 5.0)
        hip = (right["stance_mean_hip_flexion_deg"]["edited"]
               - right["stance_mean_hip_flexion_deg"]["baseline"])
        knee = (right["stance_mean_knee_flexion_deg"]["edited"]
                - right["stance_mean_knee_flexion_deg"]["baseline"])
        verdict = ("reproduces" if toe and hip > 0 and knee > 0 else
                   "partly reproduces" if toe or (hip > 0 and knee > 0) else "contradicts")
        return (f"Initial contact on the {right['initial_contact']['edited']} (ankle "
                f"{right['ankle_at_initial_contact_deg']['edited']:+.1f} deg, baseline "
                f"{right['ankle_at_initial_contact_deg']['baseline']:+.1f}), stance hip "
                f"flexion {hip:+.1f} deg and knee flexion {knee:+.1f} deg on average: "
                f"{verdict} Ong et al. 2019's toe walking with more stance hip and knee "
                "flexion under plantarflexor contracture.")
    if kind == "rectus_transfer":
        swing = right["swing_knee_flexion_peak_deg"]
        up = swing["edited"] - swing["baseline"]
        verdict = "reproduces" if up > 1.0 else "contradicts"
        limit = c.get("knee_flexion_limit_deg")
        bound = ("" if limit is None or swing["edited"] < limit - 0.5 else
                 f", both on the problem's {limit:.0f} deg knee bound (with "
                 "baseline.bounds.preset=physiological the knee may flex further)")
        premise = ("" if swing["baseline"] < STIFF_KNEE_PEAK_DEG else
                   f"; the baseline already flexes {swing['baseline']:.0f} deg in swing, no "
                   "stiff-knee gait for the transfer to relieve, so the operation's premise "
                   "is not tested")
        return (f"Peak swing knee flexion {swing['baseline']:.1f} -> {swing['edited']:.1f} "
                f"deg ({up:+.1f}{bound}): {verdict} the aim of the distal rectus femoris "
                "transfer (more swing knee flexion; Delp 1994's flexor moment arm, Asakawa "
                f"2002/2004){premise}.")
    return "No published finding is attached to these edits."
