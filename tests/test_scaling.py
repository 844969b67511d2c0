"""Segment scaling to a static trial: builder lengths, recovery of known lengths, subject01."""

import dataclasses
import json
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from predgait.data import read_trc
from predgait.data.trial import Markers
from predgait.dynamics.inverse3d_trial import inverse_fullbody, read_marker_map, read_trial
from predgait.errors import InputError
from predgait.kinematics.joint_centres import harrington_hip
from predgait.kinematics.scaling import TrialPoint, frame_distances, read_scaling, scale_fullbody
from predgait.models.anthropometry_3d import DE_LEVA_TABLE4, Sex
from predgait.models.fullbody import LENGTHS, build_fullbody_urdf, segment_lengths
from predgait.models.loading3d import fullbody_for_subject, load_fullbody
from predgait.problemfile import load_problem
from predgait.workflows.inverse3d import run_inverse_fullbody, scaled_urdf

REPO = Path(__file__).resolve().parents[1]
DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "opensim_subject01_walk1"
MAP = REPO / "problems" / "markers_fullbody_subject01.toml"
MASS, HEIGHT = 72.6, 1.8034

# Known-answer spec: every trial point is a synthetic marker at the model frame of the
# same name, except the knee centres (mean of two markers 5 cm either side).
SPEC = """
[scaling.points]
knee_center_r = ["KL_r", "KM_r"]
knee_center_l = ["KL_l", "KM_l"]
[scaling.measurements]
pelvis_width = ["asis_r", "asis_l"]
shoulder_width = ["shoulder_center_r", "shoulder_center_l"]
trunk = [["hip_center_r", "sternum"], ["hip_center_l", "sternum"]]
head = ["sternum", "head_top"]
thigh_r = ["hip_center_r", "knee_center_r"]
thigh_l = ["hip_center_l", "knee_center_l"]
shank_r = ["knee_center_r", "ankle_center_r"]
shank_l = ["knee_center_l", "ankle_center_l"]
foot_r = ["heel_contact_r", "toe_contact_r"]
foot_l = ["heel_contact_l", "toe_contact_l"]
upper_arm_r = ["shoulder_r", "elbow_lat_r"]
upper_arm_l = ["shoulder_l", "elbow_lat_l"]
forearm_r = ["elbow_lat_r", "wrist_r"]
forearm_l = ["elbow_lat_l", "wrist_l"]
[scaling.groups]
trunk = ["pelvis", "torso", "upper_trunk"]
forearm_r = ["forearm_r", "hand_r"]
forearm_l = ["forearm_l", "hand_l"]
"""
DIRECT = ("asis_r", "asis_l", "shoulder_center_r", "shoulder_center_l", "hip_center_r",
          "hip_center_l", "sternum", "head_top", "ankle_center_r", "ankle_center_l",
          "heel_contact_r", "toe_contact_r", "heel_contact_l", "toe_contact_l", "shoulder_r",
          "shoulder_l", "elbow_lat_r", "elbow_lat_l", "wrist_r", "wrist_l")


def spec_from(tmp_path, text, markers=None):
    path = tmp_path / "map.toml"
    path.write_text(text)
    return read_scaling(load_problem(path).table("scaling"), markers or {})


def inertials(text):
    out = {}
    for link in ET.fromstring(text).iter("link"):
        inertial = link.find("inertial")
        if inertial is not None and float(inertial.find("mass").get("value")) > 0:
            tensor = inertial.find("inertia")
            out[link.get("name")] = (
                float(inertial.find("mass").get("value")),
                np.array([float(c) for c in inertial.find("origin").get("xyz").split()]),
                np.array([float(tensor.get(k)) for k in ("ixx", "iyy", "izz")]))
    return out


