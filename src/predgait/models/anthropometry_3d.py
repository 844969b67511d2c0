"""Whole-body segment parameters from height, mass and sex (SI units).

Source of the inertial parameters:
    de Leva P. (1996) Adjustments to Zatsiorsky-Seluyanov's segment inertia parameters.
    J Biomech 29(9):1223-1230, Table 4 (mass as a fraction of body mass, COM position
    as a fraction of the segment length from the first endpoint, radii of gyration about
    the COM as fractions of the length: sagittal, transverse, longitudinal). The table's
    reference subjects are 1.741 m / 73.0 kg (male) and 1.735 m / 61.9 kg (female);
    segment lengths here are the table lengths scaled by ``height / reference stature``.

Axes of the radii: "sagittal" is read as the radius about the mediolateral axis
(rotation in the sagittal plane, segment Y), "transverse" as the radius about the
anteroposterior axis (segment X) and "longitudinal" about the long axis (segment Z; the
foot's long axis is X). The paper leaves the first two ambiguous; they differ by < 10 %.

Geometry that de Leva does not give (documented estimates, fractions of height H):
    * Ankle (lateral malleolus) height 0.039 H and heel-to-ankle distance 0.25 of the foot
      length (:mod:`predgait.models.anthropometry`, after Winter 2009 Fig. 4.1).
    * Pelvis width (inter-ASIS distance) PW = 0.142 H; hip joint centres 30 % PW distal,
      22 % PW posterior and 36 % PW lateral of the mid-ASIS point (Bell, Pedersen & Brand
      1990, J Biomech 23:617-621); ASIS-PSIS depth 0.65 PW, PSIS 0.18 PW off the midline.
    * Shoulder joint centres 0.094 H lateral of the midline at the suprasternale level.
    * Foot breadth 0.055 H with foot length 0.152 H (Winter 2009 Fig. 4.1, after Drillis &
      Contini 1966), used as breadth = 0.055 / 0.152 of the (given) foot length: the
      medial and lateral sole points lie half of it either side of the foot's centre
      line, at the heel and at the toe (a rectangular sole; the real heel is narrower).

Subject-specific lengths (e.g. measured on a static trial, :mod:`predgait.kinematics.scaling`)
replace the height-scaled ones through ``lengths`` mappings keyed like
:func:`default_lengths`; masses stay fractions of body mass and radii of gyration stay
fractions of the (new) length.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from enum import StrEnum

import numpy as np

from predgait.errors import InputError
from predgait.models.anthropometry import (
    ANKLE_HEIGHT_FRACTION,
    FootGeometry,
    check_subject,
    foot_geometry,
)


class Sex(StrEnum):
    """Sex column of de Leva's Table 4."""

    MALE = "male"
    FEMALE = "female"


@dataclass(frozen=True)
class DeLevaRow:
    """One row of de Leva (1996) Table 4 (one sex).

    Attributes:
        length_mm: Mean segment length of the reference sample, mm (endpoints below).
        mass: Mass, fraction of body mass.
        com: COM, fraction of the length from the first endpoint.
        r_sag, r_trans, r_long: Radii of gyration about the COM, fractions of the length.
    """

    length_mm: float
    mass: float
    com: float
    r_sag: float
    r_trans: float
    r_long: float


#: de Leva (1996) Table 4 reference statures, m.
REFERENCE_STATURE = {Sex.MALE: 1.741, Sex.FEMALE: 1.735}

