"""3D whole-body URDF in the ADAMS/Android layout (thesis 2.3.2): 35 degrees of freedom.

Pelvis 6 (free flyer, added by :mod:`predgait.models.loading3d`, not a URDF joint);
three rotations (Cardan X-Y-Z) at each hip, knee, ankle, the lumbar joint and each
shoulder; one at each elbow: 6 + 3 x 6 + 3 + 3 x 2 + 2 = 35.

Cardan convention (thesis 2.3.2, after Greenwood 1988): the distal frame is the proximal
frame rotated first about X, then about the new Y, then about the newest Z, so
``R = Rx(a) Ry(b) Rz(c)``. Each 3-DOF joint is a chain of three revolute joints
``<joint>_x``, ``<joint>_y``, ``<joint>_z`` through two massless links (explicit zero-mass
``<inertial>``, which ADAM reads).

Frames: every segment frame has X forward, Y left, Z up when all coordinates are zero
(upright standing, arms hanging, feet flat); its origin is at the segment's proximal
joint centre (pelvis: mid-point of the hip joint centres; torso: lumbar joint; foot:
ankle centre). Right side = -Y. For the legs, positive Y rotations are hip extension,
knee flexion and ankle plantarflexion; for the elbow, flexion is negative.

Segments (de Leva 1996 Table 4, :mod:`predgait.models.anthropometry_3d`): pelvis = lower
trunk (LPT); torso = middle trunk (MPT) with the upper trunk (UPT) and head on fixed
joints; thighs, shanks, feet, upper arms, forearms with the hands on fixed joints.

Marker frames (skin markers, first estimates; calibrate them on a static trial) and
joint-centre frames are massless links on fixed joints (names in :data:`MARKERS`,
:data:`JOINT_CENTRES`); ``heel_contact_*`` and ``toe_contact_*`` lie on the sole's centre
line, the :data:`SOLE_EDGES` half a foot breadth medial and lateral of them
(:func:`predgait.models.anthropometry_3d.foot_breadth`), ``ball_contact_*`` (:data:`BALLS`)
between them under the metatarsal heads: a problem's ``[contact] frames`` picks a set.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from predgait.errors import InputError
from predgait.models import anthropometry_3d as a3
from predgait.models.anthropometry_3d import Segment3D, Sex
from predgait.models.urdf import xml_text

KIND = "fullbody"

#: Joint ranges, rad: (x, y, z) for the 3-DOF joints (legs: y + = extension at the hip,
#: flexion at the knee, plantarflexion at the ankle), y only for the elbow.
JOINT_LIMITS: dict[str, tuple[tuple[float, float], ...]] = {
    "hip": ((-0.8, 0.8), (-2.2, 0.7), (-0.9, 0.9)),
    "knee": ((-0.35, 0.35), (-0.25, 2.6), (-0.7, 0.7)),
    "ankle": ((-0.7, 0.7), (-1.0, 1.0), (-0.8, 0.8)),
    "lumbar": ((-0.7, 0.7), (-0.6, 1.3), (-0.9, 0.9)),
    "shoulder": ((-2.0, 2.0), (-3.1, 1.3), (-1.6, 1.6)),
    "elbow": ((-2.7, 0.1),),
}

SIDES = ("r", "l")
MARKERS = (
    "asis_r", "asis_l", "psis_r", "psis_l", "sacrum",
    "thigh_lat_r", "thigh_lat_l", "knee_lat_r", "knee_lat_l", "tibia_r", "tibia_l",
    "ankle_lat_r", "ankle_lat_l", "heel_r", "heel_l", "toe_r", "toe_l",
    "c7", "sternum", "shoulder_r", "shoulder_l", "elbow_lat_r", "elbow_lat_l",
    "wrist_r", "wrist_l", "head_top",
)
JOINT_CENTRES = (
    "hip_center_r", "hip_center_l", "knee_center_r", "knee_center_l",
    "ankle_center_r", "ankle_center_l", "shoulder_center_r", "shoulder_center_l",
    "elbow_center_r", "elbow_center_l", "lumbar_center",
)
CONTACTS = ("heel_contact_r", "heel_contact_l", "toe_contact_r", "toe_contact_l")
#: Medial and lateral sole points at the heel and at the toe (4 per foot): the ground
#: then supports the foot about its heel-toe line too.
SOLE_EDGES = tuple(f"{end}_{edge}_contact_{side}" for side in SIDES
                   for end in ("heel", "toe") for edge in ("medial", "lateral"))
#: Sole points under the metatarsal heads (the ball of the foot), on the centre line:
#: after heel-off the plates' COP lies there, not at the toe tip (issue 27).
BALLS = ("ball_contact_r", "ball_contact_l")
#: Metatarsal heads (and the toe marker) from the heel, fraction of the foot length.
BALL_FRACTION = 0.72


def _num(value: float) -> str:
    text = f"{value:.10g}"
    return "0" if text in ("-0", "0") else text


def _vec(values) -> str:
    return " ".join(_num(v) for v in values)


def _link(name: str, segment: Segment3D | None = None) -> str:
    if segment is None:  # massless (Cardan intermediate link), explicit for ADAM
        mass, com, inertia = 0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    else:
        mass, com, inertia = segment.mass, segment.com, segment.inertia
    return (
        f'  <link name="{name}">\n    <inertial>\n'
        f'      <origin xyz="{_vec(com)}" rpy="0 0 0"/>\n'
        f'      <mass value="{_num(mass)}"/>\n'
        f'      <inertia ixx="{_num(inertia[0])}" ixy="0" ixz="0" iyy="{_num(inertia[1])}" '
        f'iyz="0" izz="{_num(inertia[2])}"/>\n'
        "    </inertial>\n  </link>\n"
    )


def _fixed(name: str, parent: str, xyz, *, massive: Segment3D | None = None) -> str:
    link = _link(name, massive) if massive is not None else f'  <link name="{name}"/>\n'
    return link + (
        f'  <joint name="{name}_fixed" type="fixed">\n'
        f'    <parent link="{parent}"/>\n    <child link="{name}"/>\n'
        f'    <origin xyz="{_vec(xyz)}" rpy="0 0 0"/>\n  </joint>\n'
    )


def _revolute(name: str, parent: str, child: str, xyz, axis: str,
              limits: tuple[float, float]) -> str:
    return (
        f'  <joint name="{name}" type="revolute">\n'
        f'    <parent link="{parent}"/>\n    <child link="{child}"/>\n'
        f'    <origin xyz="{_vec(xyz)}" rpy="0 0 0"/>\n'
        f'    <axis xyz="{axis}"/>\n'
        f'    <limit lower="{_num(limits[0])}" upper="{_num(limits[1])}" effort="1000" '
        'velocity="50"/>\n  </joint>\n'
    )


def _cardan(joint: str, kind: str, parent: str, child: str, xyz) -> str:
    """X-Y-Z chain of revolute joints from ``parent`` to ``child`` at ``xyz``."""
    lim = JOINT_LIMITS[kind]
    return (
        _revolute(f"{joint}_x", parent, f"{joint}_x_link", xyz, "1 0 0", lim[0])
        + _link(f"{joint}_x_link")
        + _revolute(f"{joint}_y", f"{joint}_x_link", f"{joint}_y_link", (0, 0, 0), "0 1 0",
                    lim[1])
        + _link(f"{joint}_y_link")
        + _revolute(f"{joint}_z", f"{joint}_y_link", child, (0, 0, 0), "0 0 1", lim[2])
    )


#: Per-body lengths the builder takes (m) -> key of :func:`a3.default_lengths`:
#: pelvis = lower trunk (hip centres to lumbar joint), torso = middle trunk, upper_trunk,
#: head (scales the suprasternale-vertex distance), pelvis_width (inter-ASIS, places the
#: hips, ASIS, PSIS, sacrum), shoulder_width (between the shoulder joint centres), and per
#: side thigh (hip-knee), shank (knee-ankle), foot (heel-toe tip), upper_arm (shoulder-
#: elbow), forearm (elbow-wrist), hand.
LENGTHS: dict[str, str] = {
    "pelvis": "lower_trunk", "torso": "middle_trunk", "upper_trunk": "upper_trunk",
    "head": "head", "pelvis_width": "pelvis_width", "shoulder_width": "shoulder_width",
    **{f"{seg}_{side}": seg for seg in ("thigh", "shank", "foot", "upper_arm", "forearm", "hand")
       for side in SIDES},
}


def segment_lengths(height: float, sex: Sex | str,
                    lengths: Mapping[str, float] | None = None) -> dict[str, float]:
    """Lengths of :data:`LENGTHS` (m): de Leva's scaled to ``height``, or ``lengths``.

    Raises:
        InputError: an unknown name or a length outside 0.01 m .. ``height``.
    """
    sex = a3.parse_sex(sex)
    base = a3.default_lengths(height, sex)
    out = {name: base[key] for name, key in LENGTHS.items()}
    for name, value in (lengths or {}).items():
        if name not in out:
            raise InputError(f"segment length {name!r} unknown; lengths: {', '.join(LENGTHS)}.")
        if not np.isfinite(value) or not 0.01 <= value <= height:
            raise InputError(f"segment length {name} = {value!r} m is outside 0.01..{height:g} m.")
        out[name] = float(value)
    return out


def _geometry(mass: float, height: float, sex: Sex, size: dict[str, float]) -> a3.BodyGeometry:
    return a3.body_geometry(mass, height, sex, {LENGTHS[k]: v for k, v in size.items()
                                                if not k.endswith(("_r", "_l"))})


def fullbody_segments(mass: float, height: float, sex: Sex | str,
                      lengths: Mapping[str, float] | None = None) -> dict[str, Segment3D]:
    """All segments (one side's limbs named ``*_r``/``*_l``), COM in their link frames.

    ``lengths`` (m, names of :data:`LENGTHS`) replace the height-scaled lengths.
    """
    sex = a3.parse_sex(sex)
    size = segment_lengths(height, sex, lengths)
    geo = _geometry(mass, height, sex, size)
    t4 = a3.DE_LEVA_TABLE4[sex]

    def seg(body, **kw):
        return a3.segment(LENGTHS[body], mass, height, sex, length=size[body], **kw)

    def down(body):  # COM below the proximal joint, first endpoint at top
        return (0.0, 0.0, -t4[LENGTHS[body]].com * size[body])

    lpt, mpt, upt = size["pelvis"], size["torso"], size["upper_trunk"]
    supr = geo.suprasternale_above_lumbar
    segs = {
        # LPT: OMPH (top, z = lpt) -> MIDH (origin).
        "pelvis": seg("pelvis", com_vector=(0, 0, lpt * (1 - t4["lower_trunk"].com))),
        # Torso frame at the lumbar joint (OMPH). MPT: XYPH (z = mpt) -> OMPH.
        "torso": seg("torso", com_vector=(0, 0, mpt * (1 - t4["middle_trunk"].com))),
        "upper_trunk": seg("upper_trunk", com_vector=(0, 0, supr - t4["upper_trunk"].com * upt)),
        "head": seg("head", com_vector=(0, 0, geo.vertex_above_lumbar
                                        - t4["head"].com * size["head"])),
    }
    for side in SIDES:
        foot = a3.foot(size[f"foot_{side}"], height, sex)
        for body in ("thigh", "shank", "upper_arm", "forearm", "hand"):
            segs[f"{body}_{side}"] = seg(f"{body}_{side}", com_vector=down(f"{body}_{side}"))
        segs[f"foot_{side}"] = seg(f"foot_{side}", com_vector=(foot.com_x, 0.0, foot.com_z),
                                   long_axis="x")
    return {name: Segment3D(name, s.mass, s.length, s.com, s.inertia)
            for name, s in segs.items()}


def _marker_positions(height: float, sex: Sex, geo: a3.BodyGeometry,
                      size: dict[str, float]) -> dict:
    """(parent link, xyz) of each marker, joint-centre and contact frame."""
    pw, h = geo.pelvis_width, height
    supr = geo.suprasternale_above_lumbar
    asis = (-a3.HJC_FROM_MID_ASIS[0] * pw, -a3.HJC_FROM_MID_ASIS[2] * pw)  # x, z from MIDH
    ha = geo.ankle_height
    out = {
        "sacrum": ("pelvis", (asis[0] - a3.PELVIS_DEPTH_FRACTION * pw, 0, asis[1])),
        "c7": ("torso", (-0.06 * h, 0, supr + 0.04 * h)),
        "sternum": ("torso", (0.06 * h, 0, supr - 0.05 * h)),
        "head_top": ("torso", (0, 0, geo.vertex_above_lumbar)),
        "lumbar_center": ("torso", (0, 0, 0)),
    }
    for side, sign in (("r", -1.0), ("l", 1.0)):
        lt, ls = size[f"thigh_{side}"], size[f"shank_{side}"]
        lu, lf = size[f"upper_arm_{side}"], size[f"forearm_{side}"]
        foot = a3.foot(size[f"foot_{side}"], height, sex)
        foot_len = foot.toe_x - foot.heel_x
        half_breadth = 0.5 * a3.foot_breadth(foot_len)
        ball_x = foot.heel_x + BALL_FRACTION * foot_len
        out |= {
            f"asis_{side}": ("pelvis", (asis[0], sign * 0.5 * pw, asis[1])),
            f"psis_{side}": ("pelvis", (asis[0] - a3.PELVIS_DEPTH_FRACTION * pw,
                                        sign * a3.PSIS_HALF_WIDTH_FRACTION * pw, asis[1])),
            f"hip_center_{side}": ("pelvis", (0, sign * geo.hip_half_width, 0)),
            f"thigh_lat_{side}": (f"thigh_{side}", (0, sign * 0.045 * h, -0.5 * lt)),
            f"knee_lat_{side}": (f"thigh_{side}", (0, sign * 0.028 * h, -lt)),
            f"knee_center_{side}": (f"thigh_{side}", (0, 0, -lt)),
            f"tibia_{side}": (f"shank_{side}", (0.015 * h, sign * 0.025 * h, -0.5 * ls)),
            f"ankle_lat_{side}": (f"shank_{side}", (0, sign * 0.02 * h, -ls)),
            f"ankle_center_{side}": (f"shank_{side}", (0, 0, -ls)),
            f"heel_{side}": (f"foot_{side}", (foot.heel_x - 0.005 * h, 0, -ha + 0.015 * h)),
            f"toe_{side}": (f"foot_{side}", (ball_x, 0, -0.35 * ha)),
            f"heel_contact_{side}": (f"foot_{side}", (foot.heel_x, 0, -ha)),
            f"ball_contact_{side}": (f"foot_{side}", (ball_x, 0, -ha)),
            f"toe_contact_{side}": (f"foot_{side}", (foot.toe_x, 0, -ha)),
            **{f"{end}_{edge}_contact_{side}": (f"foot_{side}", (x, lateral * half_breadth, -ha))
               for end, x in (("heel", foot.heel_x), ("toe", foot.toe_x))
               for edge, lateral in (("medial", -sign), ("lateral", sign))},
            f"shoulder_{side}": ("torso", (0, sign * (geo.shoulder_half_width + 0.02 * h),
                                           supr + 0.02 * h)),
            f"shoulder_center_{side}": ("torso", (0, sign * geo.shoulder_half_width, supr)),
            f"elbow_lat_{side}": (f"upper_arm_{side}", (0, sign * 0.02 * h, -lu)),
            f"elbow_center_{side}": (f"upper_arm_{side}", (0, 0, -lu)),
            f"wrist_{side}": (f"forearm_{side}", (0, sign * 0.015 * h, -lf)),
        }
    return out


def build_fullbody_urdf(mass: float, height: float, sex: Sex | str = Sex.MALE, *,
                        lengths: Mapping[str, float] | None = None) -> str:
    """URDF text of the 35-DOF whole body for a subject.

    Args:
        mass: Body mass, kg.
        height: Standing height, m.
        sex: ``male`` or ``female`` (selects de Leva's column).
        lengths: Subject-specific lengths, m, names of :data:`LENGTHS` (e.g. from
            :mod:`predgait.kinematics.scaling`); the others follow ``height``. Segment
            masses stay de Leva's fractions of ``mass``.

    Returns:
        URDF text; the root link is ``pelvis`` (free flyer added by the loader).
    """
    sex = a3.parse_sex(sex)
    size = segment_lengths(height, sex, lengths)
    geo = _geometry(mass, height, sex, size)
    segs = fullbody_segments(mass, height, sex, lengths)
    frames = _marker_positions(height, sex, geo, size)
    scaled = ("" if not lengths else "\n     Segment lengths (m) given: " + ", ".join(
        f"{k} {_num(v)}" for k, v in sorted(lengths.items())) + ".")
    parts = [
        '<?xml version="1.0"?>\n'
        f"<!-- Generated by predgait.models.fullbody: 35-DOF whole body (de Leva 1996), "
        f"body mass {_num(mass)} kg, height {_num(height)} m, sex {xml_text(sex.value)}.{scaled}\n"
        f"     Do not edit by hand. predgait: kind={KIND} base=free_flyer -->\n"
        '<robot name="predgait_fullbody">\n',
        _link("pelvis", segs["pelvis"]),
        _cardan("lumbar", "lumbar", "pelvis", "torso", (0, 0, size["pelvis"])),
        _link("torso", segs["torso"]),
        _fixed("upper_trunk", "torso", (0, 0, 0), massive=segs["upper_trunk"]),
        _fixed("head", "torso", (0, 0, 0), massive=segs["head"]),
    ]
    for side, sign in (("r", -1.0), ("l", 1.0)):
        parts += [
            _cardan(f"hip_{side}", "hip", "pelvis", f"thigh_{side}",
                    (0, sign * geo.hip_half_width, 0)),
            _link(f"thigh_{side}", segs[f"thigh_{side}"]),
            _cardan(f"knee_{side}", "knee", f"thigh_{side}", f"shank_{side}",
                    (0, 0, -size[f"thigh_{side}"])),
            _link(f"shank_{side}", segs[f"shank_{side}"]),
            _cardan(f"ankle_{side}", "ankle", f"shank_{side}", f"foot_{side}",
                    (0, 0, -size[f"shank_{side}"])),
            _link(f"foot_{side}", segs[f"foot_{side}"]),
        ]
    for side, sign in (("r", -1.0), ("l", 1.0)):
        parts += [
            _cardan(f"shoulder_{side}", "shoulder", "torso", f"upper_arm_{side}",
                    (0, sign * geo.shoulder_half_width, geo.suprasternale_above_lumbar)),
            _link(f"upper_arm_{side}", segs[f"upper_arm_{side}"]),
            _revolute(f"elbow_{side}", f"upper_arm_{side}", f"forearm_{side}",
                      (0, 0, -size[f"upper_arm_{side}"]), "0 1 0", JOINT_LIMITS["elbow"][0]),
            _link(f"forearm_{side}", segs[f"forearm_{side}"]),
            _fixed(f"hand_{side}", f"forearm_{side}", (0, 0, -size[f"forearm_{side}"]),
                   massive=segs[f"hand_{side}"]),
        ]
    for name in MARKERS + JOINT_CENTRES + CONTACTS + SOLE_EDGES + BALLS:
        parent, xyz = frames[name]
        parts.append(_fixed(name, parent, xyz))
    parts.append("</robot>\n")
    return "".join(parts)
