"""Muscle scenario edits: each changes what it says and nothing else; the shipped files."""

from dataclasses import fields
from pathlib import Path

import casadi as cs
import numpy as np
import pytest

from predgait.dynamics.muscle_paths import PathGeometry
from predgait.dynamics.muscles import MuscleSet
from predgait.errors import InputError
from predgait.models.osim import bundled_2d_gait
from predgait.models.osim_model import build_model
from predgait.problemfile import load_problem
from predgait.scenarios import muscle_edits as me

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"
SHIPPED = sorted(PROBLEMS.glob("scenario_muscle_*.toml"))
DEG = np.pi / 180.0


@pytest.fixture(scope="module")
def built():
    return build_model(bundled_2d_gait())


@pytest.fixture(scope="module")
def muscles(built):
    return MuscleSet.from_osim(built.osim)


def _coordinates(built):
    return tuple(c.name for c in built.osim.coordinates)


def _scenario(tmp_path, built, muscles, text):
    path = tmp_path / "s.toml"
    path.write_text('name = "t"\nkind = "muscle_scenario"\nbaseline = "b.toml"\n' + text)
    spec = me.parse_muscle_scenario(load_problem(path), muscles, _coordinates(built))
    return me.muscle_scenario(spec.edits, built, muscles)


def _changes(before: MuscleSet, after: MuscleSet) -> dict:
    """(muscle, field) -> (old, new) of every parameter that differs ('where' aside)."""
    out = {}
    for a, b in zip(before.muscles, after.muscles, strict=True):
        for f in fields(a):
            if f.name != "where" and getattr(a, f.name) != getattr(b, f.name):
                out[(a.name, f.name)] = (getattr(a, f.name), getattr(b, f.name))
    return out


@pytest.mark.parametrize(("text", "field", "edited", "expect"), [
    ('kind = "max_isometric_force"\nmuscles = ["soleus", "gastroc"]\nscale = 0.2\n',
     "max_isometric_force", {"soleus_r", "soleus_l", "gastroc_r", "gastroc_l"},
     lambda old: 0.2 * old),
    ('kind = "tendon_slack_length"\nmuscles = ["soleus_r"]\nchange_m = -0.01\n',
     "tendon_slack_length", {"soleus_r"}, lambda old: old - 0.01),
    ('kind = "tendon_slack_length"\nmuscles = "hamstrings"\nscale = 1.05\n',
     "tendon_slack_length", {"hamstrings_r", "hamstrings_l"}, lambda old: 1.05 * old),
    ('kind = "optimal_fiber_length"\nmuscles = ["soleus"]\nscale = 0.8\n',
     "optimal_fiber_length", {"soleus_r", "soleus_l"}, lambda old: 0.8 * old),
    ('kind = "passive_fiber_strain"\nmuscles = ["soleus"]\nstrain = 0.3\n',
     "passive_fiber_strain_at_one_norm_force", {"soleus_r", "soleus_l"}, lambda old: 0.3),
    ('kind = "passive_fiber_strain"\nmuscles = ["gastroc_l"]\nscale = 0.5\n',
     "passive_fiber_strain_at_one_norm_force", {"gastroc_l"}, lambda old: 0.5 * old),
])
def test_parameter_edit_changes_only_its_parameter(tmp_path, built, muscles, text, field,
                                                   edited, expect):
    scenario = _scenario(tmp_path, built, muscles, "[[muscle_edit]]\n" + text)
    changes = _changes(muscles, scenario.muscles)
    assert {m for m, _ in changes} == edited
    assert {f for _, f in changes} == {field}
    for old, new in changes.values():
        assert new == pytest.approx(expect(old), rel=1e-15)
    assert scenario.paths is None and scenario.built is built
    assert not scenario.coordinate_bounds and not scenario.passive_torques


def test_sides_and_symmetry(tmp_path, built, muscles):
    both = _scenario(tmp_path, built, muscles, '[[muscle_edit]]\nkind = "max_isometric_force"'
                     '\nmuscles = ["soleus"]\nscale = 0.5\n')
    right = _scenario(tmp_path, built, muscles, '[[muscle_edit]]\nkind = '
                      '"max_isometric_force"\nmuscles = ["soleus_r"]\nscale = 0.5\n')
    assert both.symmetric and not right.symmetric
    fused = _scenario(tmp_path, built, muscles, '[[muscle_edit]]\nkind = "fuse"\n'
                      'coordinate = "knee_angle_r"\nangle_deg = -10.0\n')
    assert not fused.symmetric


