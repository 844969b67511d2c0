"""A whole-body predgait model as an OpenSim 4 model file (``.osim``), for OpenSim's GUI and API.

Written from the Pinocchio model (the scaled, calibrated body of a full-body inverse run):
one OpenSim ``Body`` per segment (mass, centre of mass and inertia about it, in the
segment frame, as Pinocchio holds them: fixed links such as the head and hands merged),
one ``CustomJoint`` per joint with the URDF's rotation sequence (the chain of revolute
joints ``<joint>_x``, ``_y``, ``_z`` through massless links becomes rotation1..3 of one
SpatialTransform, body-fixed X-Y-Z as the URDF's ``R = Rx Ry Rz``), the pelvis a
``CustomJoint`` to ground with rotations ``pelvis_rx/ry/rz`` (Cardan X-Y-Z,
:func:`predgait.kinematics.ik3d.pelvis_cardan`) and translations ``pelvis_tx/ty/tz``, and
markers at their calibrated places. Coordinate names are those of ``kinematics3d.sto``
(:func:`predgait.kinematics.ik3d.coordinate_columns`), so that file, or ``motion.mot``,
plays the motion in OpenSim. Lab frame: Z up (gravity 0 0 -g). predgait never imports
OpenSim; ``benchmarks/osim_export_peer.py`` checks the file with it.
"""

from __future__ import annotations

from collections.abc import Mapping
from xml.sax.saxutils import escape, quoteattr

import numpy as np

AXES = {"RX": "1 0 0", "RY": "0 1 0", "RZ": "0 0 1"}


def _vec(values) -> str:
    return " ".join(f"{float(v):.10g}" for v in values)


def _segments(pm) -> list[dict]:
    """Per segment: body name, parent body, offset in the parent, rotation axes and names."""
    import pinocchio as pin

    names = {}
    for frame in pm.frames:
        if (frame.type == pin.FrameType.BODY and not frame.name.endswith("_link")
                and frame.parentJoint not in names
                and np.allclose(frame.placement.homogeneous, np.eye(4))):
            names[frame.parentJoint] = frame.name
    body_of = {1: names.get(1, "pelvis")}
    segments = []
    for joint in range(2, pm.njoints):
        if joint not in names:   # a massless link inside a Cardan chain
            continue
        chain = [joint]
        while pm.parents[chain[0]] not in body_of and pm.parents[chain[0]] > 1:
            chain.insert(0, pm.parents[chain[0]])
        for inner in chain[1:]:
            if not np.allclose(pm.jointPlacements[inner].homogeneous, np.eye(4)):
                raise ValueError(f"joint {pm.names[inner]}: a Cardan chain with an offset")
        body_of[joint] = names[joint]
        first = pm.jointPlacements[chain[0]]
        segments.append({"body": names[joint], "joint": joint,
                         "parent": body_of[pm.parents[chain[0]]],
                         "translation": first.translation,
                         "rotation": pin.rpy.matrixToRpy(first.rotation),
                         "axes": [AXES[pm.joints[j].shortname()[-2:]] for j in chain],
                         "coordinates": [pm.names[j] for j in chain],
                         "limits": [(pm.lowerPositionLimit[pm.idx_qs[j]],
                                     pm.upperPositionLimit[pm.idx_qs[j]]) for j in chain]})
    return segments


def _body(name: str, inertia) -> str:
    i = inertia.inertia
    return (f"<Body name={quoteattr(name)}><mass>{inertia.mass:.10g}</mass>"
            f"<mass_center>{_vec(inertia.lever)}</mass_center>"
            f"<inertia>{_vec([i[0, 0], i[1, 1], i[2, 2], i[0, 1], i[0, 2], i[1, 2]])}</inertia>"
            "</Body>\n")


def _axis(name: str, axis: str, coordinate: str | None) -> str:
    function = ("<LinearFunction name=\"function\"><coefficients>1 0</coefficients>"
                "</LinearFunction>" if coordinate else
                "<Constant name=\"function\"><value>0</value></Constant>")
    return (f"<TransformAxis name=\"{name}\"><coordinates>{coordinate or ''}</coordinates>"
            f"<axis>{axis}</axis>{function}</TransformAxis>")


