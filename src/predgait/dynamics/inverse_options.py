"""What the planar inverse-dynamics pipeline is asked (:class:`InverseOptions`).

The options of :func:`predgait.dynamics.inverse_trial.run_inverse`: the trial files, the
subject, how each of the hip, knee, ankle, heel and toe points is found (a marker or a
joint-centre rule), filters, contact threshold; and those of the bundled subject01 trial
(:func:`bundled_options`, :func:`bundled_source`: the one check of a problem file's trial
source).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path

from predgait.data import (
    Side,
)
from predgait.data.bundled import bundled_path, subject_info
from predgait.data.cutoffs import Cutoff, CutoffRule
from predgait.data.resample import RELEASE_FRACTION

POINT_NAMES = ("hip", "knee", "ankle", "heel", "toe")
#: The bundled trial's name in problem files (``[trial] source``).
BUNDLED = "bundled:subject01"
#: N, default contact threshold: a contact must reach it; it lasts while the force stays
#: above ``RELEASE_FRACTION`` of it (:func:`predgait.data.resample.contact_frames`).
THRESHOLD = 10.0
#: A run whose IK flags more than this fraction of the frames is a failed run (exit 3).
MOST_FRAMES = 0.5


@dataclass(frozen=True)
class HipRegression:
    """Hip centre by Harrington et al. (2007) from these pelvis markers."""

    rasis: str
    lasis: str
    sacrum: str


@dataclass(frozen=True)
class StaticCentre:
    """Knee/ankle centre: mid-point of two static markers, carried by a 3-marker cluster."""

    medial: str
    lateral: str
    cluster: tuple[str, str, str]


PointSource = str | HipRegression | StaticCentre


@dataclass(frozen=True)
class InverseOptions:
    """Everything ``predgait inverse`` needs (units: kg, m, Hz, N).

    ``points`` maps hip, knee, ankle, heel, toe to a trial marker name or a joint-centre
    rule. ``cutoff``: Hz, ``CutoffRule.AUTO`` (residual analysis) or None (markers
    unfiltered). ``grf_cutoff``: Hz, None (forces unfiltered) or, by default,
    ``CutoffRule.MARKERS``: the markers' cut-off (Kristianslund et al. 2012, J Biomech
    45:666-671: the same cut-off for both avoids the impact artefacts of mismatched
    filtering). ``threshold``: N, contact threshold; a contact lasts while the force
    stays above ``release`` x threshold (hysteresis, see
    :func:`predgait.data.resample.contact_frames`; 1 = none). ``limit_margin``: deg added to both
    ends of the model's joint ranges for the IK.
    """

    markers: Path
    mass: float | str          # kg, or "plates" (weighed on the plates, data.body_weight)
    points: Mapping[str, PointSource]
    side: Side = Side.RIGHT
    grf: Path | None = None
    static: Path | None = None
    height: float | None = None
    model: Path | None = None
    cutoff: Cutoff = 6.0
    grf_cutoff: Cutoff = CutoffRule.MARKERS
    threshold: float = THRESHOLD
    release: float = RELEASE_FRACTION
    scale_to_markers: bool = True
    max_gap_frames: int = 10
    limit_margin: float = 0.0


def subject01_points(side: Side | str = Side.RIGHT) -> dict[str, PointSource]:
    """Point definitions for the bundled subject01 marker set (Gait2354 example)."""
    s = "R" if str(side) == "right" else "L"
    return {
        "hip": HipRegression("R.ASIS", "L.ASIS", "V.Sacral"),
        "knee": StaticCentre(f"{s}.Knee.Med", f"{s}.Knee.Lat",
                             (f"{s}.Thigh.Upper", f"{s}.Thigh.Front", f"{s}.Thigh.Rear")),
        "ankle": StaticCentre(f"{s}.Ankle.Med", f"{s}.Ankle.Lat",
                              (f"{s}.Shank.Upper", f"{s}.Shank.Front", f"{s}.Shank.Rear")),
        "heel": f"{s}.Heel",
        "toe": f"{s}.Toe.Tip",
    }


def bundled_source(table, key: str = "source") -> str:
    """The trial source a problem table names at ``key``: the bundled trial (the default).

    The one check of a problem file's trial source (leg, gait7, scenarios).

    Raises:
        InputError: Naming the file, key and line, and what to write instead.
    """
    source = table.get(key, str, BUNDLED)
    if source != BUNDLED:
        raise table.error(key, f"{source!r} is not a known trial: use \"{BUNDLED}\" (leg "
                               "problems also take inverse_problem = FILE.toml).")
    return source


def bundled_options(side: Side | str = Side.RIGHT) -> InverseOptions:
    """Options of the bundled subject01 trial (what ``problems/inverse_subject01.toml`` says).

    Its contact threshold stays at the 20 N without hysteresis this trial was first run
    with: the forward engines' stored answers (tests/data/engine_reference.npz) start from
    these moments. Its plates read exactly 0 N unloaded; against OpenSim's results the
    default 10 N with hysteresis changes no r or RMS by more than 0.002.
    """
    folder = bundled_path("subject01_walk1")
    info = subject_info("subject01_walk1")
    return InverseOptions(
        markers=folder / "subject01_walk1.trc", grf=folder / "subject01_walk1_grf.mot",
        static=folder / "subject01_static.trc", mass=info["mass"], height=info["height"],
        side=Side(str(side)), points=subject01_points(side), threshold=20.0, release=1.0)


def with_options(options: InverseOptions, **changes) -> InverseOptions:
    """A copy of ``options`` with some fields changed."""
    return replace(options, **changes)
