"""Do two planar gait solutions agree? Right-leg kinematics from heel strike, RMS in deg.

Used for issue 26 item 6 (grids of 30, 50 and 75 intervals agree within 3 deg RMS; the
spread of a multi-start; two OpenBLAS kernels) and item 5's comparison with Moco's own
solution. Every solution is a periodic stride; its right heel strike is the time at which
the right foot's vertical force rises through :data:`STANCE_THRESHOLD_N`, found by linear
interpolation between nodes (not the first node above it: on a 16-interval half stride a
node is 3 % of the stride, which alone would be several degrees of "disagreement"), and
each curve is sampled on 0..100 % of the stride from that instant (101 points).

Angles (deg, OpenSim's signs made clinical): hip flexion = hip_flexion_r, knee flexion =
-knee_angle_r, ankle dorsiflexion = ankle_angle_r.
"""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np

from predgait.errors import InputError
from predgait.kinematics.clinical import clinical_joint

JOINTS = ("hip", "knee", "ankle")
#: A foot carrying more than this (N) is in stance (as muscle_gait_stride).
STANCE_THRESHOLD_N = 20.0
PERCENT = np.linspace(0.0, 100.0, 101)
#: OpenSim coordinate of each joint angle (its clinical sign: kinematics.clinical, osim2d).
COLUMNS = {"hip": "hip_flexion", "knee": "knee_angle", "ankle": "ankle_angle"}


def heel_strike_time(t: np.ndarray, fz: np.ndarray,
                     threshold: float = STANCE_THRESHOLD_N) -> float:
    """First upward crossing of ``threshold`` by the periodic ``fz`` (t[-1] = t[0] + T), s.

    Args:
        t: (n,) s, a whole period (the last row repeats the first one).
        fz: (n,) N, the right foot's vertical force.
        threshold: N, the stance threshold.
    """
    body_t, body = np.asarray(t, float)[:-1], np.asarray(fz, float)[:-1]
    on = body > threshold
    if on.all() or not on.any():
        raise InputError(f"the right foot never touches down and lifts off (vertical force "
                         f"{body.min():.3g}..{body.max():.3g} N, threshold {threshold} N): "
                         "no heel strike to align the curves on.")
    k = int(np.flatnonzero(on & ~np.roll(on, 1))[0])
    period = t[-1] - t[0]
    t0 = body_t[k - 1] - (period if k == 0 else 0.0)
    f0, f1 = body[k - 1], body[k]
    return float(t0 + (threshold - f0) / (f1 - f0) * (body_t[k] - t0))


def heel_strike_curves(t: np.ndarray, angles: dict[str, np.ndarray], fz: np.ndarray,
                       threshold: float = STANCE_THRESHOLD_N) -> dict[str, np.ndarray]:
    """Each periodic curve (deg) on 0..100 % of the stride from the right heel strike."""
    t = np.asarray(t, float)
    start, period = heel_strike_time(t, fz, threshold), t[-1] - t[0]
    clock = t[0] + np.mod(start + PERCENT / 100.0 * period - t[0], period)
    return {k: np.interp(clock, t, np.asarray(v, float)) for k, v in angles.items()}


def gait_curves(plant, planar, gait) -> dict[str, np.ndarray]:
    """Right hip, knee, ankle (deg, 101 points) of a half-stride MuscleGait."""
    from predgait.problems.muscle_gait_stride import full_stride

    stride = full_stride(plant, gait, np.zeros(gait.grf.shape[:2]))
    values = planar.osim_from_q(stride.q)
    angles = {j: np.degrees(clinical_joint("osim2d", f"{name}_r").clinical(values[f"{name}_r"]))
              for j, name in COLUMNS.items()}
    return heel_strike_curves(stride.t, angles, stride.foot_fz(plant)[:, 0])


def moco_curves(solution: Path, grf: Path) -> dict[str, np.ndarray]:
    """Right hip, knee, ankle (deg, 101 points) of Moco's half-stride solution.

    The stride is the half stride followed by its mirror (left <-> right), as Moco's
    ``createPeriodicTrajectory`` makes the _fullcycle file; the heel strike comes from
    the _fullcycle_grf file (``ground_force_r_vy``, N).
    """
    from predgait.data.storage import read_storage

    half, forces = read_storage(solution), read_storage(grf)
    t = half.time - half.time[0]
    period = 2.0 * t[-1]
    full_t = np.concatenate([t, t[1:] + t[-1]])

    def column(name: str) -> np.ndarray:
        label = next((c for c in half.columns if c.endswith(f"/{name}/value")), None)
        if label is None:
            raise InputError(f"{solution}: no column '/{name}/value'.")
        return half.columns[label]

    angles = {}
    for joint, name in COLUMNS.items():
        right, left = column(f"{name}_r"), column(f"{name}_l")
        sign = clinical_joint("osim2d", f"{name}_r")
        angles[joint] = np.degrees(sign.clinical(np.concatenate([right, left[1:]])))
    ft = forces.time - half.time[0]
    fz = np.interp(np.mod(full_t, period), np.mod(ft, period + 1e-12),
                   forces.column("ground_force_r_vy"))
    return heel_strike_curves(full_t, angles, fz)


def rms_deg(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> dict[str, float]:
    """Per joint RMS difference (deg) of two sets of curves on the same percentages."""
    return {j: float(np.sqrt(np.mean((a[j] - b[j]) ** 2))) for j in JOINTS}


def agreement_table(curves: dict) -> list[dict]:
    """Pairwise RMS (deg) of every pair of labelled curve sets.

    Returns rows of a, b (the labels), hip, knee, ankle and their max.
    """
    rows = []
    for a, b in itertools.combinations(curves, 2):
        rms = rms_deg(curves[a], curves[b])
        rows.append({"a": a, "b": b, **rms, "max": max(rms.values())})
    return rows
