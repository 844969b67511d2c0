"""Measured trial in, joint moments out: the planar inverse-dynamics pipeline.

markers (TRC / C3D / CSV) + ground reactions (MOT / C3D plates)
  -> gap filling, Butterworth low-pass (Winter correction) of markers and forces
  -> joint centres (markers, Harrington hip regression, static-trial calibration)
  -> least-squares IK of the leg URDF (hinge-consistent coordinates)
  -> 5-point central differences -> Pinocchio RNEA with the ground reaction on the foot
  -> ankle, knee, hip moments, joint forces and powers; time zero at heel strike.

Options: :mod:`predgait.dynamics.inverse_options`; the trial's points, leg model and foot
GRF: :mod:`predgait.dynamics.leg_measurements`; here the run and its result.
"""

from __future__ import annotations

import functools
import logging
from dataclasses import dataclass, field, replace

import numpy as np

from predgait.data import (
    differentiate,
    events_from_plate,
    fill_gaps,
    lowpass,
)
from predgait.data.body_weight import PLATES, PlateMass, plate_body_mass, resolve_mass
from predgait.data.cutoffs import marker_cutoff, plate_cutoff
from predgait.data.events import Events, Side
from predgait.data.trial import ForcePlate, Trial
from predgait.dynamics.inverse import LegInverse, LoadHistory, leg_inverse_dynamics
from predgait.dynamics.inverse_options import InverseOptions, bundled_options
from predgait.dynamics.leg_measurements import (
    cop_hint,
    foot_grf,
    foot_pitch,
    joint_points,
    kinematic_events,
    leg_model,
    needed_markers,
    read_trial,
)
from predgait.dynamics.leg_static import LegStatic, leg_static
from predgait.errors import InputError
from predgait.kinematics import clinical
from predgait.kinematics.bounded_ik import frames_near
from predgait.kinematics.planar_ik import IKResult, solve_ik
from predgait.models.anthropometry import LegParameters
from predgait.models.loading import Model
from predgait.textfile import source_name

log = logging.getLogger(__name__)
#: Fewest marker frames the pipeline analyses (the 5-point differences, the filter).
MIN_FRAMES = 20


