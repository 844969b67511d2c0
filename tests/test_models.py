"""Models: anthropometry in the URDF, Pinocchio vs ADAM, RNEA/ABA round trips, thesis
Newton-Euler equations (rod 3.2.20-3.2.28; leg 3.3.3-3.3.5) vs Pinocchio."""

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from predgait.dynamics.external import Load, generalized_load, joint_forces
from predgait.errors import InputError
from predgait.models import anthropometry
from predgait.models.loading import generate_urdf, load_model, model_from_urdf
from predgait.models.symbolic import symbolic_model

REPO = Path(__file__).resolve().parents[1]
#: The planar models of this file; urdf/fullbody.urdf and urdf/gait7.urdf have their own
#: tests (tests/test_fullbody.py, tests/test_gait7.py).
SHIPPED = [REPO / "urdf" / f"{kind}.urdf" for kind in ("leg", "rod")]


def shipped_models():
    return [load_model(path) for path in SHIPPED]


def random_states(model, count=5, seed=0):
    rng = np.random.default_rng(seed)
    for _ in range(count):
        yield (rng.uniform(-1, 1, model.nq), rng.uniform(-2, 2, model.nq),
               rng.uniform(-5, 5, model.nq))


def dense_mass(model, data, q):
    mass = pin.crba(model.pin_model, data, q)
    return np.triu(mass) + np.triu(mass, 1).T


def test_shipped_urdfs_are_the_generated_ones():
    assert {p.name for p in (REPO / "urdf").glob("*.urdf")} == {
        "leg.urdf", "rod.urdf", "fullbody.urdf", "gait7.urdf"}
    for path in SHIPPED:
        kind = path.stem
        assert path.read_text() == generate_urdf(kind), f"regenerate {path}"


@pytest.mark.parametrize("mass,height", [(72.6, 1.8034), (50.0, 1.55), (110.0, 1.95)])
def test_leg_segments_equal_table_3_3_2(mass, height):
    model = model_from_urdf(generate_urdf("leg", mass=mass, height=height))
    pm = model.pin_model
    # Thesis Table 3.3.2 and Winter (2009) Fig. 4.1, written out by hand.
    expected = {
        "shank": (0.0465 * mass, 0.246 * height, 0.302, 0.384),
        "thigh": (0.100 * mass, 0.245 * height, 0.323, 0.4101),
    }
    for name, (seg_mass, length, gyration, com_from_proximal) in expected.items():
        inertia = pm.inertias[pm.frames[model.frame_id(name)].parentJoint]
        assert inertia.mass == pytest.approx(seg_mass, rel=1e-9)
        # COM measured from the proximal joint; the frame sits at the distal joint.
        assert inertia.lever[2] == pytest.approx(length * (1 - com_from_proximal), rel=1e-9)
        assert inertia.inertia[1, 1] == pytest.approx(seg_mass * (gyration * length) ** 2,
                                                      rel=1e-9)
    foot = pm.inertias[pm.frames[model.frame_id("foot")].parentJoint]
    foot_length = 0.152 * height
    assert foot.mass == pytest.approx(0.0145 * mass, rel=1e-9)
    assert foot.inertia[1, 1] == pytest.approx(0.0145 * mass * (0.475 * foot_length) ** 2,
                                               rel=1e-9)
    data = pm.createData()
    pin.framesForwardKinematics(pm, data, np.zeros(model.nq))
    heel, toe = (data.oMf[model.frame_id(n)].translation for n in ("heel", "toe"))
    assert np.linalg.norm(toe - heel) == pytest.approx(foot_length, rel=1e-9)
    # Foot COM: 0.564 of the length from the toe, 0.522 of the ankle height above the sole.
    com_world = data.oMi[1].act(foot.lever)
    assert toe[0] - com_world[0] == pytest.approx(0.564 * foot_length, rel=1e-9)
    assert com_world[2] - heel[2] == pytest.approx(0.522 * 0.039 * height, rel=1e-9)
    hip = data.oMf[model.frame_id("hip_center")].translation
    assert hip[2] == pytest.approx((0.246 + 0.245) * height, rel=1e-9)
    assert model.total_mass() == pytest.approx((0.0145 + 0.0465 + 0.1) * mass, rel=1e-9)


def test_rod_is_a_uniform_slender_rod():
    model = model_from_urdf(generate_urdf("rod", mass=2.0, length=1.5))
    inertia = model.pin_model.inertias[1]
    assert inertia.mass == 2.0
    assert inertia.inertia[1, 1] == pytest.approx(2.0 * 1.5**2 / 12)
    assert np.allclose(inertia.lever, 0)