def test_knee_fusion_bounds(tmp_path, built, muscles):
    scenario = _scenario(tmp_path, built, muscles, '[[muscle_edit]]\nkind = "fuse"\n'
                         'coordinate = "knee_angle_r"\nangle_deg = -10.0\n')
    assert scenario.coordinate_bounds == {"knee_angle_r": (-10 * DEG, -10 * DEG)}
    assert scenario.speed_bounds == {"knee_angle_r": (0.0, 0.0)}
    assert scenario.fused == ("knee_angle_r",)
    assert _changes(muscles, scenario.muscles) == {}
    # the problem builder's bounds (muscle_gait_setup.coordinate_bounds) take it as is
    from predgait.problems.muscle_gait_setup import MOCO_BOUNDS, coordinate_bounds

    q_bounds = coordinate_bounds(built, {**MOCO_BOUNDS, **scenario.coordinate_bounds})
    row = built.osim_coordinates.index("knee_angle_r")
    np.testing.assert_allclose(q_bounds[row], [-10 * DEG, -10 * DEG])


def test_edited_plant(tmp_path, built, muscles):
    from predgait.problems.muscle_gait_setup import plant_2d_gait

    plant, planar = plant_2d_gait(built.osim)
    scenario = _scenario(tmp_path, planar, plant.muscle_set, '[[muscle_edit]]\nkind = '
                         '"transfer"\nmuscle = "rect_fem"\ndonor = "bifemsh"\n')
    edited = scenario.edited_plant(plant)
    assert edited.muscle_set is scenario.muscles and edited.paths is scenario.paths
    assert edited.contacts is plant.contacts and edited.model is plant.model
    assert scenario.symmetric
    row = plant.muscle_names.index("rect_fem_l")
    knee = planar.osim_coordinates.index("knee_angle_l")
    q = planar.default_q()
    assert plant.paths.moment_arms(q)[row, knee] > 0.02        # extensor
    assert edited.paths.moment_arms(q)[row, knee] < -0.02      # flexor


def test_afo_spring_torque(tmp_path, built, muscles):
    scenario = _scenario(tmp_path, built, muscles, '[[muscle_edit]]\nkind = "spring"\n'
                         'coordinate = "ankle_angle"\nstiffness = 286.5\nneutral_deg = 5.0\n'
                         'damping = 0.5\n')
    assert [s.coordinate for s in scenario.passive_torques] == ["ankle_angle_r",
                                                                "ankle_angle_l"]
    assert scenario.symmetric and _changes(muscles, scenario.muscles) == {}
    q = built.default_q()
    v = np.zeros_like(q)
    r = built.osim_coordinates.index("ankle_angle_r")
    q[r], v[r] = 15 * DEG, 2.0
    forces = scenario.passive_forces(built, q, v)
    expected = np.zeros_like(q)
    expected[r] = -286.5 * 10 * DEG - 0.5 * 2.0      # 10 deg dorsiflexed past neutral
    expected[built.osim_coordinates.index("ankle_angle_l")] = -286.5 * (0.0 - 5 * DEG)
    np.testing.assert_allclose(forces, expected, rtol=1e-14, atol=1e-12)
    qs, vs = cs.SX.sym("q", len(q)), cs.SX.sym("v", len(q))
    f = cs.Function("f", [qs, vs], [scenario.passive_forces(built, qs, vs)])
    np.testing.assert_allclose(np.array(f(q, v)).ravel(), expected, rtol=1e-14, atol=1e-12)


