"""The two-segment-foot variant of the 2D gait model: its generator, the reader's
SpringGeneralizedForce, and the springs in the NLP's residual and Pinocchio's check."""

from dataclasses import replace
from pathlib import Path

import casadi as cs
import numpy as np
import pytest

from predgait.errors import InputError
from predgait.models.osim import read_osim

FOLDER = Path(__file__).resolve().parents[1] / "src" / "predgait" / "datasets" / \
    "moco_2d_walking"
TOES = FOLDER / "2D_gait_toes.osim"


@pytest.fixture(scope="module")
def toes():
    return read_osim(TOES)


def test_bundled_file_is_what_the_generator_writes():
    import importlib.util

    spec = importlib.util.spec_from_file_location("make_toes", FOLDER / "make_2d_gait_toes.py")
    make = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(make)
    assert TOES.read_text() == make.toes_model_text((FOLDER / "2D_gait.osim").read_text())


def test_structure(toes):
    names = [c.name for c in toes.coordinates]
    assert "mtp_angle_r" in names and "mtp_angle_l" in names and len(names) == 12
    assert {j.name: j.kind.name for j in toes.joints}["mtp_r"] == "PIN"
    springs = {s.name: s for s in toes.springs}
    assert set(springs) == {"mtp_passive_r", "mtp_passive_l"}
    assert springs["mtp_passive_r"].coordinate == "mtp_angle_r"
    assert (springs["mtp_passive_r"].stiffness, springs["mtp_passive_r"].viscosity) == \
        (25.0, 0.03)
    spheres = {s.name: s for s in toes.spheres}
    assert spheres["toe_r"].body == "toes_r" and spheres["front_r"].body == "calcn_r"
    assert len(toes.contacts) == 6
    # the toe sphere's bottom is level with the metatarsal-head sphere's at mtp = 0
    mtp_y = -0.00182784875586352
    toe_bottom = spheres["toe_r"].location[1] + mtp_y - spheres["toe_r"].radius
    front_bottom = spheres["front_r"].location[1] - spheres["front_r"].radius
    assert toe_bottom == pytest.approx(front_bottom, abs=1e-12)


def test_spring_forces_known_answer(toes):
    from predgait.problems.muscle_gait_setup import plant_2d_gait

    plant, planar = plant_2d_gait(toes)
    q, v = np.zeros(plant.model.nq), np.zeros(plant.model.nq)
    right = planar.osim_coordinates.index("mtp_angle_r")
    left = planar.osim_coordinates.index("mtp_angle_l")
    q[right], v[right], q[left] = 0.2, 1.0, -0.1     # model = sign * OpenSim, sign +1 here
    forces = plant.spring_forces(q, v)
    expected = np.zeros(plant.model.nq)
    expected[right] = -25.0 * 0.2 - 0.03 * 1.0
    expected[left] = -25.0 * -0.1
    np.testing.assert_allclose(forces, expected, atol=1e-12)
    # the node's residual holds them: r(with springs) - r(without) = -forces
    from predgait.problems.muscle_gait_dynamics import node_function

    bare = replace(plant, springs=())
    rng = np.random.default_rng(3)
    args = [q + 0.05 * rng.standard_normal(q.size), v, rng.standard_normal(q.size),
            np.full(plant.n_muscles, 0.2), np.full(plant.n_muscles, 0.3), np.zeros(1)]
    with_springs = np.array(node_function(plant)(*args)[0]).ravel()
    without = np.array(node_function(bare)(*args)[0]).ravel()
    np.testing.assert_allclose(with_springs - without,
                               -plant.spring_forces(args[0], args[1]), atol=1e-9)
    assert isinstance(node_function(plant), cs.Function)