#: de Leva (1996) Table 4, segments and endpoints (first -> second):
#: head VERT->MIDG (vertex to mid-gonion); upper trunk UPT SUPR->XYPH (suprasternale to
#: xiphoid); middle trunk MPT XYPH->OMPH (omphalion); lower trunk LPT OMPH->MIDH (mid
#: hip joint centres); upper arm SJC->EJC; forearm EJC->WJC; hand WJC->MET3; thigh
#: HJC->KJC; shank KJC->LMAL (lateral malleolus); foot HEEL->TTIP (toe tip).
DE_LEVA_TABLE4: dict[Sex, dict[str, DeLevaRow]] = {
    Sex.MALE: {
        "head": DeLevaRow(203.3, 0.0694, 0.5976, 0.362, 0.376, 0.312),
        "upper_trunk": DeLevaRow(170.7, 0.1596, 0.2999, 0.716, 0.454, 0.659),
        "middle_trunk": DeLevaRow(215.5, 0.1633, 0.4502, 0.482, 0.383, 0.468),
        "lower_trunk": DeLevaRow(145.7, 0.1117, 0.6115, 0.615, 0.551, 0.587),
        "upper_arm": DeLevaRow(281.7, 0.0271, 0.5772, 0.285, 0.269, 0.158),
        "forearm": DeLevaRow(268.9, 0.0162, 0.4574, 0.276, 0.265, 0.121),
        "hand": DeLevaRow(86.2, 0.0061, 0.7900, 0.628, 0.513, 0.401),
        "thigh": DeLevaRow(422.2, 0.1416, 0.4095, 0.329, 0.329, 0.149),
        "shank": DeLevaRow(434.0, 0.0433, 0.4459, 0.255, 0.249, 0.103),
        "foot": DeLevaRow(258.1, 0.0137, 0.4415, 0.257, 0.245, 0.124),
    },
    Sex.FEMALE: {
        "head": DeLevaRow(200.2, 0.0668, 0.5894, 0.330, 0.359, 0.318),
        "upper_trunk": DeLevaRow(142.5, 0.1545, 0.2077, 0.746, 0.502, 0.718),
        "middle_trunk": DeLevaRow(205.3, 0.1465, 0.4512, 0.433, 0.354, 0.415),
        "lower_trunk": DeLevaRow(181.5, 0.1247, 0.4920, 0.433, 0.402, 0.444),
        "upper_arm": DeLevaRow(275.1, 0.0255, 0.5754, 0.278, 0.260, 0.148),
        "forearm": DeLevaRow(264.3, 0.0138, 0.4559, 0.261, 0.257, 0.094),
        "hand": DeLevaRow(78.0, 0.0056, 0.7474, 0.531, 0.454, 0.335),
        "thigh": DeLevaRow(368.5, 0.1478, 0.3612, 0.369, 0.364, 0.162),
        "shank": DeLevaRow(432.3, 0.0481, 0.4416, 0.271, 0.267, 0.093),
        "foot": DeLevaRow(228.3, 0.0129, 0.4014, 0.299, 0.279, 0.139),
    },
}

PELVIS_WIDTH_FRACTION = 0.142
HJC_FROM_MID_ASIS = (-0.22, 0.36, -0.30)  # x (posterior), |y| (lateral), z (distal), x PW
PELVIS_DEPTH_FRACTION = 0.65
PSIS_HALF_WIDTH_FRACTION = 0.18
SHOULDER_HALF_WIDTH_FRACTION = 0.094
#: Winter (2009) Fig. 4.1 (Drillis & Contini 1966): foot breadth / foot length.
FOOT_BREADTH_PER_LENGTH = 0.055 / 0.152


@dataclass(frozen=True)
class Segment3D:
    """A rigid segment: mass, length, COM and principal inertia in its own frame.

    Attributes:
        name: Segment name (de Leva row name).
        mass: kg.
        length: m (between the table's endpoints).
        com: (3,) COM in the segment frame, m.
        inertia: (3,) principal moments of inertia about the COM along the segment
            frame axes X, Y, Z, kg m^2.
    """

    name: str
    mass: float
    length: float
    com: tuple[float, float, float]
    inertia: tuple[float, float, float]


def parse_sex(value: str | Sex) -> Sex:
    """Sex from text, with a clear error."""
    try:
        return Sex(str(value).lower())
    except ValueError:
        raise InputError(f"--sex = {value!r}; choose male or female.") from None


