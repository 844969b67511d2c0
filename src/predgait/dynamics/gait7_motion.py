"""Measured walking mapped onto the planar 7-link model gait7 (thesis 2.3.1).

Source: the planar inverse dynamics of each leg (:func:`predgait.dynamics.inverse_trial.
bundled_inverse`, hinge-consistent IK of marker-based joint centres, 6 Hz low-pass) and
the trunk markers. In the leg model a positive pitch tilts a segment's top toward +X and
the absolute pitches are foot = q_pitch, shank = foot + q_ankle, thigh = shank + q_knee
(:mod:`predgait.kinematics.clinical`). gait7 uses the same pitch sense, with
HAT = base_pitch, thigh = HAT + hip, shank = thigh + knee, foot = shank + ankle, so::

    hip_g7 = thigh - HAT,   knee_g7 = -q_knee (flexion),   ankle_g7 = -q_ankle (plantarflexion)

and a gait7 joint torque is minus the leg-model torque at knee and ankle.

HAT base: ``base_x``, ``base_z`` = mean of the right and left hip centres (Harrington
regression, through each leg's IK); ``base_pitch`` = lean of the line from that point to
the mid-point of the acromion markers (R/L.Acromium; 0 = upright, + = forward), the HAT
of gait7 being the hip-to-shoulder segment (Winter 2009, Table 4.1). Velocities and
accelerations are 5-point central differences of the mapped coordinates.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from predgait.data import differentiate, lowpass
from predgait.dynamics.inverse_options import bundled_options
from predgait.dynamics.inverse_trial import InverseResult, bundled_inverse
from predgait.dynamics.leg_measurements import read_trial
from predgait.errors import InputError
from predgait.kinematics.clinical import clinical_joint, leg_clinical
from predgait.models.gait7 import build_gait7_urdf
from predgait.models.loading import Model, model_from_urdf
from predgait.textfile import source_name

SIDES = ("right", "left")
SHOULDER_MARKERS = ("R.Acromium", "L.Acromium")
#: Leg-model frames; gait7 has each with a suffix _r/_l (hip_center: one, shared).
LEG_FRAMES = ("hip_center", "knee_center", "ankle_center", "heel", "toe")


@dataclass(frozen=True, eq=False)
class Gait7Motion:
    """Measured motion in gait7 coordinates, measured loads, and the points it came from.

    Attributes:
        time: (n,) s, trial clock (the file's time column).
        q, v, a: (n, 9) gait7 coordinates (m, rad), velocities and accelerations.
        knee_moment: side -> (n,) N m, the leg inverse-dynamics knee torque in gait7 sign
            (+ toward knee flexion).
        plate_time: (k,) s. plate_fz: side -> (k,) N, measured vertical GRF per foot (raw).
        points: "<frame>_<r|l>" -> (n, 3) m, lab positions of the leg models' frames at
            the IK solution (the measured joint centres within the IK residuals).
        heel_strikes: side -> (h,) s, trial clock.
        provenance: trial files and options.
    """

    time: np.ndarray
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    knee_moment: dict[str, np.ndarray]
    plate_time: np.ndarray
    plate_fz: dict[str, np.ndarray]
    points: dict[str, np.ndarray]
    heel_strikes: dict[str, np.ndarray]
    provenance: dict = field(default_factory=dict)


def frame_positions(model: Model, q: np.ndarray, frames) -> dict[str, np.ndarray]:
    """(n, 3) lab positions of named frames of ``model`` for coordinates q (n, nq), m."""
    pm = model.pin_model
    data = pm.createData()
    ids = {name: model.frame_id(name) for name in frames}
    out = {name: np.zeros((len(q), 3)) for name in ids}
    for k, row in enumerate(q):
        pin.framesForwardKinematics(pm, data, row)
        for name, fid in ids.items():
            out[name][k] = data.oMf[fid].translation
    return out


def hat_pitch(hip: np.ndarray, shoulder: np.ndarray) -> np.ndarray:
    """Pitch (n,) of the hip-to-shoulder line about +Y (0 upright, + leaning forward), rad."""
    d = shoulder - hip
    return np.arctan2(d[:, 0], d[:, 2])


def map_legs(pitch_hat: np.ndarray, right: np.ndarray, left: np.ndarray
             ) -> dict[str, np.ndarray]:
    """gait7 joint coordinates (name -> (n,), rad) from HAT pitch and the legs' q (n, 5)."""
    out = {}
    for s, q in (("r", right), ("l", left)):
        thigh = q[:, 2] + q[:, 3] + q[:, 4]
        out |= {f"hip_{s}": thigh - pitch_hat, f"knee_{s}": leg_to_gait7("knee", s, q[:, 4]),
                f"ankle_{s}": leg_to_gait7("ankle", s, q[:, 3])}
    return out


def leg_to_gait7(joint: str, side: str, value: np.ndarray) -> np.ndarray:
    """A leg knee or ankle angle or torque (model sign) as gait7's, through both tables."""
    return clinical_joint("gait7", f"{joint}_{side}").clinical(leg_clinical(joint, value))


def gait7_motion(model: Model, right: InverseResult, left: InverseResult, shoulder: np.ndarray,
                 plates: dict[str, tuple[np.ndarray, np.ndarray]], *,
                 provenance: dict | None = None) -> Gait7Motion:
    """Map two legs' inverse results (same frames) and the shoulder point onto gait7.

    Args:
        model: The gait7 model (its coordinate order).
        right: Inverse result of the right leg.
        left: Inverse result of the left leg of the same trial (same frames).
        shoulder: (n, 3) m, mid-point of the shoulder markers at the same frames.
        plates: side -> (time (k,) s, vertical force (k,) N) measured per foot.
        provenance: Recorded with the result.
    """
    time = right.time + right.provenance["time_zero_s"]
    other = left.time + left.provenance["time_zero_s"]
    if time.shape != other.shape or np.max(np.abs(time - other)) > 1e-6:
        raise InputError("gait7 mapping: the right and left inverse results must share "
                         "their frames (same trial and marker filtering).")
    pts = {side: frame_positions(inv.model, inv.q, LEG_FRAMES)
           for side, inv in (("r", right), ("l", left))}
    hip = 0.5 * (pts["r"]["hip_center"] + pts["l"]["hip_center"])
    pitch = hat_pitch(hip, shoulder)
    columns = {"base_x": hip[:, 0], "base_z": hip[:, 2], "base_pitch": pitch,
               **map_legs(pitch, right.q, left.q)}
    q = np.column_stack([columns[name] for name in model.coordinate_names])
    v = differentiate(q, time, method="central5")
    a = differentiate(q, time, method="central5", order=2)
    points = {f"{name}_{s}": p for s, frames in pts.items() for name, p in frames.items()}
    knee = {"right": leg_to_gait7("knee", "r", right.tau[:, 4]),
            "left": leg_to_gait7("knee", "l", left.tau[:, 4])}
    strikes = {side: inv.events.heel_strikes + inv.provenance["time_zero_s"]
               for side, inv in (("right", right), ("left", left))}
    plate_time = plates["right"][0]
    return Gait7Motion(time=time, q=q, v=v, a=a, knee_moment=knee, plate_time=plate_time,
                       plate_fz={s: np.interp(plate_time, *plates[s]) for s in SIDES},
                       points=points, heel_strikes=strikes, provenance=provenance or {})


@functools.lru_cache(maxsize=4)
def gait7_model(mass: float, height: float) -> Model:
    """gait7 for a subject (:func:`predgait.models.gait7.build_gait7_urdf`), cached."""
    return model_from_urdf(build_gait7_urdf(mass, height),
                           source=f"gait7 for {mass:g} kg, {height:g} m")


@functools.lru_cache(maxsize=4)
def bundled_gait7_motion(model: Model) -> Gait7Motion:
    """The bundled subject01 walking trial in the coordinates of ``model`` (cached)."""
    options = bundled_options("right")
    trial, _ = read_trial(options)
    markers = trial.markers
    idx = [markers.names.index(n) for n in SHOULDER_MARKERS]
    xyz = lowpass(markers.xyz[:, idx], markers.rate, options.cutoff)
    plates = {p.name: (p.time, p.force[:, 2]) for p in trial.plates}
    return gait7_motion(model, bundled_inverse("right"), bundled_inverse("left"),
                        xyz.mean(axis=1), plates,
                        provenance={"trial": source_name(options.markers),
                                    "grf": source_name(options.grf),
                                    "marker_cutoff_hz": options.cutoff})