def test_segment_table_csv(tmp_path):
    table = tmp_path / "segments.csv"
    table.write_text("# lab table\nsegment,mass_kg,length_m,com_from_proximal,inertia_kg_m2\n"
                     "foot,1.2,0.26,0.45,0.011\nshank,3.4,0.42,0.40,0.05\n"
                     "thigh,8.0,0.45,0.43,0.16\n")
    model = model_from_urdf(generate_urdf("leg", segments=table))
    pm = model.pin_model
    thigh = pm.inertias[pm.frames[model.frame_id("thigh")].parentJoint]
    assert (thigh.mass, thigh.inertia[1, 1]) == (8.0, pytest.approx(0.16))
    assert thigh.lever[2] == pytest.approx(0.45 * (1 - 0.43))
    table.write_text("segment,mass_kg,length_m,com_from_proximal,inertia_kg_m2\n"
                     "foot,1.2,0.26,0.45,0.011\nshank,-3,0.42,0.40,0.05\n")
    with pytest.raises(Exception, match=r"line 3, column mass_kg"):
        generate_urdf("leg", segments=table)


@pytest.mark.parametrize("model", shipped_models(), ids=[p.stem for p in SHIPPED])
def test_pinocchio_and_adam_agree(model):
    sym = symbolic_model(model)
    data = model.pin_model.createData()
    for q, v, a in random_states(model):
        mass = dense_mass(model, data, q)
        np.testing.assert_allclose(np.array(sym.mass_matrix(q)), mass, atol=1e-9)
        bias = pin.nonLinearEffects(model.pin_model, data, q, v)
        np.testing.assert_allclose(np.array(sym.bias_force(q, v)).ravel(), bias, atol=1e-9)
        tau = pin.rnea(model.pin_model, data, q, v, a)
        adam_tau = np.array(sym.mass_matrix(q)) @ a + np.array(sym.bias_force(q, v)).ravel()
        np.testing.assert_allclose(adam_tau, tau, atol=1e-9)
        adam_qdd = np.array(sym.forward_dynamics(q, v, tau)).ravel()
        np.testing.assert_allclose(adam_qdd, pin.aba(model.pin_model, data, q, v, tau),
                                   rtol=1e-9, atol=1e-9 * np.abs(a).max() * np.linalg.cond(mass))
        np.testing.assert_allclose(adam_qdd, a, rtol=1e-7, atol=1e-7)
        pin.framesForwardKinematics(model.pin_model, data, q)
        for frame in ("top", "hip_center", "toe"):
            if model.pin_model.existFrame(frame):
                np.testing.assert_allclose(np.array(sym.frame_position(frame)(q)).ravel(),
                                           data.oMf[model.frame_id(frame)].translation,
                                           atol=1e-12)


def test_gravity_is_shared_by_both_engines():
    model = load_model("leg", gravity=9.0)
    sym = symbolic_model(model)
    q = np.zeros(model.nq)
    data = model.pin_model.createData()
    bias = pin.computeGeneralizedGravity(model.pin_model, data, q)
    assert bias[1] == pytest.approx(9.0 * model.total_mass())
    np.testing.assert_allclose(np.array(sym.bias_force(q, q)).ravel(), bias, atol=1e-12)


@pytest.mark.parametrize("model", shipped_models(), ids=[p.stem for p in SHIPPED])
def test_rnea_then_aba_returns_the_accelerations(model):
    data = model.pin_model.createData()
    for q, v, a in random_states(model, seed=1):
        tau = pin.rnea(model.pin_model, data, q, v, a)
        np.testing.assert_allclose(pin.aba(model.pin_model, data, q, v, tau), a, atol=1e-8)