def test_builder_lengths_scale_com_and_inertia_as_de_leva():
    default = build_fullbody_urdf(MASS, HEIGHT, "male")
    base = segment_lengths(HEIGHT, "male")
    given = {"thigh_r": 0.50, "forearm_l": 0.25, "pelvis": 0.12}
    scaled = inertials(build_fullbody_urdf(MASS, HEIGHT, "male", lengths=given))
    ref = inertials(default)
    t4 = DE_LEVA_TABLE4[Sex.MALE]
    for body, length in given.items():
        k = length / base[body]
        mass, com, inertia = scaled[body]
        assert mass == pytest.approx(ref[body][0], rel=1e-12)  # de Leva mass fraction
        np.testing.assert_allclose(inertia, ref[body][2] * k**2, rtol=1e-8)
        np.testing.assert_allclose(com, ref[body][1] * k, rtol=1e-8, atol=1e-12)
    row = t4["thigh"]  # thigh: COM 40.95 % below the hip, radii 32.9/32.9/14.9 % of 0.50 m
    np.testing.assert_allclose(scaled["thigh_r"][1], [0, 0, -0.4095 * 0.50], atol=1e-9)
    np.testing.assert_allclose(scaled["thigh_r"][2], row.mass * MASS * (
        np.array([row.r_trans, row.r_sag, row.r_long]) * 0.50) ** 2, rtol=1e-8)
    for body in set(ref) - set(given):  # the other segments are untouched
        np.testing.assert_allclose(scaled[body][2], ref[body][2], rtol=1e-9)
    # Joints follow: the right knee sits 0.50 m below the hip, the left one does not move.
    model = fullbody_for_subject(MASS, HEIGHT, lengths=given)
    d = frame_distances(model, [("hip_center_r", "knee_center_r"),
                                ("hip_center_l", "knee_center_l")])
    np.testing.assert_allclose(d, [0.50, base["thigh_l"]], atol=1e-9)
    # Explicit default lengths give the default body (the header comment aside).
    explicit = build_fullbody_urdf(MASS, HEIGHT, "male", lengths=base)
    strip = re.compile(r"<!--.*?-->", re.S)
    assert strip.sub("", explicit) == strip.sub("", default)
    with pytest.raises(InputError, match="'femur_r' unknown"):
        build_fullbody_urdf(MASS, HEIGHT, lengths={"femur_r": 0.4})


def synthetic_static(model, q, frames):
    """Three frames of markers at the model's frames in pose q (knee pairs 5 cm apart)."""
    pm, data = model.pin_model, model.pin_model.createData()
    pin.framesForwardKinematics(pm, data, q)
    pos = {f: data.oMf[model.frame_id(f)].translation.copy() for f in frames}
    for side in ("r", "l"):
        knee = data.oMf[model.frame_id(f"knee_center_{side}")]
        offset = knee.rotation @ np.array([0.0, 0.05, 0.0])
        pos[f"KL_{side}"], pos[f"KM_{side}"] = knee.translation + offset, knee.translation - offset
    names = tuple(pos)
    xyz = np.repeat(np.array([pos[n] for n in names])[None], 3, axis=0)
    return Markers(np.arange(3) / 60.0, names, xyz, 60.0, "synthetic static")


def test_scaling_recovers_known_lengths(tmp_path):
    spec = spec_from(tmp_path, SPEC, {f: f for f in DIRECT})
    rng = np.random.default_rng(8)
    factors = {m.name: rng.uniform(0.85, 1.15) for m in spec.measurements}
    base = segment_lengths(HEIGHT, "male")
    known = {n: base[n] * factors[m.name] for m in spec.measurements for n in m.lengths}
    assert set(known) == set(LENGTHS)
    truth = fullbody_for_subject(MASS, HEIGHT, lengths=known)
    # A T-pose (shoulders abducted 80 deg, elbows bent 20 deg), pelvis moved and turned.
    q = truth.neutral()
    q[:3] = (0.4, -0.2, 1.0)
    q[3:7] = pin.Quaternion(pin.rpy.rpyToMatrix(0.05, -0.1, 0.6)).coeffs()
    for name, angle in (("shoulder_r_x", 1.4), ("shoulder_l_x", -1.4), ("elbow_r", -0.35),
                        ("elbow_l", -0.35)):
        q[7 + truth.joint_velocity_index(name) - 6] = angle
    static = synthetic_static(truth, q, DIRECT)
    result = scale_fullbody(spec, static, mass=MASS, height=HEIGHT, q=q)
    for name, length in known.items():
        assert abs(result.lengths[name] - length) < 1e-6, name
        assert result.factors[next(m.name for m in spec.measurements if name in m.lengths)] \
            == pytest.approx(length / base[name], abs=1e-6)
    assert result.iterations < 30
    # Measured in the wrong pose (arms down), the upper arms come out wrong by > 1 cm.
    wrong = scale_fullbody(spec, static, mass=MASS, height=HEIGHT)
    assert abs(wrong.lengths["upper_arm_r"] - known["upper_arm_r"]) > 0.01


