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
from dataclasses import dataclass
from pathlib import Path

from predgait.errors import InputError

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


def leg_from_csv(path: str | Path) -> LegParameters:
    """Leg parameters from a lab's own segment table.

    The CSV has a header ``segment,mass_kg,length_m,com_from_proximal,inertia_kg_m2`` and
    one row each for ``foot``, ``shank`` and ``thigh``: mass (kg), length (m; foot: heel
    to toe), COM as a fraction of length from the proximal joint (foot: from the heel)
    and the sagittal moment of inertia about the COM (kg m^2). The ankle height and the
    heel-to-ankle distance are scaled from the foot length by the regression ratios.

    Raises:
        InputError: The file is missing, a column or segment is missing, or a value is
            not a positive finite number.
    """
    from predgait.textfile import read_text

    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: segment table not found; give a CSV with columns "
                         f"{', '.join(SEGMENT_CSV_COLUMNS)}.")
    text = read_text(path, what="segment table CSV", allow_empty=True)
    numbered = [(n, ln) for n, ln in enumerate(text.splitlines(), start=1)
                if ln.strip() and not ln.lstrip().startswith("#")]
    reader = csv.reader([ln for _, ln in numbered])
    header = [h.strip() for h in next(reader, [])]
    missing = [c for c in SEGMENT_CSV_COLUMNS if c not in header]
    if missing:
        raise InputError(f"{path}: missing column(s) {', '.join(missing)}; the file has "
                         f"{', '.join(header) or 'no header'}.")
    if len(set(header)) != len(header):
        twice = next(h for h in header if header.count(h) > 1)
        raise InputError(f"{path}: column {twice!r} appears twice in the header.")
    rows = {}
    for (line, _), fields in zip(numbered[1:], reader, strict=True):
        row = dict(zip(header, (f.strip() for f in fields), strict=False))
        name = row.get("segment", "").lower()
        if name not in LEG_SEGMENTS:
            raise InputError(f"{path}, line {line}: segment {row.get('segment', '')!r} is not "
                             f"one of {', '.join(LEG_SEGMENTS)}.")
        if name in rows:
            raise InputError(f"{path}, line {line}: segment '{name}' again (first on line "
                             f"{rows[name][0]}); give each segment once.")
        rows[name] = (line, {c: row.get(c, "") for c in SEGMENT_CSV_COLUMNS})
    segments = {}
    for name in LEG_SEGMENTS:
        if name not in rows:
            raise InputError(f"{path}: no row for segment '{name}'; rows needed: "
                             f"{', '.join(LEG_SEGMENTS)}.")
        line, row = rows[name]
        values = {}
        for column in SEGMENT_CSV_COLUMNS[1:]:
            try:
                value = float(row[column])
            except ValueError:
                value = math.nan
            if not math.isfinite(value) or value <= 0:
                raise InputError(f"{path}, line {line}, column {column}: {row[column]!r} is "
                                 f"not a positive number (SI units: kg, m, kg m^2).")
            values[column] = value
        if values["com_from_proximal"] >= 1:
            raise InputError(f"{path}, line {line}, column com_from_proximal: must be a "
                             f"fraction of the segment length between 0 and 1.")
        segments[name] = Segment(name, values["mass_kg"], values["length_m"],
                                 values["com_from_proximal"], values["inertia_kg_m2"])
    foot_len = segments["foot"].length
    ankle_height = ANKLE_HEIGHT_FRACTION / LENGTH_FRACTION["foot"] * foot_len
    foot = foot_geometry(foot_len, ankle_height, segments["foot"].com_fraction)
    return LegParameters(segments=segments, foot=foot, source=str(path))


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