@dataclass(frozen=True)
class InverseResult:
    """Planar inverse-dynamics results of one leg (see docs/DEVELOPING.md contract)."""

    time: np.ndarray
    model: Model
    side: Side
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    tau: np.ndarray
    hip_force: np.ndarray
    hip_moment: np.ndarray
    joint_force: dict[str, np.ndarray]
    grf: np.ndarray
    cop: np.ndarray
    free_moment: np.ndarray
    events: Events
    ik: IKResult
    body_mass: float
    has_grf: bool
    provenance: dict = field(default_factory=dict)
    leg: LegParameters | None = None
    flagged: np.ndarray | None = None
    knee_static: float = 0.0
    plate_mass: PlateMass | None = None   # body mass the plates measure (data.body_weight)

    @property
    def valid(self) -> np.ndarray:
        """(n,) bool: frames whose results stand (see :func:`flagged_outputs`)."""
        return np.ones(self.time.size, dtype=bool) if self.flagged is None else ~self.flagged

    def _masked(self, values: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        return {k: np.where(self.valid, v, np.nan) for k, v in values.items()}

    def clinical_angles(self) -> dict[str, np.ndarray]:
        """Hip flexion, knee flexion, ankle dorsiflexion, rad (NaN at flagged frames)."""
        return self._masked(clinical.clinical_angles(self.q))

    def anatomical_angles(self) -> dict[str, np.ndarray]:
        """Clinical angles with the knee calibrated on the static trial, rad.

        The knee flexion of the model's hinge (between the hip-knee and knee-ankle
        joint-centre lines) minus its value standing in the static trial (``knee_static``),
        so that the straight standing knee reads 0 (the calibrated anatomical frames of
        Cappozzo et al. 1995, Clin Biomech 10:171-178). The ankle needs no offset: the foot
        is already calibrated flat on the static trial and the shank's forward lean
        standing is posture. Hip flexion is the thigh against the vertical.
        """
        angles = self.clinical_angles()
        angles["knee_flexion"] = angles["knee_flexion"] - self.knee_static
        return angles

    def clinical_rates(self) -> dict[str, np.ndarray]:
        """Their time derivatives, rad/s (NaN at flagged frames)."""
        return self._masked(clinical.clinical_angles(self.v))

    def clinical_moments(self) -> dict[str, np.ndarray]:
        """Hip flexion, knee flexion, ankle dorsiflexion moments, N m (NaN at flagged frames)."""
        return self._masked(clinical.clinical_moments(self.tau, self.hip_moment[:, 1]))

    def status(self) -> str:
        """``completed`` or ``completed with N flagged frames``."""
        n = int(self.ik.flagged.sum())
        return "completed" if n == 0 else f"completed with {n} flagged frames"

    def powers(self) -> dict[str, np.ndarray]:
        """Joint powers, W."""
        return clinical.joint_powers(self.clinical_moments(), self.clinical_rates())

    def first_cycle(self) -> tuple[float, float] | None:
        """Start and end time (s) of the first full gait cycle, if the trial has one."""
        cycles = self.events.cycles()
        return cycles[0] if cycles else None


def flagged_outputs(ik_flagged: np.ndarray, *, stencil: int = 2) -> np.ndarray:
    """Frames whose outputs depend on a flagged IK frame (the 5-point differences reach +-2)."""
    return frames_near(ik_flagged, stencil)


def run_inverse(options: InverseOptions, *, loaded: tuple[Trial, np.ndarray] | None = None,
                static: LegStatic | None = None) -> InverseResult:
    """Run the pipeline (module docstring) on one trial and leg.

    ``loaded`` is the trial already read with its rotation (:func:`read_trial`), e.g. with
    noise added for a noise bootstrap; None reads ``options.markers``. ``static``: the
    leg's static calibration (:func:`~predgait.dynamics.leg_static.leg_static`) for these
    options and the trial's rotation (a batch worker keeps it per subject); None: made
    here from ``options.static``.
    """
    trial, turn = read_trial(options) if loaded is None else loaded
    weighed = options.mass == PLATES
    if weighed:
        options = replace(options, mass=resolve_mass(options.mass, trial.plates,
                                                     source=str(options.grf or trial.source)))
    needed = needed_markers(options.points)
    if trial.markers.n_frames < MIN_FRAMES:
        raise InputError(f"{trial.source}: the trial has {trial.markers.n_frames} frames; "
                         f"inverse dynamics needs at least {MIN_FRAMES} (a gait cycle).")
    markers = fill_gaps(trial.markers, names=needed, max_gap_frames=options.max_gap_frames,
                        edges="trim")
    if markers.n_frames < MIN_FRAMES:
        raise InputError(f"{trial.source}: only {markers.n_frames} frames have all of "
                         f"{', '.join(needed)}; check the marker names.")
    cutoff, cutoff_note = marker_cutoff(markers.select(needed), options.cutoff)
    grf_cutoff = plate_cutoff(trial.plates, options.grf_cutoff, cutoff)
    if cutoff is not None:
        markers = markers.with_xyz(lowpass(markers.xyz, markers.rate, cutoff))
    if static is None and options.static is not None:
        static = leg_static(options, turn)
    elif static is not None and not static.fits(options, turn):
        raise ValueError("run_inverse: the static calibration is another subject's (options "
                         "or the trial's rotation differ).")
    points = joint_points(markers, options, None if static is None else static.markers)
    pitch = foot_pitch(points)
    if static is None:
        model, leg = leg_model(options, points)
        knee_static = 0.0
    else:
        pitch = pitch - float(np.mean(foot_pitch(static.points)))
        model, leg, knee_static = static.model, static.leg, static.knee_static
    ik = solve_ik(model, {f"{k}_center": points[k] for k in ("hip", "knee", "ankle")}, pitch,
                  limit_margin=np.radians(options.limit_margin))
    if ik.flagged.any():
        bad = np.flatnonzero(ik.flagged)
        log.warning("IK flagged %d frames (first at t = %.3f s): %s", bad.size,
                    markers.time[bad[0]], ik.limited_coordinates() or "not converged")
    time = markers.time
    q = ik.q
    v = differentiate(q, time, method="central5")
    a = differentiate(q, time, method="central5", order=2)
    try:
        force, cop, free = foot_grf(trial.plates, time, points["heel"], points["toe"],
                                     options, grf_cutoff)
    except InputError as exc:   # a plate's own complaint: say which file it came from
        raise InputError(f"{options.grf or trial.source}: {exc}") from None
    has_grf = bool(trial.plates)
    if has_grf and not np.any(force[:, 2] >= options.threshold):
        raise InputError(f"{options.grf or trial.source}: no plate has a contact (vertical "
                         f"force >= {options.threshold:g} N) under the {options.side} foot"
                         f"{cop_hint(trial.plates, points['heel'], options.threshold)}.")
    contact = (force[:, 2] != 0)[:, None]
    loads = [LoadHistory("foot", np.where(contact, force, 0.0), cop, np.where(contact, free, 0.0))]
    inv: LegInverse = leg_inverse_dynamics(model, q, v, a, loads)
    if has_grf:
        # Events from the unfiltered reaction: low-pass filtering smears the contact edges.
        raw = foot_grf(trial.plates, time, points["heel"], points["toe"], options, None)
        foot_plate = ForcePlate(time=time, force=raw[0], cop=raw[1], free_moment=raw[2],
                                name=str(options.side))
        events = events_from_plate(foot_plate, options.side, threshold=options.threshold)
    else:
        events = kinematic_events(time, points, options.side)
    t0 = float(events.heel_strikes[0]) if len(events.heel_strikes) else 0.0
    provenance = {
        "trial": source_name(options.markers), "grf": source_name(options.grf),
        "static": source_name(options.static), "side": str(options.side),
        "mass_kg": options.mass, "mass_from": "plates" if weighed else "given",
        "height_m": options.height, "model": model.source,
        "marker_cutoff_hz": cutoff, "marker_cutoff": cutoff_note, "grf_cutoff_hz": grf_cutoff,
        "contact_threshold_n": options.threshold,
        "contact_release_n": options.release * options.threshold,
        "joint_limit_margin_deg": options.limit_margin, "time_zero_s": t0,
        "knee_flexion_standing_deg": float(np.degrees(knee_static)),
    }
    return InverseResult(
        time=time - t0, model=model, side=options.side, q=q, v=v, a=a, tau=inv.tau,
        hip_force=inv.hip_force, hip_moment=inv.hip_moment, joint_force=inv.joint_force,
        grf=force, cop=cop, free_moment=free, events=events.shifted(t0), ik=ik,
        body_mass=options.mass, has_grf=has_grf, provenance=provenance, leg=leg,
        flagged=flagged_outputs(ik.flagged), knee_static=knee_static,
        plate_mass=plate_body_mass(trial.plates, gravity=model.gravity))


@functools.lru_cache(maxsize=4)
def bundled_inverse(side: Side | str = Side.RIGHT) -> InverseResult:
    """Inverse dynamics of the bundled subject01 trial with default options (cached)."""
    return run_inverse(bundled_options(side))


