"""Is a predicted planar gait human? Checks of issue 26 item 5 against measured walking.

Every curve is taken from its own right heel strike and resampled on 0..100 % of the
stride (101 points). Hip flexion is the thigh against the trunk on both sides of every
comparison (the predicted one from :func:`predgait.kinematics.osim2d_angles.leg_angles_deg`).
Measured normal gait:

* ``subject01``: the bundled OpenSim Gait2354 walk (:mod:`predgait.simulations.
  gait7_motion`, hinge-consistent IK): the stride between its first two right heel
  strikes; hip = thigh against the trunk (HAT), knee, ankle as gait7 measures them.
* ``winter``: Winter (2009) Appendix A Table A.1 markers, stride frames 28 -> 97 (his
  right heel contacts): hip = thigh (hip -> knee) against the trunk (rib cage -> hip),
  knee = thigh against shank (fibula head -> malleolus), ankle = foot (heel -> MT5)
  against the shank's perpendicular, minus its value at heel strike (Winter's ankle is
  near neutral at heel contact; the marker offset is otherwise unknown).

Checks (bound, source): hip, knee, ankle r >= 0.85 and RMS <= 8 deg against each;
loading-response knee flexion (:func:`loading_response_flexion`: the knee's flexion from
heel strike to its peak in the first 20 % of the stride) >= 8 deg (normal 15-20 deg,
Perry 1992; subject01 19.8, Winter 17.1); ankle at right toe-off <= -5 deg (plantarflexed;
normal about -20 deg); vertical GRF <= 1.5 BW with a mid-stance trough below both peaks; slip of the
loaded foot's contact points <= 2 cm per stride.
"""

from __future__ import annotations

import numpy as np

from predgait.analysis.plausibility import Check

__all__ = ["Check", "human_checks", "measured_curves"]
JOINTS = ("hip", "knee", "ankle")
#: Stride percentages of the loading response window for the knee's first flexion peak.
LOADING_RESPONSE = (0.0, 20.0)
MIN_R = 0.85
MAX_RMS_DEG = 8.0
MIN_LOADING_KNEE_DEG = 8.0
MAX_TOE_OFF_ANKLE_DEG = -5.0
MAX_VERTICAL_GRF_BW = 1.5
MAX_SLIP_M = 0.02
PERCENT = np.linspace(0.0, 100.0, 101)
#: Winter's Table A.1: right heel contact frames (1-based) of one stride.
WINTER_STRIDE = (28, 97)


def resample_stride(t: np.ndarray, values: np.ndarray) -> np.ndarray:
    """(101, ...) values on 0..100 % of the stride t[0]..t[-1]."""
    s = 100.0 * (t - t[0]) / (t[-1] - t[0])
    values = np.asarray(values, float)
    return np.stack([np.interp(PERCENT, s, values[:, i]) for i in range(values.shape[1])],
                    axis=1) if values.ndim == 2 else np.interp(PERCENT, s, values)


def subject01_curves() -> dict[str, np.ndarray]:
    """Right hip flexion, knee flexion, ankle dorsiflexion (deg, 101 points) of subject01."""
    from predgait.dynamics.gait7_motion import bundled_gait7_motion, gait7_model
    from predgait.kinematics.clinical import clinical_joint

    model = gait7_model(72.6, 1.8034)
    motion = bundled_gait7_motion(model)
    start, end = motion.heel_strikes["right"][:2]
    names = model.coordinate_names
    keep = (motion.time >= start - 0.05) & (motion.time <= end + 0.05)
    t = motion.time[keep]
    q = np.degrees(motion.q[keep])
    grid = np.linspace(start, end, 201)
    curves = {j: clinical_joint(model, f"{j}_r").clinical(q[:, names.index(f"{j}_r")])
              for j in JOINTS}
    return {k: resample_stride(grid, np.interp(grid, t, v)) for k, v in curves.items()}


