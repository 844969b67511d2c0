"""The identified passive knee and ankle beside Riener & Edrich (1999), on the trial's angles.

A fitted passive curve is plausible only if it is of the size a published model gives at
the same joint angles. For every quiet sample of the fit (the samples it used) this
evaluates both the identified elastic moment M_fit(theta) (with its 95 % delta-method
band, :func:`~predgait.problems.passive_answer.elastic_moment`) and the Riener & Edrich
moment at the sample's own hip, knee and ankle angles
(:mod:`predgait.dynamics.riener_edrich`: it depends on the adjacent joints through the
bi-articular muscles), and reports, in N m:

* the RMS difference of the two over the quiet samples, beside the RMS of each;
* the share of samples where the identified moment is within a factor of 2 of the
  literature's (1/2 <= M_fit / M_lit <= 2: same sign, at most twice or half as large);
* the share of samples where the literature lies inside the identified 95 % band;
* for the knee, the literature's RMS change with the hip 10 deg more flexed (the leg model's
  hip angle is the thigh against the vertical, the paper's against the pelvis).

The literature describes a generic adult's relaxed leg; a difference says how far this
trial's answer is from it, not which is wrong.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from predgait.dynamics import riener_edrich
from predgait.problems.passive_answer import elastic_moment
from predgait.problems.passive_model import PassiveModel

#: A sample's identified moment is "within a factor" of the literature's when
#: 1/FACTOR <= M_fit / M_lit <= FACTOR.
FACTOR = 2.0


@dataclass(frozen=True)
class LiteratureCheck:
    """One joint's identified elastic moment beside the literature's, per quiet sample.

    Attributes:
        joint: ``knee`` or ``ankle``.
        angle: (n,) the joint's clinical angle at the quiet samples, rad.
        identified: (n,) the fitted model's elastic moment there, N m.
        band: (n,) its 95 % half-width, N m.
        literature: (n,) Riener & Edrich at the samples' hip, knee and ankle angles, N m.
        literature_hip_tilted: (n,) the same with the hip :data:`~predgait.dynamics.
            riener_edrich.HIP_TILT_DEG` more flexed, N m.
    """

    joint: str
    angle: np.ndarray
    identified: np.ndarray
    band: np.ndarray
    literature: np.ndarray
    literature_hip_tilted: np.ndarray

    def as_dict(self) -> dict:
        """JSON-ready summary (module docstring) with the sentence printed for it."""
        stats = compare(self.identified, self.band, self.literature)
        tilt = _rms(self.literature_hip_tilted - self.literature)
        out = {"literature": riener_edrich.SOURCE, "quiet_samples": int(self.angle.size),
               "angle_range_deg": [round(float(np.degrees(self.angle.min())), 2),
                                   round(float(np.degrees(self.angle.max())), 2)],
               **stats, "hip_tilt_sensitivity_n_m": tilt}
        out["text"] = sentence(self.joint, out)
        return out


def _rms(x) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


def compare(identified, band, literature) -> dict:
    """RMS difference and sizes (N m), shares within a factor and inside the band."""
    identified, literature = np.asarray(identified), np.asarray(literature)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = identified / literature
    return {"rms_difference_n_m": _rms(identified - literature),
            "rms_identified_n_m": _rms(identified), "rms_literature_n_m": _rms(literature),
            "factor": FACTOR,
            "within_factor_fraction": float(np.mean((ratio >= 1 / FACTOR)
                                                    & (ratio <= FACTOR))),
            "inside_band_fraction": float(np.mean(np.abs(identified - literature)
                                                  <= np.asarray(band)))}


def sentence(joint: str, stats: dict) -> str:
    """What the CLI prints for one joint."""
    return (f"{joint} RMS difference {stats['rms_difference_n_m']:.2f} N m (identified "
            f"{stats['rms_identified_n_m']:.2f}, literature {stats['rms_literature_n_m']:.2f} "
            f"N m RMS); identified within a factor of {stats['factor']:g} of the literature "
            f"at {100 * stats['within_factor_fraction']:.0f} % of the samples, literature "
            f"inside the identified 95 % band at {100 * stats['inside_band_fraction']:.0f} %")


def literature_check(model: PassiveModel, values: dict, information: np.ndarray,
                     angles: dict) -> dict[str, LiteratureCheck]:
    """Joint -> :class:`LiteratureCheck` over the quiet samples.

    Args:
        model: The fitted passive model.
        values: Its parameter values (SI).
        information: The fit's Fisher information of its fitted parameters (SI).
        angles: ``hip_flexion``, ``knee_flexion`` (anatomical), ``ankle_dorsiflexion``:
            (n,) clinical angles of the quiet samples, rad; samples with a NaN are left out.
    """
    hip, knee, ankle = (np.asarray(angles[name], dtype=float) for name in (
        "hip_flexion", "knee_flexion", "ankle_dorsiflexion"))
    keep = np.isfinite(hip) & np.isfinite(knee) & np.isfinite(ankle)
    if not keep.any():
        return {}
    hip, knee, ankle = hip[keep], knee[keep], ankle[keep]
    tilted = hip + np.radians(riener_edrich.HIP_TILT_DEG)
    out = {}
    for joint in model.joints:
        own = knee if joint == "knee" else ankle
        identified, band = elastic_moment(model, values, information, joint, own)
        out[joint] = LiteratureCheck(
            joint, own, identified, band,
            np.asarray(riener_edrich.passive_moment(joint, hip, knee, ankle)),
            np.asarray(riener_edrich.passive_moment(joint, tilted, knee, ankle)))
    return out