def _joint(name: str, parent: str, child: str, offset, rotation, rotations, translations,
           coordinates) -> str:
    """A CustomJoint: ``rotations``/``translations`` are (axis, coordinate or None) x 3."""
    parent_path = "/ground" if parent == "ground" else f"/bodyset/{parent}"
    coords = "".join(
        f"<Coordinate name={quoteattr(c)}><default_value>0</default_value>"
        f"<range>{lo:.10g} {hi:.10g}</range><clamped>false</clamped><locked>false</locked>"
        "</Coordinate>" for c, lo, hi in coordinates)
    axes = "".join(_axis(f"rotation{k}", a, c) for k, (a, c) in enumerate(rotations, 1))
    axes += "".join(_axis(f"translation{k}", a, c) for k, (a, c) in enumerate(translations, 1))
    return (f"<CustomJoint name={quoteattr(name)}>"
            f"<socket_parent_frame>{escape(parent)}_offset</socket_parent_frame>"
            f"<socket_child_frame>{escape(child)}_offset</socket_child_frame>"
            f"<coordinates>{coords}</coordinates><frames>"
            f"<PhysicalOffsetFrame name=\"{escape(parent)}_offset\"><socket_parent>"
            f"{parent_path}</socket_parent><translation>{_vec(offset)}</translation>"
            f"<orientation>{_vec(rotation)}</orientation></PhysicalOffsetFrame>"
            f"<PhysicalOffsetFrame name=\"{escape(child)}_offset\"><socket_parent>"
            f"/bodyset/{escape(child)}</socket_parent><translation>0 0 0</translation>"
            "<orientation>0 0 0</orientation></PhysicalOffsetFrame></frames>"
            f"<SpatialTransform>{axes}</SpatialTransform></CustomJoint>\n")


def osim_text(model, markers: Mapping[str, str], *, name: str = "predgait_fullbody") -> str:
    """The ``.osim`` XML of a whole-body model (see the module docstring).

    Args:
        model: A :class:`predgait.models.loading3d.Model3D` (free-flyer pelvis).
        markers: Model marker frame -> marker name to write (e.g. the trial's label).
        name: The OpenSim model's name.
    """
    pm = model.pin_model
    segments = _segments(pm)
    pelvis = "pelvis"
    bodies = _body(pelvis, pm.inertias[1]) + "".join(
        _body(s["body"], pm.inertias[s["joint"]]) for s in segments)
    xyz = ("1 0 0", "0 1 0", "0 0 1")
    big = (-1e3, 1e3)
    joints = _joint("ground_pelvis", "ground", pelvis, (0, 0, 0), (0, 0, 0),
                    [(a, f"pelvis_r{c}") for a, c in zip(xyz, "xyz", strict=True)],
                    [(a, f"pelvis_t{c}") for a, c in zip(xyz, "xyz", strict=True)],
                    [(f"pelvis_r{c}", -np.pi, np.pi) for c in "xyz"]
                    + [(f"pelvis_t{c}", *big) for c in "xyz"])
    for s in segments:
        rotations = list(zip(s["axes"], s["coordinates"], strict=True))
        spare = [a for a in xyz if a not in s["axes"]]
        rotations += [(a, None) for a in spare[:3 - len(rotations)]]
        joints += _joint(s["coordinates"][0].removesuffix("_x"), s["parent"], s["body"],
                         s["translation"], s["rotation"], rotations,
                         [(a, None) for a in xyz],
                         [(c, lo, hi) for c, (lo, hi) in
                          zip(s["coordinates"], s["limits"], strict=True)])
    body_of = {1: pelvis} | {s["joint"]: s["body"] for s in segments}
    marker_xml = ""
    for frame, label in markers.items():
        f = pm.frames[pm.getFrameId(frame)]
        if f.parentJoint not in body_of:
            raise ValueError(f"marker frame {frame} is not on a segment")
        marker_xml += (f"<Marker name={quoteattr(label)}><socket_parent_frame>/bodyset/"
                       f"{body_of[f.parentJoint]}</socket_parent_frame>"
                       f"<location>{_vec(f.placement.translation)}</location>"
                       "<fixed>false</fixed></Marker>\n")
    return ("<?xml version=\"1.0\" encoding=\"UTF-8\" ?>\n"
            "<OpenSimDocument Version=\"40000\">\n"
            f"<Model name={quoteattr(name)}>\n"
            f"<gravity>0 0 {-model.gravity:.10g}</gravity>\n"
            f"<BodySet name=\"bodyset\"><objects>\n{bodies}</objects></BodySet>\n"
            f"<JointSet name=\"jointset\"><objects>\n{joints}</objects></JointSet>\n"
            f"<MarkerSet name=\"markerset\"><objects>\n{marker_xml}</objects></MarkerSet>\n"
            "</Model>\n</OpenSimDocument>\n")