def test_harrington_point_is_the_regression():
    rng = np.random.default_rng(3)
    mean = {n: rng.normal(size=3) for n in ("RA", "LA", "RP", "LP")}
    point = TrialPoint(("RA", "LA", "RP", "LP"), "left")
    expected = harrington_hip(mean["RA"], mean["LA"], 0.5 * (mean["RP"] + mean["LP"]),
                              side="left")
    np.testing.assert_allclose(point.locate(mean), expected, atol=1e-12)
    np.testing.assert_allclose(TrialPoint(("RA", "LA")).locate(mean),
                               0.5 * (mean["RA"] + mean["LA"]), atol=1e-12)


@pytest.mark.parametrize("change,message", [
    (("knee_center_r\"]", "knee_centre_r\"]"), "model frame 'knee_centre_r' unknown"),
    (("thigh_l = [\"hip_center_l\"", "femur_l = [\"hip_center_l\""),
     "'femur_l' is not a segment length"),
    (("trunk = [\"pelvis\", \"torso\"", "trunk = [\"thigh_r\", \"torso\""),
     "length 'thigh_r' is already scaled by"),
    (("knee_center_r = [\"KL_r\", \"KM_r\"]", "knee_center_r = 3"),
     "expected a trial marker"),
    (("foot_l = [\"heel_contact_l\"", "foot_l = [\"heel_l\""),
     "model frame 'heel_l' has no trial point"),
])
def test_bad_scaling_entry_is_named(tmp_path, change, message):
    text = SPEC.replace(*change)
    assert text != SPEC
    with pytest.raises(InputError, match=message) as info:
        spec_from(tmp_path, text, {f: f for f in DIRECT})
    assert "map.toml" in str(info.value) and "line" in str(info.value)


def test_missing_static_marker_is_named(tmp_path, subject01):
    text = MAP.read_text().replace('["R.Knee.Lat", "R.Knee.Med"]', '["R.Knee.Lateral", '
                                                                   '"R.Knee.Med"]')
    path = tmp_path / "map.toml"
    path.write_text(text)
    markers, plates, static = subject01["inputs"]
    with pytest.raises(InputError, match="R.Knee.Lateral are not in .*subject01_static.trc"):
        inverse_fullbody(markers, plates, read_marker_map(path), mass=MASS, height=HEIGHT,
                         static=static)
    with pytest.raises(InputError, match=r"\[scaling\] measures segments on a static trial"):
        inverse_fullbody(markers, plates, read_marker_map(MAP), mass=MASS, height=HEIGHT)


GROUPS = {"legs": ("Thigh", "Shank", "Heel", "Toe", "Midfoot"), "upper_arm": ("Bicep", "Elbow"),
          "forearm": ("Wrist",), "pelvis": ("ASIS", "Sacral")}


def group_rms(result):
    """Mean over a group's markers of each marker's RMS residual, mm."""
    ik = result.ik
    rms = {n: np.sqrt(np.nanmean(ik.residuals[:, i] ** 2)) for i, n in enumerate(ik.marker_names)}
    out = {g: 1000 * np.mean([v for n, v in rms.items() if any(k in n for k in keys)])
           for g, keys in GROUPS.items()}
    return out | {"frame_mean": 1000 * float(ik.rms.mean())}


@pytest.fixture(scope="module")
def subject01():
    if not DATA.is_dir():
        raise FileNotFoundError(f"{DATA} is missing: clone predgait beside shared/.")
    markers, plates = read_trial([DATA / "subject01_walk1.trc", DATA / "subject01_walk1_grf.mot"])
    static = read_trc(DATA / "subject01_static.trc")
    mmap = read_marker_map(MAP)
    run = {"mass": MASS, "height": HEIGHT, "static": static}
    return {"inputs": (markers, plates, static),
            "before": inverse_fullbody(markers, plates, dataclasses.replace(mmap, scaling=None),
                                       **run),
            "after": inverse_fullbody(markers, plates, mmap, **run)}