@pytest.mark.parametrize("change, needle", [
    ("<stiffness>25.0</stiffness>", "<stiffness>-1</stiffness>"),
    ("<coordinate>mtp_angle_r</coordinate>", "<coordinate>mtp_angle_x</coordinate>"),
])
def test_bad_spring(tmp_path, change, needle):
    text = TOES.read_text()
    start = text.index('<SpringGeneralizedForce name="mtp_passive_r">')
    text = text[:start] + text[start:].replace(change, needle, 1)
    path = tmp_path / "bad_toes.osim"
    path.write_text(text)
    with pytest.raises(InputError) as err:
        read_osim(path)
    msg = str(err.value)
    line = TOES.read_text().count("\n", 0, start) + 1
    assert f"{path}:{line}:" in msg and "SpringGeneralizedForce 'mtp_passive_r'" in msg
    assert ("stiffness = -1" in msg) if "stiffness" in change else ("mtp_angle_x" in msg)


def test_against_opensim(toes):
    """Sphere centres and toe spring torques against OpenSim 4.6 at 6 random states
    (tests/reference/osim2d/toes_reference.csv, written by make_toes_reference.py)."""
    import csv

    from predgait.problems.muscle_gait_dynamics import link_point
    from predgait.problems.muscle_gait_setup import plant_2d_gait

    plant, planar = plant_2d_gait(toes)
    sphere_of = {c.sphere: c.name for c in toes.contacts}
    by_contact = {s.name: s for s in plant.spheres}
    path = Path(__file__).parent / "reference" / "osim2d" / "toes_reference.csv"
    rows = list(csv.DictReader(path.open()))
    assert len(rows) == 36
    names = planar.osim_coordinates
    rows_of = {n: names.index(n) for n in ("mtp_angle_r", "mtp_angle_l")}
    for row in rows:
        q = planar.q_from_osim(np.array([float(row[n]) for n in names]))
        v = planar.q_from_osim(np.array([float(row[f"{n}.speed"]) for n in names]))
        sphere = by_contact[sphere_of[row["sphere"]]]
        p = np.array(link_point(plant.model, sphere.link, sphere.location)(q)).ravel()
        # predgait lab frame: X forward, Y left (= -Z OpenSim), Z up (= Y OpenSim)
        np.testing.assert_allclose(p, [float(row["x"]), -float(row["z"]), float(row["y"])],
                                   atol=1e-9)
        forces = plant.spring_forces(q, v)
        for name, index in rows_of.items():
            spring = name.replace("angle", "passive")         # mtp_passive_r / _l
            assert forces[index] == pytest.approx(float(row[spring]), abs=1e-9)


@pytest.fixture(scope="module")
def toes_prediction():
    from predgait.problems.muscle_gait import Goal
    from predgait.problems.muscle_prediction import (
        BUNDLED_MODELS,
        MusclePredictSpec,
        bundled_file,
        solve_prediction,
    )

    spec = MusclePredictSpec(nodes=16, human_checks=False,
                             osim=bundled_file(BUNDLED_MODELS["bundled_toes"]),
                             goal=Goal(loading_rate_weight=3e-3))
    return solve_prediction(spec)


def test_toes_prediction_holds_the_springs(toes_prediction):
    """On 16 intervals: converges; Pinocchio's re-evaluation with the toe springs equals
    the NLP's dynamics, and without them misses exactly the springs' torques."""
    from predgait.problems.muscle_gait_check import node_check

    pred = toes_prediction
    assert pred.gait.solved.success, pred.gait.solved.status
    assert pred.check["max_residual"] < 0.05                  # N, N m
    assert "loading_rate" in pred.gait.terms and pred.gait.terms["loading_rate"] > 0
    bare = node_check(replace(pred.plant, springs=()), pred.gait)
    path = pred.gait.path
    springs = np.array([pred.plant.spring_forces(q, v)
                        for q, v in zip(path.q, path.v, strict=True)])
    assert np.abs(springs).max() > 0.5                       # the toes bend under load
    np.testing.assert_allclose(bare["residual"] - pred.check["residual"], springs,
                               atol=1e-9)
