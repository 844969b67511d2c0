"""Planar 7-link gait model: anthropometry, Pinocchio vs ADAM, regeneration."""

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from predgait.models.gait7 import CONTACT_FRAMES, build_gait7_urdf
from predgait.models.loading import load_model, model_from_urdf
from predgait.models.symbolic import symbolic_model

REPO = Path(__file__).resolve().parents[1]


def test_gait7_anthropometry_and_geometry():
    mass, height = 72.6, 1.8034
    model = model_from_urdf(build_gait7_urdf(mass, height))
    assert model.kind == "gait7" and model.nq == 9
    assert set(model.coordinate_names[3:]) == {"hip_r", "knee_r", "ankle_r", "hip_l",
                                               "knee_l", "ankle_l"}
    assert model.total_mass() == pytest.approx(mass, rel=1e-12)
    pm = model.pin_model
    hat = pm.inertias[1]
    hat_len = 0.288 * height
    assert hat.mass == pytest.approx(0.678 * mass, rel=1e-9)
    assert hat.lever[2] == pytest.approx(0.626 * hat_len, rel=1e-9)
    assert hat.inertia[1, 1] == pytest.approx(0.678 * mass * (0.496 * hat_len) ** 2, rel=1e-9)
    thigh = pm.inertias[pm.frames[model.frame_id("thigh_r")].parentJoint]
    assert thigh.mass == pytest.approx(0.1 * mass, rel=1e-9)
    assert thigh.lever[2] == pytest.approx(-0.4101 * 0.245 * height, rel=1e-9)
    data = pm.createData()
    q = np.zeros(model.nq)
    q[1] = (0.245 + 0.246 + 0.039) * height  # hip height standing
    pin.framesForwardKinematics(pm, data, q)
    for name in CONTACT_FRAMES:
        assert data.oMf[model.frame_id(name)].translation[2] == pytest.approx(0, abs=1e-12)
    heel, toe = (data.oMf[model.frame_id(n)].translation for n in ("heel_r", "toe_r"))
    assert toe[0] - heel[0] == pytest.approx(0.152 * height, rel=1e-9)


def test_gait7_pinocchio_equals_adam():
    model = model_from_urdf(build_gait7_urdf(72.6, 1.8034))
    sym = symbolic_model(model)
    pm, data = model.pin_model, model.pin_model.createData()
    rng = np.random.default_rng(1)
    for _ in range(4):
        q, v, a = (rng.uniform(-1, 1, 9), rng.uniform(-2, 2, 9), rng.uniform(-5, 5, 9))
        mass = pin.crba(pm, data, q)
        mass = np.triu(mass) + np.triu(mass, 1).T
        np.testing.assert_allclose(sym.mass_matrix(q).full(), mass, atol=1e-9)
        tau = pin.rnea(pm, data, q, v, a)
        np.testing.assert_allclose((sym.mass_matrix(q) @ a + sym.bias_force(q, v)).full().ravel(),
                                   tau, atol=1e-9)
        pin.framesForwardKinematics(pm, data, q)
        np.testing.assert_allclose(sym.frame_position("toe_l")(q).full().ravel(),
                                   data.oMf[model.frame_id("toe_l")].translation, atol=1e-12)


def test_shipped_gait7_urdf_is_the_generated_one():
    path = REPO / "urdf" / "gait7.urdf"
    assert path.read_text() == build_gait7_urdf(72.6, 1.8034), f"regenerate {path}"
    assert load_model(path).kind == "gait7"
