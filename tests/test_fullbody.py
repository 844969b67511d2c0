"""35-DOF whole body: de Leva (1996) Table 4 in the URDF, Pinocchio vs ADAM, RNEA/ABA."""

import xml.etree.ElementTree as ET
from pathlib import Path

import casadi as cs
import numpy as np
import pinocchio as pin
import pytest

from predgait.errors import InputError
from predgait.models.fullbody import (
    BALL_FRACTION,
    BALLS,
    CONTACTS,
    JOINT_CENTRES,
    MARKERS,
    SOLE_EDGES,
    build_fullbody_urdf,
)
from predgait.models.loading3d import (
    adam_kindyn,
    base_transform,
    fullbody_for_subject,
    load_fullbody,
    model3d_from_urdf,
)

REPO = Path(__file__).resolve().parents[1]

# de Leva (1996) Table 4, written out by hand: (length mm, mass %, COM % from the first
# endpoint, r_sag %, r_trans %, r_long %).
MALE = {"thigh": (422.2, 14.16, 40.95, 32.9, 32.9, 14.9),
        "shank": (434.0, 4.33, 44.59, 25.5, 24.9, 10.3),
        "upper_arm": (281.7, 2.71, 57.72, 28.5, 26.9, 15.8),
        "lower_trunk": (145.7, 11.17, 61.15, 61.5, 55.1, 58.7)}
FEMALE = {"thigh": (368.5, 14.78, 36.12, 36.9, 36.4, 16.2),
          "foot": (228.3, 1.29, 40.14, 29.9, 27.9, 13.9),
          "forearm": (264.3, 1.38, 45.59, 26.1, 25.7, 9.4)}


def links(text):
    out = {}
    for link in ET.fromstring(text).iter("link"):
        inertial = link.find("inertial")
        if inertial is None:
            continue
        com = [float(c) for c in inertial.find("origin").get("xyz").split()]
        tensor = inertial.find("inertia")
        out[link.get("name")] = (float(inertial.find("mass").get("value")), np.array(com),
                                 np.array([float(tensor.get(k)) for k in ("ixx", "iyy", "izz")]))
    return out


@pytest.mark.parametrize("sex,table,stature", [("male", MALE, 1.741), ("female", FEMALE, 1.735)])
def test_segments_equal_de_leva_table4(sex, table, stature):
    mass, height = 64.0, 1.70
    got = links(build_fullbody_urdf(mass, height, sex))
    name = {"thigh": "thigh_r", "shank": "shank_l", "upper_arm": "upper_arm_r",
            "lower_trunk": "pelvis", "foot": "foot_l", "forearm": "forearm_r"}
    for segment, (length_mm, mass_pc, com_pc, r_sag, r_trans, r_long) in table.items():
        seg_mass, com, inertia = got[name[segment]]
        length = length_mm / 1000 * height / stature
        assert seg_mass == pytest.approx(mass_pc / 100 * mass, rel=1e-9)
        expected = seg_mass * (np.array([r_trans, r_sag, r_long]) / 100 * length) ** 2
        if segment == "foot":  # long axis X, heel -> toe
            expected = seg_mass * (np.array([r_long, r_sag, r_trans]) / 100 * length) ** 2
        np.testing.assert_allclose(inertia, expected, rtol=1e-9)
        if segment == "lower_trunk":  # OMPH (top, z = length) -> MIDH (origin)
            assert com[2] == pytest.approx(length * (1 - com_pc / 100), rel=1e-9)
        elif segment != "foot":  # proximal joint at the origin, segment along -Z
            assert com[2] == pytest.approx(-length * com_pc / 100, rel=1e-9)


@pytest.mark.parametrize("sex", ["male", "female"])
def test_total_mass_is_body_mass(sex):
    model = fullbody_for_subject(80.0, 1.75, sex)
    # Table 4 sums to 100.00 % (male) and 99.99 % (female).
    assert model.total_mass() == pytest.approx(80.0, rel=2e-4)
    assert model.nq == 36 and model.nv == 35 and len(model.joint_names) == 29


def test_frames_and_geometry():
    model = load_fullbody()
    pm, data = model.pin_model, model.pin_model.createData()
    for name in MARKERS + JOINT_CENTRES + CONTACTS:
        model.frame_id(name)
    pin.framesForwardKinematics(pm, data, model.neutral())
    pos = {n: data.oMf[model.frame_id(n)].translation for n in JOINT_CENTRES + CONTACTS}
    height = 1.8034
    # Standing: the pelvis origin is at hip height; the soles are at 0.039 H below the ankle.
    sole = pos["heel_contact_r"][2]
    hip = pos["hip_center_r"][2]
    thigh, shank = (x / 1000 * height / 1.741 for x in (422.2, 434.0))
    assert hip - pos["knee_center_r"][2] == pytest.approx(thigh, rel=1e-9)
    assert pos["knee_center_r"][2] - pos["ankle_center_r"][2] == pytest.approx(shank, rel=1e-9)
    assert pos["ankle_center_r"][2] - sole == pytest.approx(0.039 * height, rel=1e-9)
    assert pos["hip_center_r"][1] < 0 < pos["hip_center_l"][1]
    head = data.oMf[model.frame_id("head_top")].translation
    assert head[2] - sole == pytest.approx(height, rel=1e-9)
    with pytest.raises(InputError, match="no frame"):
        model.frame_id("nose")