def _angle(u: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Signed angle from u to w in the sagittal plane (X forward, Y up), deg."""
    cross = u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0]
    return np.degrees(np.arctan2(cross, (u * w).sum(axis=1)))


def winter_curves() -> dict[str, np.ndarray]:
    """Right hip, knee, ankle (deg, 101 points) from Winter's Table A.1 markers."""
    from predgait.data import load_winter_a1, lowpass

    markers = load_winter_a1()
    xyz = lowpass(markers.xyz, markers.rate, 6.0)
    first, last = (f - 1 for f in WINTER_STRIDE)

    def point(label: str) -> np.ndarray:
        index = next(i for i, n in enumerate(markers.names) if label in n.upper())
        return xyz[first:last + 1, index][:, [0, 2]]   # lab X forward, Z up

    rib, hip, knee = point("RIB"), point("HIP"), point("KNEE")
    fibula, ankle, heel, mt5 = point("FIBULA"), point("ANKLE"), point("HEEL"), point("MT5")
    trunk_down, thigh, shank = hip - rib, knee - hip, ankle - fibula
    hip_flexion = _angle(trunk_down, thigh)       # thigh ahead of the trunk line: flexion
    knee_flexion = _angle(shank, thigh)
    foot = mt5 - heel
    ankle = _angle(shank, foot) - 90.0           # toes up: dorsiflexion
    ankle -= ankle[0]
    t = np.arange(first, last + 1) / markers.rate
    return {"hip": resample_stride(t, hip_flexion), "knee": resample_stride(t, knee_flexion),
            "ankle": resample_stride(t, ankle)}


def measured_curves() -> dict[str, dict[str, np.ndarray]]:
    """Measured curves, source -> joint -> (101,) deg: subject01 and Winter."""
    return {"subject01": subject01_curves(), "winter": winter_curves()}


def loading_response_flexion(knee: np.ndarray) -> float:
    """Knee flexion during loading response, deg.

    The peak of the (101,) knee flexion curve in :data:`LOADING_RESPONSE` minus its value at
    heel strike (0 when the knee only extends).
    """
    window = (PERCENT >= LOADING_RESPONSE[0]) & (PERCENT <= LOADING_RESPONSE[1])
    return float(np.asarray(knee)[window].max() - knee[0])


def curve_agreement(predicted: dict[str, np.ndarray], measured: dict[str, np.ndarray]
                    ) -> dict[str, dict[str, float]]:
    """Agreement per joint, {"r", "rms_deg"}, between two sets of (101,) curves."""
    return {j: {"r": float(np.corrcoef(predicted[j], measured[j])[0, 1]),
                "rms_deg": float(np.sqrt(np.mean((predicted[j] - measured[j]) ** 2)))}
            for j in JOINTS}


def human_checks(curves: dict[str, np.ndarray], *, toe_off_percent: float,
                 vertical_grf_bw: dict, slip_m: float,
                 measured: dict[str, dict[str, np.ndarray]] | None = None) -> list[Check]:
    """The checks of a predicted stride (right leg, from its heel strike).

    Args:
        curves: joint -> (101,) deg, hip flexion, knee flexion, ankle dorsiflexion.
        toe_off_percent: right toe-off, % of the stride.
        vertical_grf_bw: right foot's ``peak_bw``, ``loading_peak_bw``, ``valley_bw``,
            ``push_off_peak_bw``.
        slip_m: the larger loaded-foot slip of the two feet, m per stride.
        measured: source -> joint -> (101,) deg (default :func:`measured_curves`).
    """
    measured = measured_curves() if measured is None else measured
    checks = []
    for source, reference in measured.items():
        for joint, numbers in curve_agreement(curves, reference).items():
            checks.append(Check(f"{joint} r vs {source}", numbers["r"], f">= {MIN_R:g}",
                                source, numbers["r"] >= MIN_R))
            checks.append(Check(f"{joint} RMS vs {source}", numbers["rms_deg"],
                                f"<= {MAX_RMS_DEG:g} deg", source,
                                numbers["rms_deg"] <= MAX_RMS_DEG))
    loading = loading_response_flexion(curves["knee"])
    checks.append(Check("loading-response knee flexion", loading,
                        f">= {MIN_LOADING_KNEE_DEG:g} deg", "Perry 1992 (15-20 deg)",
                        loading >= MIN_LOADING_KNEE_DEG))
    ankle = float(np.interp(toe_off_percent, PERCENT, curves["ankle"]))
    checks.append(Check("ankle at toe-off", ankle, f"<= {MAX_TOE_OFF_ANKLE_DEG:g} deg",
                        "Winter 2009 (about -20 deg)", ankle <= MAX_TOE_OFF_ANKLE_DEG))
    g = vertical_grf_bw
    checks.append(Check("vertical GRF peak", g["peak_bw"], f"<= {MAX_VERTICAL_GRF_BW:g} BW",
                        "subject01 1.07 BW", g["peak_bw"] <= MAX_VERTICAL_GRF_BW))
    lower_peak = min(g["loading_peak_bw"], g["push_off_peak_bw"])
    checks.append(Check("vertical GRF mid-stance trough", g["valley_bw"],
                        f"< both peaks ({lower_peak:.2f} BW) - 0.05", "double-hump vertical GRF",
                        g["valley_bw"] < lower_peak - 0.05))
    checks.append(Check("loaded-foot slip per stride", slip_m, f"<= {MAX_SLIP_M:g} m",
                        "issue 26", slip_m <= MAX_SLIP_M))
    return checks