def test_transfer_turns_rectus_into_a_knee_flexor(tmp_path, built, muscles):
    scenario = _scenario(tmp_path, built, muscles, '[[muscle_edit]]\nkind = "transfer"\n'
                         'muscle = "rect_fem_r"\ndonor = "bifemsh_r"\n')
    path = scenario.built.osim.muscle("rect_fem_r").path
    donor = built.osim.muscle("bifemsh_r").path
    assert path[0] == built.osim.muscle("rect_fem_r").path[0]            # origin kept
    assert [p.location for p in path[1:]] == [p.location for p in donor[1:]]
    assert {p.body for p in path[1:]} == {"tibia_r"}
    others = [m for m in built.osim.muscles if m.name != "rect_fem_r"]
    assert [m for m in scenario.built.osim.muscles if m.name != "rect_fem_r"] == others
    before, after = PathGeometry(built), PathGeometry(scenario.built)
    names = before.coordinate_names
    knee, hip = names.index("knee_angle_r"), names.index("hip_flexion_r")
    row = before.muscle_names.index("rect_fem_r")
    poses = np.zeros((6, len(names)))
    poses[:, knee] = np.linspace(-100, 5, 6) * DEG
    poses[:, hip] = np.linspace(-10, 40, 6) * DEG
    old, new = before.moment_arms(poses), after.moment_arms(poses)
    assert np.all(old[:, row, knee] > 0.01)        # extensor before (OpenSim: + extends)
    assert np.all(new[:, row, knee] < -0.01)       # flexor after, as bifemsh
    assert np.all(np.sign(old[:, before.muscle_names.index("bifemsh_r"), knee]) == -1)
    assert np.all(new[:, row, hip] > 0.02)         # still a hip flexor
    others = [m for m in range(len(names)) if m != row]
    np.testing.assert_array_equal(new[:, others], old[:, others])
    # tendon slack reset: same fibre length in the default pose, nothing else changed
    default = [c.default_value for c in built.osim.coordinates]
    i = muscles.index("rect_fem_r")
    fibre = [after.lengths(default)[row] - scenario.muscles.muscles[i].tendon_slack_length,
             before.lengths(default)[row] - muscles.muscles[i].tendon_slack_length]
    assert fibre[0] == pytest.approx(fibre[1], abs=1e-12)
    assert set(_changes(muscles, scenario.muscles)) == {("rect_fem_r", "tendon_slack_length")}
    # the smooth fit follows the transferred path (the optimiser's moment arms)
    model_q = built.q_from_osim({n: poses[:, i] for i, n in enumerate(names)})
    arms = scenario.paths.moment_arms(model_q.T)
    column = built.osim_coordinates.index("knee_angle_r")
    np.testing.assert_allclose(arms[row, column], new[:, row, knee], atol=1e-3)


@pytest.mark.parametrize(("text", "key", "message"), [
    ('kind = "max_isometric_force"\nmuscles = ["soleus_x"]\nscale = 0.5\n', "muscles",
     "no muscle named 'soleus_x'"),
    ('kind = "max_isometric_force"\nmuscles = ["soleus"]\nscale = 0.0\n', "scale",
     "impossible"),
    ('kind = "tendon_slack_length"\nmuscles = ["soleus"]\nchange_m = -0.5\n', "change_m",
     "must stay > 0"),
    ('kind = "tendon_slack_length"\nmuscles = ["soleus"]\nscale = -1.0\n', "scale",
     "impossible"),
    ('kind = "tendon_slack_length"\nmuscles = ["soleus"]\n', "kind", "exactly one of"),
    ('kind = "passive_fiber_strain"\nmuscles = ["soleus"]\nstrain = -0.2\n', "strain",
     "must stay > 0"),
    ('kind = "transfer"\nmuscle = "rect_fem_r"\ndonor = "hamstring_r"\n', "donor",
     "no muscle named 'hamstring_r'"),
    ('kind = "fuse"\ncoordinate = "knee_r"\nangle_deg = 0.0\n', "coordinate",
     "no coordinate named 'knee_r'"),
    ('kind = "spring"\ncoordinate = "ankle_angle_r"\nstiffness = -5.0\n', "stiffness",
     "outside"),
    ('kind = "weaken"\nmuscles = ["soleus"]\n', "kind", "is not one of"),
    ('kind = "max_isometric_force"\nmuscles = ["soleus"]\nscale = 0.5\nfactor = 2.0\n',
     "factor", "unknown key"),
])
def test_bad_input_names_file_key_and_line(tmp_path, built, muscles, text, key, message):
    with pytest.raises(InputError) as caught:
        _scenario(tmp_path, built, muscles, "\n[[muscle_edit]]\n" + text)
    line = 6 + next(i for i, t in enumerate(text.splitlines()) if t.startswith(key))
    text = str(caught.value)
    assert str(tmp_path / "s.toml") in text and f"muscle_edit.0.{key}" in text
    assert f"(line {line})" in text and message in text


def test_shipped_scenarios_parse(built, muscles):
    assert len(SHIPPED) >= 5
    for path in SHIPPED:
        spec = me.parse_muscle_scenario(load_problem(path), muscles, _coordinates(built))
        assert spec.edits and spec.baseline in (
            PROBLEMS / "predict_2d_muscles_impact.toml",
            PROBLEMS / "predict_2d_muscles_physiological.toml")
        text = path.read_text()
        assert text.startswith("#") and ("Compare with" in text or "Compare:" in text)


def test_transfer_needs_a_proximal_point(built):
    from predgait.scenarios.muscle_transfer import transferred_osim

    with pytest.raises(InputError, match="no point proximal"):
        transferred_osim(built.osim, "soleus_r", "bifemsh_r")   # soleus starts on the tibia