def test_sole_edges_lie_half_a_foot_breadth_beside_the_centre_line():
    """Winter (2009) Fig. 4.1: foot breadth 0.055 H for a foot 0.152 H long, so the
    medial and lateral points lie 0.055 / 0.152 / 2 of the foot length either side of
    the heel and toe points, on the sole, lateral outward (right: -Y); the ball point
    lies between heel and toe under the metatarsal heads."""
    model = fullbody_for_subject(70.0, 1.7, "female", lengths={"foot_r": 0.25,
                                                               "foot_l": 0.22})
    pm, data = model.pin_model, model.pin_model.createData()
    pin.framesForwardKinematics(pm, data, model.neutral())

    def at(name):
        return data.oMf[model.frame_id(name)].translation

    assert len(SOLE_EDGES) == 8
    for side, sign, length in (("r", -1.0, 0.25), ("l", 1.0, 0.22)):
        assert at(f"toe_contact_{side}")[0] - at(f"heel_contact_{side}")[0] == pytest.approx(
            length, rel=1e-9)
        for end in ("heel", "toe"):
            centre = at(f"{end}_contact_{side}")
            for edge, outward in (("medial", -1.0), ("lateral", 1.0)):
                offset = at(f"{end}_{edge}_contact_{side}") - centre
                np.testing.assert_allclose(
                    offset, [0.0, sign * outward * 0.5 * 0.055 / 0.152 * length, 0.0],
                    atol=1e-12)
        # The ball point: on the sole's centre line under the toe marker (metatarsal head).
        ball = at(f"ball_contact_{side}") - at(f"heel_contact_{side}")
        np.testing.assert_allclose(ball, [BALL_FRACTION * length, 0.0, 0.0], atol=1e-12)
        assert at(f"toe_{side}")[0] == pytest.approx(at(f"ball_contact_{side}")[0], abs=1e-12)
    assert BALLS == ("ball_contact_r", "ball_contact_l")


def random_state(model, rng):
    quat = pin.Quaternion(pin.SE3.Random().rotation).coeffs()
    q = np.concatenate([rng.uniform(-1, 1, 3), quat, rng.uniform(-0.6, 0.6, model.nv - 6)])
    return q, rng.uniform(-2, 2, model.nv), rng.uniform(-5, 5, model.nv)


def test_pinocchio_equals_adam():
    model = load_fullbody()
    pm, data = model.pin_model, model.pin_model.createData()
    kindyn = adam_kindyn(model, backend="numpy")
    rng = np.random.default_rng(3)
    for _ in range(4):
        q, v, a = random_state(model, rng)
        mass = pin.crba(pm, data, q)
        mass = np.triu(mass) + np.triu(mass, 1).T
        h_pin = pin.nonLinearEffects(pm, data, q, v)
        frame = base_transform(q)
        mass_adam = np.asarray(kindyn.mass_matrix(frame, q[7:]))
        h_adam = np.asarray(kindyn.bias_force(frame, q[7:], v[:6], v[6:])).ravel()
        np.testing.assert_allclose(mass_adam, mass, atol=1e-9)
        np.testing.assert_allclose(h_adam, h_pin, atol=1e-9)
        np.testing.assert_allclose(mass_adam @ a + h_adam, pin.rnea(pm, data, q, v, a),
                                   atol=1e-9)
        # Frame kinematics agree too (a marker on the foot).
        pin.framesForwardKinematics(pm, data, q)
        foot = np.asarray(kindyn.forward_kinematics("toe_r", frame, q[7:]))
        np.testing.assert_allclose(foot, data.oMf[model.frame_id("toe_r")].homogeneous,
                                   atol=1e-12)


def test_adam_casadi_gravity_is_the_models():
    model = load_fullbody(gravity=9.81)
    kindyn = adam_kindyn(model)
    q = model.neutral()
    h = cs.evalf(kindyn.bias_force(cs.DM(base_transform(q)), cs.DM(q[7:]), cs.DM.zeros(6),
                                   cs.DM.zeros(29))).full().ravel()
    # Upright: the vertical base force is the weight, with g = 9.81 (not ADAM's 9.80665).
    assert h[2] == pytest.approx(72.6 * 9.81, rel=1e-9)


def test_rnea_then_aba_round_trip():
    model = load_fullbody()
    pm, data = model.pin_model, model.pin_model.createData()
    rng = np.random.default_rng(5)
    for _ in range(3):
        q, v, a = random_state(model, rng)
        tau = pin.rnea(pm, data, q, v, a)
        np.testing.assert_allclose(pin.aba(pm, data, q, v, tau), a, atol=1e-8)


def test_bad_inputs():
    with pytest.raises(InputError, match="sex"):
        build_fullbody_urdf(70, 1.7, "x")
    with pytest.raises(InputError, match="--mass"):
        build_fullbody_urdf(5000, 1.7, "male")
    leg = (REPO / "urdf" / "leg.urdf").read_text()
    with pytest.raises(InputError, match="free-flyer"):
        model3d_from_urdf(leg)


def test_shipped_fullbody_urdf_is_the_generated_one():
    path = REPO / "urdf" / "fullbody.urdf"
    assert path.read_text() == build_fullbody_urdf(72.6, 1.8034, "male"), f"regenerate {path}"
    assert load_fullbody(path).total_mass() == pytest.approx(72.6)
