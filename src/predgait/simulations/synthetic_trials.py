"""Synthetic leg trials with known answers, for checking a batch run trial by trial.

A leg of a given mass and height (Winter's anthropometry, :func:`generate_urdf`) walks a
smooth periodic motion at a given cadence and speed; Pinocchio's forward kinematics give
the exact hip, knee, ankle, heel and toe positions (written as a markers CSV, 100 Hz) and a
periodic ground reaction (sin^2 stance windows of 60 % of each cycle, vertical peak
1.05 body weight, COP rolling heel to toe) is written as an OpenSim MOT (Y-up, 1000 Hz). The
answer is the RNEA of the exact motion with that load (:func:`leg_inverse_dynamics`):
clinical angles (deg) and moments (N m) per frame in ``answers.csv``. Each trial also gets
the inverse problem file (``inverse.toml``) that ``predgait inverse`` runs on it.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from predgait.data import write_csv, write_storage
from predgait.data.frames import OPENSIM_TO_LAB
from predgait.dynamics.external import Load
from predgait.dynamics.inverse import leg_inverse_dynamics
from predgait.kinematics import clinical
from predgait.models.loading import generate_urdf, model_from_urdf

MARKER_RATE, PLATE_RATE = 100.0, 1000.0
#: Model frame of each leg point (the markers CSV names its columns after the points).
POINT_FRAMES = {"hip": "hip_center", "knee": "knee_center", "ankle": "ankle_center",
                "heel": "heel", "toe": "toe"}
STANCE_FRACTION = 0.6   # of each cycle, from heel strike


@dataclass(frozen=True)
class SyntheticWalk:
    """One synthetic trial: subject (kg, m), cadence (cycles/s), speed (m/s), cycles."""

    mass: float = 72.6
    height: float = 1.80
    cadence: float = 0.8
    speed: float = 0.6
    cycles: int = 3


def leg_motion(t: np.ndarray, walk: SyntheticWalk):
    """Coordinates (n, 5) of the leg and their exact rates and accelerations."""
    w = 2 * np.pi * walk.cadence
    mean = np.array([0.3, 0.08, 0.0, 0.1, -0.5])
    amp = np.array([0.05, 0.02, 0.15, 0.15, 0.4])
    phase = np.array([0.0, 1.0, 0.5, 2.0, 1.0])
    arg = w * t[:, None] + phase
    q, v, a = mean + amp * np.sin(arg), amp * w * np.cos(arg), -amp * w**2 * np.sin(arg)
    q[:, 0] += walk.speed * t
    v[:, 0] += walk.speed
    return q, v, a


def frame_positions(model, q: np.ndarray) -> dict[str, np.ndarray]:
    """Lab positions (n, 3) m of the leg points' frames at each configuration (n, 5)."""
    import pinocchio as pin

    pm = model.pin_model
    data = pm.createData()
    out = {name: np.zeros((len(q), 3)) for name in POINT_FRAMES.values()}
    for k, qk in enumerate(q):
        pin.framesForwardKinematics(pm, data, qk)
        for name in out:
            out[name][k] = data.oMf[model.frame_id(name)].translation
    return out


def ground_reaction(t: np.ndarray, heel: np.ndarray, toe: np.ndarray, walk: SyntheticWalk):
    """Force (n, 3) N, COP (n, 3) m on z = 0 and free moment (n, 3) N m of the stances.

    Stances start at t = 0.25 s + k / cadence (k = 0, 1, ...) and last 60 % of a cycle.
    """
    period = 1.0 / walk.cadence
    phase = np.mod(t - 0.25, period) / (STANCE_FRACTION * period)
    on = (t > 0.25) & (phase < 1.0)
    s = np.clip(phase, 0.0, 1.0)
    window = np.where(on, np.sin(np.pi * s) ** 2, 0.0)
    weight = walk.mass * 9.81
    force = np.column_stack([0.2 * weight * window * np.cos(np.pi * s), np.zeros_like(t),
                             1.05 * weight * window])
    cop = heel + s[:, None] * (toe - heel)
    cop[:, 2] = 0.0
    free = np.column_stack([np.zeros_like(t), np.zeros_like(t), 3.0 * window])
    return force, cop, free


def _write_grf_mot(path: Path, time: np.ndarray, force, cop, free) -> None:
    """Lab-frame plate -> an OpenSim MOT (Y-up, one unnamed plate)."""
    to_file = OPENSIM_TO_LAB.T
    columns = {}
    for stem, values in (("ground_force_v", force), ("ground_force_p", cop),
                         ("ground_torque_", free)):
        for axis, column in zip("xyz", (values @ to_file.T).T, strict=True):
            columns[f"{stem}{axis}"] = column
    write_storage(path, time, columns, name="synthetic_grf")


def write_synthetic_trial(folder: str | Path, walk: SyntheticWalk) -> dict[str, Path]:
    """Write leg.urdf, markers.csv, grf.mot, inverse.toml and answers.csv into ``folder``.

    Returns:
        The written paths by name (``urdf``, ``markers``, ``grf``, ``problem``, ``answers``).
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    urdf = generate_urdf("leg", mass=walk.mass, height=walk.height)
    model = model_from_urdf(urdf, source="synthetic")
    duration = walk.cycles / walk.cadence + 0.5
    t = np.arange(0.0, duration + 1e-9, 1 / MARKER_RATE)
    q, v, a = leg_motion(t, walk)
    positions = frame_positions(model, q)
    paths = {name: folder / file for name, file in (
        ("urdf", "leg.urdf"), ("markers", "markers.csv"), ("grf", "grf.mot"),
        ("problem", "inverse.toml"), ("answers", "answers.csv"))}
    paths["urdf"].write_text(urdf)
    write_csv(paths["markers"], t, {p: positions[f] for p, f in POINT_FRAMES.items()},
              units=dict.fromkeys(POINT_FRAMES, "m"), provenance=f"synthetic {walk}")
    t_plate = np.arange(0.0, duration + 1e-9, 1 / PLATE_RATE)
    feet = frame_positions(model, leg_motion(t_plate, walk)[0])
    _write_grf_mot(paths["grf"], t_plate, *ground_reaction(t_plate, feet["heel"], feet["toe"],
                                                           walk))
    exact = ground_reaction(t, positions["heel"], positions["toe"], walk)
    loads = [[Load("foot", f, point=c, moment=m)] for f, c, m in zip(*exact, strict=True)]
    inverse = leg_inverse_dynamics(model, q, v, a, loads)
    angles = clinical.clinical_angles(q)
    moments = clinical.clinical_moments(inverse.tau, inverse.hip_moment[:, 1])
    columns = {k: np.degrees(val) for k, val in angles.items()} | moments
    write_csv(paths["answers"], t, columns,
              units=dict.fromkeys(angles, "deg") | dict.fromkeys(moments, "N m"),
              provenance=f"exact answer of synthetic {walk}")
    paths["problem"].write_text(
        "# Synthetic leg trial (predgait.simulations.synthetic_trials)\n[trial]\n"
        f'markers = "markers.csv"\ngrf = "grf.mot"\nmodel = "leg.urdf"\n'
        f"mass = {walk.mass!r}\nheight = {walk.height!r}\nside = \"right\"\n\n[points]\n"
        + "".join(f'{p} = "{p}"\n' for p in POINT_FRAMES)
        + "\n[options]\ncutoff = 6.0\nscale_to_markers = false\n")
    return paths