def test_scaling_improves_subject01_fit(subject01):
    before, after = group_rms(subject01["before"]), group_rms(subject01["after"])
    # Measured (mm, before -> after): frame mean 39.9 -> 36.1, upper arm 88.2 -> 77.5,
    # forearm 50.9 -> 42.1, pelvis 24.8 -> 22.6, legs 8.3 -> 7.95.
    assert after["frame_mean"] < before["frame_mean"] - 2.5
    assert after["upper_arm"] < before["upper_arm"] - 7.0
    assert after["forearm"] < before["forearm"] - 5.0
    assert after["pelvis"] < before["pelvis"] - 1.0
    assert after["legs"] < before["legs"] - 0.1
    scaling = subject01["after"].scaling
    assert subject01["before"].scaling is None
    # The scaled thigh matches the static trial's Harrington hip to mid-epicondyle distance.
    model = subject01["after"].model
    assert frame_distances(model, [("hip_center_r", "knee_center_r")], None)[0] == \
        pytest.approx(scaling.measured["thigh_r"], abs=1e-6)
    assert 0.85 < min(scaling.factors.values()) and max(scaling.factors.values()) < 1.15
    assert model.total_mass() == pytest.approx(MASS, rel=1e-4)


def test_scaled_urdf_carries_the_calibrated_marker_frames(subject01, tmp_path):
    """Loaded back, the written URDF puts every fitted marker frame where the IK had it
    (so residuals recompute from the outputs); the generic frames are centimetres off."""
    result = subject01["after"]
    path = tmp_path / "scaled_model.urdf"
    path.write_text(scaled_urdf(result))
    models = {"written": load_fullbody(path), "fitted": result.model}
    generic = tmp_path / "generic.urdf"
    generic.write_text(result.model.urdf)
    models["generic"] = load_fullbody(generic)
    q = result.ik.q[result.ik.q.shape[0] // 2]
    where = {}
    for key, model in models.items():
        data = model.pin_model.createData()
        pin.framesForwardKinematics(model.pin_model, data, q)
        where[key] = np.array([data.oMf[model.frame_id(f)].translation
                               for f in result.ik.marker_frames if model.pin_model.existFrame(f)])
    assert where["written"].shape == where["fitted"].shape
    np.testing.assert_allclose(where["written"], where["fitted"], atol=1e-6)
    shared = np.array([models["generic"].pin_model.existFrame(f) for f in result.ik.marker_frames])
    assert np.abs(where["generic"] - where["fitted"][shared]).max() > 0.01


def test_scaled_model_and_factors_written(tmp_path):
    info = run_inverse_fullbody([DATA / "subject01_walk1.trc", DATA / "subject01_walk1_grf.mot"],
                                MAP, mass=MASS, height=HEIGHT, out_dir=tmp_path / "out",
                                static=DATA / "subject01_static.trc", window=(0.6, 0.9))
    saved = json.loads((tmp_path / "out" / "summary.json").read_text())
    factors = saved["provenance"]["scaling"]["factors"]
    assert factors == info["provenance"]["scaling"]["factors"] and "thigh_r" in factors
    lengths = saved["provenance"]["scaling"]["lengths_m"]
    model = load_fullbody(tmp_path / "out" / "scaled_model.urdf")
    d = frame_distances(model, [("knee_center_l", "ankle_center_l")])[0]
    assert d == pytest.approx(lengths["shank_l"], abs=1e-5)
    assert model.total_mass() == pytest.approx(MASS, rel=1e-4)
    # The headline error over the markers the fit trusts (legs, pelvis) is beside the
    # all-marker one, which the arm and trunk markers (weight 0.2) dominate.
    trusted = saved["ik_trusted_rms_m"]
    assert trusted["mean"] < saved["ik_rms_m"]["mean"]
    assert "R.Heel" in trusted["markers"] and "R.Elbow" not in trusted["markers"]
    assert saved["ik_weighted_rms_m"]["mean"] < saved["ik_rms_m"]["mean"]