def scaled_length(name: str, height: float, sex: Sex) -> float:
    """Length of ``name`` scaled to ``height`` (m)."""
    return DE_LEVA_TABLE4[sex][name].length_mm / 1000.0 * height / REFERENCE_STATURE[sex]


def default_lengths(height: float, sex: Sex) -> dict[str, float]:
    """Lengths (m) scaled to ``height``.

    Keys: every Table 4 row, ``pelvis_width`` (inter-ASIS) and ``shoulder_width``
    (between the shoulder joint centres).
    """
    out = {name: scaled_length(name, height, sex) for name in DE_LEVA_TABLE4[sex]}
    out["pelvis_width"] = PELVIS_WIDTH_FRACTION * height
    out["shoulder_width"] = 2.0 * SHOULDER_HALF_WIDTH_FRACTION * height
    return out


def segment(name: str, mass: float, height: float, sex: Sex, *,
            com_vector: np.ndarray, long_axis: str = "z", length: float | None = None
            ) -> Segment3D:
    """Segment ``name`` with its COM at ``com_vector`` (m, segment frame).

    Radii of gyration scale with the segment ``length`` (m; default: de Leva's scaled
    to ``height``); ``long_axis`` is the frame axis of the segment's length (z, or x for
    the foot).
    """
    row = DE_LEVA_TABLE4[sex][name]
    length = scaled_length(name, height, sex) if length is None else length
    seg_mass = row.mass * mass
    sag, trans, lon = (seg_mass * (r * length) ** 2 for r in (row.r_sag, row.r_trans,
                                                              row.r_long))
    inertia = (lon, sag, trans) if long_axis == "x" else (trans, sag, lon)
    return Segment3D(name, seg_mass, length, tuple(float(c) for c in com_vector), inertia)


@dataclass(frozen=True)
class BodyGeometry:
    """Landmark distances (m) used by the whole-body generator."""

    ankle_height: float
    pelvis_width: float
    hip_half_width: float
    vertex_above_lumbar: float
    suprasternale_above_lumbar: float
    shoulder_half_width: float


def body_geometry(mass: float, height: float, sex: Sex,
                  lengths: Mapping[str, float] | None = None) -> BodyGeometry:
    """Landmark geometry for a subject (see module docstring for the sources).

    Args:
        mass: Body mass, kg.
        height: Standing height, m.
        sex: de Leva column.
        lengths: m, keyed like :func:`default_lengths`; given ones replace the defaults.
            The vertex stays above the suprasternale by the height-based distance scaled
            by ``head`` / default head length.
    """
    check_subject(mass, height)
    base = default_lengths(height, sex)
    size = base | dict(lengths or {})
    ankle_height = ANKLE_HEIGHT_FRACTION * height
    lumbar = ankle_height + base["shank"] + base["thigh"] + base["lower_trunk"]
    supr = size["middle_trunk"] + size["upper_trunk"]
    neck_head = height - lumbar - (base["middle_trunk"] + base["upper_trunk"])
    return BodyGeometry(
        ankle_height=ankle_height,
        pelvis_width=size["pelvis_width"],
        hip_half_width=HJC_FROM_MID_ASIS[1] * size["pelvis_width"],
        vertex_above_lumbar=supr + neck_head * size["head"] / base["head"],
        suprasternale_above_lumbar=supr,
        shoulder_half_width=0.5 * size["shoulder_width"],
    )


def foot_breadth(foot_length: float) -> float:
    """Foot breadth (m) of a foot ``foot_length`` (m) long (:data:`FOOT_BREADTH_PER_LENGTH`)."""
    return FOOT_BREADTH_PER_LENGTH * foot_length


def foot(foot_length: float, height: float, sex: Sex) -> FootGeometry:
    """Heel, toe (sole) and COM of the foot relative to the ankle centre, m."""
    return foot_geometry(foot_length, ANKLE_HEIGHT_FRACTION * height,
                         DE_LEVA_TABLE4[sex]["foot"].com)