def test_rod_matches_thesis_equations():
    """Thesis 3.2.20-3.2.22 (inertial-based) and 3.2.26-3.2.28 (body-based).

    Coordinates: X, Z of the COM and pitch about +Y (top toward +X), end A at the top
    a distance L_A = L2 - L1 from the COM, end B at the bottom, L_B = L1 below it. The
    printed moment arms of 3.2.22/3.2.28 carry the opposite sign for this geometry
    (A at the top, as in the text); we use the signs that follow from r x F.
    """
    model = load_model("rod")
    pm = model.pin_model
    data = pm.createData()
    m, inertia = pm.inertias[1].mass, pm.inertias[1].inertia[1, 1]
    half = 0.5 * anthropometry.ROD_LENGTH_M
    rng = np.random.default_rng(3)
    for _ in range(5):
        q, v = rng.uniform(-1, 1, 3), rng.uniform(-2, 2, 3)
        theta = q[2]
        f_a, f_b = rng.uniform(-20, 20, 2), rng.uniform(-20, 20, 2)  # (I, K) lab components
        m_a = rng.uniform(-5, 5)
        pin.framesForwardKinematics(pm, data, q)
        loads = [Load("top", np.array([f_a[0], 0, f_a[1]]), moment=np.array([0, m_a, 0])),
                 Load("bottom", np.array([f_b[0], 0, f_b[1]]))]
        a = pin.aba(pm, data, q, v, np.zeros(3), joint_forces(model, data, loads))
        g = model.gravity
        expected = np.array([
            (f_a[0] + f_b[0]) / m,                                             # 3.2.29
            (f_a[1] + f_b[1] - m * g) / m,                                     # 3.2.30
            (m_a + f_a[0] * half * np.cos(theta) - f_b[0] * half * np.cos(theta)
             - f_a[1] * half * np.sin(theta) + f_b[1] * half * np.sin(theta)) / inertia,
        ])
        np.testing.assert_allclose(a, expected, atol=1e-10)
        # Body-based: the same forces in rod axes (x across, z along the rod), 3.2.26-28.
        c, s = np.cos(theta), np.sin(theta)
        body = {k: (f[0] * c - f[1] * s, f[0] * s + f[1] * c) for k, f in
                (("A", f_a), ("B", f_b))}
        x_dd = ((body["A"][0] + body["B"][0]) * c + (body["A"][1] + body["B"][1]) * s) / m
        z_dd = (-(body["A"][0] + body["B"][0]) * s + (body["A"][1] + body["B"][1]) * c
                - m * g) / m
        th_dd = (m_a + body["A"][0] * half - body["B"][0] * half) / inertia
        np.testing.assert_allclose(a, [x_dd, z_dd, th_dd], atol=1e-10)


def planar(vector):
    return np.array([vector[0], vector[2]])


def cross2(r, f):
    """Moment about +Y of a force f = (Fx, Fz) at r = (rx, rz): r_z F_x - r_x F_z."""
    return r[1] * f[0] - r[0] * f[1]


