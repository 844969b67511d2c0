"""Segment parameters from anthropometry (SI units).

Sources:
    * Thesis Table 3.3.2 (Winter 1990 mass fractions and radii of gyration; Verstraete
      1988 centre-of-mass locations) for the foot, shank ("leg") and thigh.
    * Segment lengths as fractions of standing height: Winter (2009), *Biomechanics and
      Motor Control of Human Movement*, 4th ed., Fig. 4.1 (after Drillis & Contini 1966):
      thigh 0.245 H, shank 0.246 H, foot length 0.152 H, ankle height 0.039 H.
    * Horizontal heel-to-ankle distance: 0.25 of foot length (an estimate; the thesis
      measured it on each subject from the standing trial, section 3.3.2).

Planar models only use the sagittal moment of inertia ``inertia_yy``. The URDF still
needs a full inertia tensor: the segment is taken as axially symmetric about its long
axis with ``Ixx = Iyy`` and ``Izz = 0.1 Iyy``; no planar result depends on Ixx or Izz.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, replace
from enum import StrEnum
from pathlib import Path

from predgait.errors import InputError

#: Subject of the bundled trial (OpenSim subject01: 72.6 kg, 1.8034 m).
DEFAULT_SUBJECT = {"mass": 72.6, "height": 1.8034}

MASS_RANGE_KG = (20.0, 300.0)
HEIGHT_RANGE_M = (0.5, 2.5)

#: Thesis Table 3.3.2: mass as a fraction of body mass (from Winter 1990).
MASS_FRACTION = {"foot": 0.0145, "shank": 0.0465, "thigh": 0.100}
#: Thesis Table 3.3.2: radius of gyration about the COM as a fraction of segment length.
GYRATION_FRACTION = {"foot": 0.475, "shank": 0.302, "thigh": 0.323}
#: Thesis Table 3.3.2: COM along the long axis, as a fraction of length from the
#: proximal joint (thigh: from the greater trochanter, shank: from the knee);
#: foot: 0.564 of the length from the toe, i.e. 0.436 from the heel.
COM_FRACTION_FROM_PROXIMAL = {"foot": 1.0 - 0.564, "shank": 0.384, "thigh": 0.4101}
#: Thesis Table 3.3.2: foot COM height as a fraction of ankle (malleolus) height.
FOOT_COM_HEIGHT_FRACTION = 0.522
#: Winter (2009) Fig. 4.1: segment lengths as fractions of standing height.
LENGTH_FRACTION = {"foot": 0.152, "shank": 0.246, "thigh": 0.245}
ANKLE_HEIGHT_FRACTION = 0.039
#: Heel-to-ankle horizontal distance as a fraction of foot length (estimate).
ANKLE_FROM_HEEL_FRACTION = 0.25

LEG_SEGMENTS = ("foot", "shank", "thigh")


@dataclass(frozen=True)
class Segment:
    """Inertial and geometric parameters of one planar segment.

    Attributes:
        name: Segment name (``foot``, ``shank``, ``thigh`` or ``rod``).
        mass: Mass, kg.
        length: Length, m (foot: heel to toe; others: proximal to distal joint).
        com_fraction: COM position along the long axis as a fraction of ``length``
            from the proximal end (foot: from the heel).
        inertia_yy: Moment of inertia about the COM and the lateral (Y) axis, kg m^2.
    """

    name: str
    mass: float
    length: float
    com_fraction: float
    inertia_yy: float

    @property
    def inertia_xx(self) -> float:
        """Frontal-plane inertia about the COM, kg m^2 (see module docstring)."""
        return self.inertia_yy

    @property
    def inertia_zz(self) -> float:
        """Inertia about the long axis, kg m^2 (see module docstring)."""
        return 0.1 * self.inertia_yy


@dataclass(frozen=True)
class FootGeometry:
    """Position of the heel, toe and COM relative to the ankle joint centre, m.

    Coordinates are in the foot frame (X toward the toe, Z up, origin at the ankle
    joint centre) with the sole flat on the ground.
    """

    heel_x: float
    toe_x: float
    sole_z: float
    com_x: float
    com_z: float


@dataclass(frozen=True)
class LegParameters:
    """Everything the leg URDF generator needs."""

    segments: dict[str, Segment]
    foot: FootGeometry
    body_mass: float | None = None
    height: float | None = None
    source: str = "regressions"


def check_subject(mass: float, height: float) -> None:
    """Raise InputError unless mass (kg) and height (m) are plausible for a person."""
    _check_range("--mass", mass, MASS_RANGE_KG, "kg")
    _check_range("--height", height, HEIGHT_RANGE_M, "m")


def _check_range(field: str, value: float, bounds: tuple[float, float], unit: str) -> None:
    lo, hi = bounds
    if not isinstance(value, int | float) or not math.isfinite(value) or not lo <= value <= hi:
        raise InputError(
            f"{field} = {value!r} {unit} is outside the accepted range {lo:g}..{hi:g} {unit}; "
            f"give the value in {unit}."
        )


def foot_geometry(foot_length: float, ankle_height: float, com_fraction: float) -> FootGeometry:
    """Heel, toe and COM of a flat foot relative to the ankle centre (thesis Table 3.3.2)."""
    heel_x = -ANKLE_FROM_HEEL_FRACTION * foot_length
    return FootGeometry(
        heel_x=heel_x,
        toe_x=heel_x + foot_length,
        sole_z=-ankle_height,
        com_x=heel_x + com_fraction * foot_length,
        com_z=-ankle_height + FOOT_COM_HEIGHT_FRACTION * ankle_height,
    )


def leg_from_subject(mass: float, height: float, *,
                     lengths: dict[str, float] | None = None) -> LegParameters:
    """Leg parameters from body mass (kg) and height (m) by the regressions above.

    Args:
        mass: Body mass, kg.
        height: Standing height, m.
        lengths: Measured segment lengths, m (e.g. joint-centre distances in a static
            trial), replacing the height regressions for the segments named; masses and
            radii of gyration (as fractions of the length) still follow Table 3.3.2.
    """
    check_subject(mass, height)
    lengths = dict(lengths or {})
    unknown = set(lengths) - set(LEG_SEGMENTS)
    if unknown:
        raise InputError(f"unknown segment(s) {', '.join(sorted(unknown))}; segments: "
                         f"{', '.join(LEG_SEGMENTS)}.")
    for name, value in lengths.items():
        _check_range(f"{name} length", value, (0.05, 1.0), "m")
    segments = {}
    for name in LEG_SEGMENTS:
        seg_mass = MASS_FRACTION[name] * mass
        length = lengths.get(name, LENGTH_FRACTION[name] * height)
        radius = GYRATION_FRACTION[name] * length
        segments[name] = Segment(
            name=name,
            mass=seg_mass,
            length=length,
            com_fraction=COM_FRACTION_FROM_PROXIMAL[name],
            inertia_yy=seg_mass * radius**2,
        )
    foot = foot_geometry(
        segments["foot"].length, ANKLE_HEIGHT_FRACTION * height, segments["foot"].com_fraction
    )
    source = "regressions" if not lengths else "regressions, measured lengths"
    return LegParameters(segments=segments, foot=foot, body_mass=mass, height=height,
                         source=source)


SEGMENT_CSV_COLUMNS = ("segment", "mass_kg", "length_m", "com_from_proximal", "inertia_kg_m2")
#: Optional columns: radius of gyration (fraction of length) instead of the inertia; how
#: the foot COM is given; the foot COM offset from the ankle (m, foot frame).
OPTIONAL_CSV_COLUMNS = ("gyration_fraction", "foot_com", "com_x_m", "com_z_m")


class FootCom(StrEnum):
    """Where a segment table puts the foot COM (``foot_com`` column of the foot row)."""

    THESIS = "thesis"          # com_from_proximal from the heel along the foot, at 0.522 of
                               # the ankle height (thesis Table 3.3.2; the default)
    HEEL_TOE = "heel_toe"      # com_from_proximal along the heel-toe line (at the sole)
    ANKLE_TOE = "ankle_toe"    # com_from_proximal from the ankle along the ankle-toe line
                               # (Dempster/Winter: malleolus to 2nd metatarsal head)
    OFFSET = "offset"          # com_x_m, com_z_m from the ankle centre in the foot frame


def _csv_rows(path: Path) -> dict[str, tuple[int, dict[str, str]]]:
    """Segment name -> (line, row) of a segment table; unknown or repeated names refused."""
    from predgait.textfile import read_text

    text = read_text(path, what="segment table CSV", allow_empty=True)
    numbered = [(n, ln) for n, ln in enumerate(text.splitlines(), start=1)
                if ln.strip() and not ln.lstrip().startswith("#")]
    reader = csv.reader([ln for _, ln in numbered])
    header = [h.strip() for h in next(reader, [])]
    required = [c for c in SEGMENT_CSV_COLUMNS if c != "inertia_kg_m2"]
    missing = [c for c in required if c not in header]
    if not {"inertia_kg_m2", "gyration_fraction"} & set(header):
        missing.append("inertia_kg_m2 (or gyration_fraction)")
    if missing:
        raise InputError(f"{path}: missing column(s) {', '.join(missing)}; the file has "
                         f"{', '.join(header) or 'no header'}.")
    unknown = [h for h in header if h not in SEGMENT_CSV_COLUMNS + OPTIONAL_CSV_COLUMNS]
    if unknown:
        raise InputError(f"{path}: unknown column(s) {', '.join(unknown)}; columns: "
                         f"{', '.join(SEGMENT_CSV_COLUMNS + OPTIONAL_CSV_COLUMNS)}.")
    if len(set(header)) != len(header):
        twice = next(h for h in header if header.count(h) > 1)
        raise InputError(f"{path}: column {twice!r} appears twice in the header.")
    rows: dict[str, tuple[int, dict[str, str]]] = {}
    for (line, _), fields in zip(numbered[1:], reader, strict=True):
        row = dict(zip(header, (f.strip() for f in fields), strict=False))
        name = row.get("segment", "").lower()
        if name not in LEG_SEGMENTS:
            raise InputError(f"{path}, line {line}: segment {row.get('segment', '')!r} is not "
                             f"one of {', '.join(LEG_SEGMENTS)}.")
        if name in rows:
            raise InputError(f"{path}, line {line}: segment '{name}' again (first on line "
                             f"{rows[name][0]}); give each segment once.")
        rows[name] = (line, row)
    return rows


def _row(path: Path, rows, name: str) -> tuple[int, dict[str, str]]:
    if name not in rows:
        raise InputError(f"{path}: no row for segment '{name}'; rows needed: "
                         f"{', '.join(LEG_SEGMENTS)}.")
    return rows[name]


def _number(path: Path, line: int, row: dict[str, str], column: str, *, low: float = 0.0,
            high: float = math.inf, strict: bool = True, signed: bool = False) -> float:
    text = row.get(column, "")
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    bad = not math.isfinite(value) or (not signed and (value < low or value > high
                                                       or (strict and value == low)))
    if bad:
        what = ("a number" if signed else f"a number in {low:g}..{high:g}" if not strict
                else "a positive number")
        raise InputError(f"{path}, line {line}, column {column}: {text!r} is not {what} "
                         "(SI units: kg, m, kg m^2).")
    return value


def leg_from_csv(path: str | Path) -> LegParameters:
    """Leg parameters from a lab's own segment table.

    The CSV has a header ``segment,mass_kg,length_m,com_from_proximal,inertia_kg_m2`` and
    one row each for ``foot``, ``shank`` and ``thigh``: mass (kg), length (m; foot: heel
    to toe), COM as a fraction 0..1 of the length from the proximal joint and the
    sagittal moment of inertia about the COM (kg m^2). Optional columns:

    * ``gyration_fraction``: radius of gyration about the COM as a fraction of the
      length, for rows whose ``inertia_kg_m2`` is empty (I = m (k L)^2).
    * ``foot_com`` (foot row): ``thesis`` (default: from the heel along the foot, at
      0.522 of the ankle height, thesis Table 3.3.2), ``heel_toe`` (along the heel-toe
      line), ``ankle_toe`` (from the ankle centre along the ankle-toe line, as Dempster's
      and Winter's tables give it) or ``offset`` (``com_x_m``, ``com_z_m``: from the
      ankle centre in the foot frame, X toward the toe, Z up; ``0, 0`` = at the ankle).

    The ankle height and the heel-to-ankle distance are scaled from the foot length by
    the regression ratios.

    Raises:
        InputError: The file is missing; a column is missing or unknown; a segment is
            missing, unknown or repeated; a value is out of range.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: segment table not found; give a CSV with columns "
                         f"{', '.join(SEGMENT_CSV_COLUMNS)}.")
    rows = _csv_rows(path)
    line, foot_row = _row(path, rows, "foot")
    try:
        foot_com = FootCom(foot_row.get("foot_com", "") or FootCom.THESIS)
    except ValueError:
        raise InputError(f"{path}, line {line}, column foot_com: "
                         f"{foot_row.get('foot_com')!r} is not one of "
                         f"{', '.join(c.value for c in FootCom)}.") from None
    segments = {}
    for name in LEG_SEGMENTS:
        line, row = _row(path, rows, name)
        for column in ("foot_com", "com_x_m", "com_z_m"):
            if name != "foot" and row.get(column, ""):
                raise InputError(f"{path}, line {line}, column {column}: only the foot row "
                                 "takes it; leave it empty.")
        mass = _number(path, line, row, "mass_kg")
        length = _number(path, line, row, "length_m")
        offset = name == "foot" and foot_com is FootCom.OFFSET
        fraction = (math.nan if offset and not row.get("com_from_proximal", "")
                    else _number(path, line, row, "com_from_proximal", high=1.0, strict=False))
        if row.get("inertia_kg_m2", ""):
            if row.get("gyration_fraction", ""):
                raise InputError(f"{path}, line {line}: give inertia_kg_m2 or "
                                 "gyration_fraction, not both.")
            inertia = _number(path, line, row, "inertia_kg_m2")
        else:
            inertia = mass * (_number(path, line, row, "gyration_fraction") * length) ** 2
        segments[name] = Segment(name, mass, length, fraction, inertia)
    foot_len = segments["foot"].length
    ankle_height = ANKLE_HEIGHT_FRACTION / LENGTH_FRACTION["foot"] * foot_len
    geometry = foot_geometry(foot_len, ankle_height,
                             0.0 if offset else segments["foot"].com_fraction)
    line, row = rows["foot"]
    fraction = segments["foot"].com_fraction
    if foot_com is FootCom.HEEL_TOE:
        geometry = replace(geometry, com_z=geometry.sole_z)
    elif foot_com is FootCom.ANKLE_TOE:
        geometry = replace(geometry, com_x=fraction * geometry.toe_x,
                           com_z=fraction * geometry.sole_z)
    elif foot_com is FootCom.OFFSET:
        geometry = replace(geometry, com_x=_number(path, line, row, "com_x_m", signed=True),
                           com_z=_number(path, line, row, "com_z_m", signed=True))
    return LegParameters(segments=segments, foot=geometry, source=str(path))


#: Thesis rod (section 3.2.1): diameter 3.5 cm, length/diameter 37.2.
ROD_DIAMETER_M = 0.035
ROD_LENGTH_M = 37.2 * ROD_DIAMETER_M
#: Hardwood density, kg/m^3 (estimate; the thesis does not give the rod's mass).
HARDWOOD_DENSITY = 700.0
ROD_MASS_KG = HARDWOOD_DENSITY * math.pi * (ROD_DIAMETER_M / 2) ** 2 * ROD_LENGTH_M


def rod_segment(mass: float = ROD_MASS_KG, length: float = ROD_LENGTH_M) -> Segment:
    """Uniform slender rod: COM at mid-length, I = m L^2 / 12 (thesis 3.2.3)."""
    _check_range("--mass", mass, (0.01, 100.0), "kg")
    _check_range("--length", length, (0.05, 10.0), "m")
    return Segment("rod", mass, length, 0.5, mass * length**2 / 12.0)
