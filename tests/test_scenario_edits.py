"""Scenario model edits regenerate the URDF with the physically right parameters."""

import numpy as np
import pinocchio as pin
import pytest

from predgait.errors import InputError
from predgait.models.anthropometry import leg_from_subject
from predgait.models.loading import model_from_urdf
from predgait.models.urdf import leg_urdf
from predgait.problemfile import load_problem
from predgait.scenarios.edits import (
    AddMass,
    LockJoint,
    MoveCom,
    PassiveEdit,
    ScaleLength,
    ScaleMass,
    apply_segment_edits,
    parse_edit,
)


def body_inertia(model, segment):
    pm = model.pin_model
    return pm.inertias[pm.frames[model.frame_id(segment)].parentJoint]


@pytest.fixture(scope="module")
def baseline():
    return leg_from_subject(72.6, 1.8034)


def test_added_mass_equals_the_sum_of_two_rigid_bodies(baseline):
    """A 1.5 kg cast at mid-shank: Pinocchio's own inertia sum is the reference."""
    edited = apply_segment_edits(baseline, [AddMass("shank", 1.5, 0.5)])
    model = model_from_urdf(leg_urdf(edited))
    before = body_inertia(model_from_urdf(leg_urdf(baseline)), "shank")
    length = baseline.segments["shank"].length
    cast = pin.Inertia(1.5, np.array([0.0, 0.0, 0.5 * length]), np.zeros((3, 3)))
    expected = before + cast
    after = body_inertia(model, "shank")
    assert after.mass == pytest.approx(expected.mass)
    np.testing.assert_allclose(after.lever, expected.lever, atol=1e-12)
    assert after.inertia[1, 1] == pytest.approx(expected.inertia[1, 1], rel=1e-9)
    assert model.total_mass() == pytest.approx(
        model_from_urdf(leg_urdf(baseline)).total_mass() + 1.5)


def test_scale_and_move(baseline):
    edits = [ScaleMass("thigh", 1.2), ScaleLength("shank", 0.9), MoveCom("thigh", 0.02)]
    model = model_from_urdf(leg_urdf(apply_segment_edits(baseline, edits)))
    base_model = model_from_urdf(leg_urdf(baseline))
    thigh, thigh0 = body_inertia(model, "thigh"), body_inertia(base_model, "thigh")
    assert thigh.mass == pytest.approx(1.2 * thigh0.mass)
    assert thigh.inertia[1, 1] == pytest.approx(1.2 * thigh0.inertia[1, 1])
    # 2 cm toward the hip: the thigh frame is at the knee, Z toward the hip.
    assert thigh.lever[2] - thigh0.lever[2] == pytest.approx(0.02)
    knee = model.pin_model.jointPlacements[model.pin_model.getJointId("knee")].translation
    assert knee[2] == pytest.approx(0.9 * baseline.segments["shank"].length)
    assert baseline.segments["thigh"].mass == pytest.approx(7.26)  # input unchanged


def test_foot_length_scales_its_geometry(baseline):
    edited = apply_segment_edits(baseline, [ScaleLength("foot", 1.1)])
    assert edited.foot.toe_x - edited.foot.heel_x == pytest.approx(
        1.1 * baseline.segments["foot"].length)


def test_parse_edits(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text('[[edit]]\nkind = "lock_joint"\njoint = "knee"\nangle_deg = 10\n\n'
                    '[[edit]]\nkind = "passive"\njoint = "ankle"\nk = 200\n\n'
                    '[[edit]]\nkind = "add_mass"\nsegment = "shin"\nmass_kg = 1\nposition = 0.5\n')
    data = load_problem(path)
    tables = [data.__class__(t, data.path, data.text, "edit.") for t in data.data["edit"]]
    assert parse_edit(tables[0]) == LockJoint("knee", np.radians(10))
    assert parse_edit(tables[1]) == PassiveEdit("ankle", 200.0, 0.0, 0.0)
    with pytest.raises(InputError, match="'shin' is not one of: foot, shank, thigh"):
        parse_edit(tables[2])