def test_leg_matches_thesis_newton_euler():
    """Thesis 3.3.3-3.3.5 per segment, top-down from a free hip, vs Pinocchio RNEA.

    With the foot as the base, RNEA returns the ankle and knee torques and the wrench
    the ground must apply to the foot (base rows). The same follows from the thesis'
    per-segment equations m a = sum F + m g, I alpha = sum M + sum r x F, solved from the
    thigh (hip unloaded) down to the foot, with COM accelerations from the model.
    """
    model = load_model("leg")
    pm = model.pin_model
    data = pm.createData()
    g = np.array([0.0, -model.gravity])
    for q, v, a in random_states(model, seed=4):
        tau = pin.rnea(pm, data, q, v, a)
        pin.forwardKinematics(pm, data, q, v, a)
        pin.updateFramePlacements(pm, data)
        seg = {}
        for name in ("foot", "shank", "thigh"):
            joint = pm.frames[model.frame_id(name)].parentJoint
            inertia = pm.inertias[joint]
            com = data.oMi[joint].act(inertia.lever)
            acc = pin.getFrameClassicalAcceleration(
                pm, data, model.frame_id(name), pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
            omega = pin.getFrameVelocity(pm, data, model.frame_id(name),
                                         pin.ReferenceFrame.LOCAL_WORLD_ALIGNED).angular
            alpha = acc.angular[1]
            r = data.oMi[joint].rotation @ inertia.lever
            com_acc = (acc.linear + np.cross(acc.angular, r)
                       + np.cross(omega, np.cross(omega, r)))
            seg[name] = dict(m=inertia.mass, I=inertia.inertia[1, 1], com=planar(com),
                             acc=planar(com_acc), alpha=alpha)
        knee = planar(data.oMf[model.frame_id("knee_center")].translation)
        ankle = planar(data.oMf[model.frame_id("ankle_center")].translation)
        # Thigh: knee force F_K and moment M_K act on it (3.3.3-3.3.5), hip free.
        th = seg["thigh"]
        f_knee = th["m"] * th["acc"] - th["m"] * g
        m_knee = th["I"] * th["alpha"] - cross2(knee - th["com"], f_knee)
        sh = seg["shank"]
        f_ankle = sh["m"] * sh["acc"] - sh["m"] * g + f_knee
        m_ankle = (sh["I"] * sh["alpha"] + m_knee - cross2(knee - sh["com"], -f_knee)
                   - cross2(ankle - sh["com"], f_ankle))
        ft = seg["foot"]
        f_ground = ft["m"] * ft["acc"] - ft["m"] * g + f_ankle
        m_ground_at_com = ft["I"] * ft["alpha"] + m_ankle - cross2(ankle - ft["com"], -f_ankle)
        np.testing.assert_allclose(tau[4], m_knee, atol=1e-9)
        np.testing.assert_allclose(tau[3], m_ankle, atol=1e-9)
        # Base rows: the ground wrench reduced to the foot origin (the ankle centre).
        m_ground_at_ankle = m_ground_at_com + cross2(ft["com"] - ankle, f_ground)
        np.testing.assert_allclose(tau[:2], f_ground, atol=1e-9)
        np.testing.assert_allclose(tau[2], m_ground_at_ankle, atol=1e-9)


def test_generalized_load_equals_rnea_difference():
    model = load_model("leg")
    pm = model.pin_model
    data = pm.createData()
    q, v, a = next(random_states(model, seed=7))
    pin.computeJointJacobians(pm, data, q)
    pin.updateFramePlacements(pm, data)
    loads = [Load("hip_center", np.array([10.0, 0, -30.0]), moment=np.array([0, 4.0, 0])),
             Load("foot", np.array([5.0, 0, 700.0]), point=np.array([0.3, 0, 0.0]))]
    fext = joint_forces(model, data, loads)
    expected = pin.rnea(pm, data, q, v, a) - pin.rnea(pm, data, q, v, a, fext)
    np.testing.assert_allclose(generalized_load(model, data, loads), expected, atol=1e-9)


FOOT_TABLE = ("segment,mass_kg,length_m,com_from_proximal,inertia_kg_m2,gyration_fraction,"
              "foot_com,com_x_m,com_z_m\n"
              "shank,3.4,0.42,0.40,0.05,,,,\nthigh,8.0,0.45,0.43,,0.323,,,\n")


@pytest.mark.parametrize(("foot_row", "expected"), [
    # heel-toe line from the heel, at the sole: heel_x = -0.25 L, sole_z = -(0.039/0.152) L
    ("foot,1.2,0.26,0.45,0.011,,heel_toe,,", (-0.065 + 0.45 * 0.26, -0.039 / 0.152 * 0.26)),
    ("foot,1.2,0.26,0.0,0.011,,heel_toe,,", (-0.065, -0.039 / 0.152 * 0.26)),
    # ankle-toe line from the ankle centre: toe at (0.75 L, sole_z)
    ("foot,1.2,0.26,0.5,0.011,,ankle_toe,,", (0.5 * 0.75 * 0.26, -0.5 * 0.039 / 0.152 * 0.26)),
    ("foot,1.2,0.26,0,0.011,,ankle_toe,,", (0.0, 0.0)),
    ("foot,1.2,0.26,,0.011,,offset,0.05,-0.03", (0.05, -0.03)),
    ("foot,1.2,0.26,,,0.475,offset,0,0", (0.0, 0.0)),
])
def test_segment_table_places_the_foot_com_as_labs_publish(tmp_path, foot_row, expected):
    table = tmp_path / "segments.csv"
    table.write_text(FOOT_TABLE + foot_row + "\n")
    model = model_from_urdf(generate_urdf("leg", segments=table))
    pm = model.pin_model
    foot = pm.inertias[pm.frames[model.frame_id("foot")].parentJoint]
    assert (foot.lever[0], foot.lever[2]) == pytest.approx(expected, abs=1e-9)  # URDF: 10 digits
    thigh = pm.inertias[pm.frames[model.frame_id("thigh")].parentJoint]
    assert thigh.inertia[1, 1] == pytest.approx(8.0 * (0.323 * 0.45) ** 2)   # gyration
    if foot_row.split(",")[5]:
        assert foot.inertia[1, 1] == pytest.approx(1.2 * (0.475 * 0.26) ** 2)


@pytest.mark.parametrize(("rows", "message"), [
    ("foot,1.2,0.26,0.45,0.011,,toe_heel,,\n", "column foot_com"),
    ("foot,1.2,0.26,0.45,0.011,0.4,,,\n", "not both"),
    ("foot,1.2,0.26,1.5,0.011,,,,\n", "column com_from_proximal"),
    ("foot,1.2,0.26,,0.011,,offset,x,0\n", "column com_x_m"),
    ("foot,1.2,0.26,0.45,0.011,,,,\nfoot,1.2,0.26,0.45,0.011,,,,\n", "segment 'foot' again"),
    ("foot,1.2,0.26,0.45,0.011,,,,\npelvis,9,0.2,0.5,0.1,,,,\n", "'pelvis' is not one of"),
])
def test_segment_table_errors_name_line_and_column(tmp_path, rows, message):
    table = tmp_path / "segments.csv"
    table.write_text(FOOT_TABLE + rows)
    with pytest.raises(InputError, match=message):
        generate_urdf("leg", segments=table)
