"""The planar leg calibrated on a subject's static trial.

The static trial is turned like the walk (its progression rotation), its gaps filled, its
joint centres located (static-calibrated knee and ankle centres); they give the leg's
segment lengths (the model) and the standing knee flexion the clinical knee angle is
measured from. :func:`leg_static` -> :class:`LegStatic`, used by
:func:`predgait.dynamics.inverse_trial.run_inverse`; a batch worker keeps one per subject,
side and walking direction (:mod:`predgait.workflows.batch_trial`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np

from predgait.data import fill_gaps, read_trc
from predgait.data.frames import rotate_markers
from predgait.data.trial import Markers
from predgait.dynamics.inverse_options import InverseOptions, StaticCentre
from predgait.dynamics.leg_measurements import foot_pitch, joint_points, leg_model, needed_markers
from predgait.kinematics import clinical
from predgait.kinematics.planar_ik import solve_ik
from predgait.models.anthropometry import LegParameters
from predgait.models.loading import Model


@dataclass(frozen=True, eq=False)
class LegStatic:
    """The static trial's part of a leg inverse.

    ``markers``: the static trial (m, turned by ``turn`` (3, 3), gaps filled);
    ``points``: its joint points (m); ``model`` and ``leg``: the leg built from them;
    ``knee_static``: the standing knee flexion, rad; ``options``: what it was made with.
    """

    markers: Markers
    points: dict[str, np.ndarray]
    model: Model
    leg: LegParameters | None
    knee_static: float
    options: InverseOptions
    turn: np.ndarray

    def fits(self, options: InverseOptions, turn: np.ndarray) -> bool:
        """Whether it is the calibration of ``options`` (any trial files) and ``turn``."""
        same = replace(options, markers=self.options.markers, grf=self.options.grf)
        return same == self.options and np.array_equal(turn, self.turn)


def static_knee_flexion(model: Model, static_points: Mapping[str, np.ndarray]) -> float:
    """Mean knee flexion (rad) of the leg fitted to the static trial's joint centres."""
    pitch = foot_pitch(static_points)
    ik = solve_ik(model, {f"{k}_center": static_points[k] for k in ("hip", "knee", "ankle")},
                  pitch - np.mean(pitch), limit_margin=np.radians(30.0))
    return float(np.mean(clinical.clinical_angles(ik.q)["knee_flexion"]))


def leg_static(options: InverseOptions, turn: np.ndarray) -> LegStatic:
    """Calibrate the leg on ``options.static`` turned by ``turn`` (the walk's rotation).

    ``options.mass`` must be in kg (not "plates").

    Raises:
        InputError: an unreadable static trial or a missing marker.
    """
    needed = needed_markers(options.points)
    static = rotate_markers(read_trc(options.static), turn)
    static_names = [n for s in options.points.values() if isinstance(s, StaticCentre)
                    for n in (s.medial, s.lateral)]
    static = fill_gaps(static, names=list(dict.fromkeys(needed + static_names)), edges="trim")
    points = joint_points(static, options, static)
    model, leg = leg_model(options, points)
    return LegStatic(static, points, model, leg, static_knee_flexion(model, points), options,
                     np.array(turn, dtype=float))
