"""The muscle gait NLP's derivatives, assembled node by node, equal CasADi's own.

:mod:`predgait.problems.muscle_gait_derivatives` joins the node's Jacobian and Hessian
(derived once, mapped over the grid) with the outer expressions' derivatives by the chain
rule. Known answer: CasADi's exact derivatives of the same NLP, differentiated as one
inlined SX graph (``nlpsol`` without the custom functions), at points off the reference
gait with random multipliers; for the product's problem, with the metabolic rate and
compliant tendons, a fused knee's residual rows and Hermite-Simpson. And Ipopt, given
them, solves the problem to the same optimum as with CasADi's own.
"""

from dataclasses import replace

import casadi as cs
import numpy as np
import pytest

from predgait.blas_threads import one_blas_thread
from predgait.data.storage import read_storage
from predgait.models.osim import bundled_2d_gait
from predgait.problems.collocation import Transcription
from predgait.problems.muscle_gait import NODE_OUTPUTS_USED, Goal, MuscleGaitProblem
from predgait.problems.muscle_gait_derivatives import nlp_derivatives
from predgait.problems.muscle_gait_setup import (
    MOCO_BOUNDS,
    bounds_for,
    compliant_rows,
    plant_2d_gait,
    reference_guess,
)
from predgait.problems.muscle_prediction import bundled_file


@pytest.fixture(scope="module")
def gait_model():
    return plant_2d_gait(bundled_2d_gait())


def _point(problem, planar, plant, rng):
    guess, reference = reference_guess(
        planar, read_storage(bundled_file("referenceCoordinates.sto")), plant, problem.n)
    x = problem.pack(guess)
    x = x * rng.uniform(0.7, 1.3, x.size) + rng.normal(0.0, 0.05, x.size)
    goal = Goal(speed=1.2, effort_weight=10.0, tracking_weight=3.0, acceleration_weight=1e-3,
                metabolic_weight=0.5 if problem.metabolic else 0.0, loading_rate_weight=3e-3)
    return x, problem.parameters(goal, reference)


def _dense(value) -> np.ndarray:
    return np.array(cs.densify(value))


CASES = {
    "moco problem": dict(),
    "metabolic, compliant tendons": dict(metabolic=True, compliant=("soleus", "vasti")),
    "fused knee rows, hermite-simpson": dict(residual_rows=[0, 1, 2, 3, 4, 6, 7, 8, 9],
                                             transcription=Transcription.HERMITE_SIMPSON),
}


@pytest.mark.parametrize("case", CASES)
def test_assembled_derivatives_equal_casadis_own(gait_model, case):
    plant, planar = gait_model
    options = dict(CASES[case])
    if "compliant" in options:
        plant = replace(plant, compliant=compliant_rows(plant.muscle_names,
                                                        options.pop("compliant")))
    problem = MuscleGaitProblem(plant, 4, tx_row=0, **options)
    own = cs.nlpsol("own", "ipopt", problem.nlp, {"print_time": False})
    assembled = nlp_derivatives(*problem._derivatives, problem.node, NODE_OUTPUTS_USED)
    rng = np.random.default_rng(7)
    for _ in range(2):
        x, p = _point(problem, planar, plant, rng)
        lam_g = rng.normal(0.0, 10.0, problem.ng)
        f_own, grad_own = own.get_function("nlp_grad_f")(x, p)
        f_ours, grad_ours = assembled["grad_f"](x, p)
        assert float(f_ours) == pytest.approx(float(f_own), rel=1e-12)
        np.testing.assert_allclose(_dense(grad_ours), _dense(grad_own), rtol=1e-9,
                                   atol=1e-9 * np.abs(_dense(grad_own)).max())
        g_own, jac_own = own.get_function("nlp_jac_g")(x, p)
        g_ours, jac_ours = assembled["jac_g"](x, p)
        np.testing.assert_allclose(_dense(g_ours), _dense(g_own), rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(_dense(jac_ours), _dense(jac_own), rtol=1e-9,
                                   atol=1e-9 * np.abs(_dense(jac_own)).max())
        hess_own = _dense(own.get_function("nlp_hess_l")(x, p, 0.8, lam_g))
        hess_ours = _dense(assembled["hess_lag"](x, p, 0.8, lam_g))
        assert np.abs(hess_own).max() > 0
        np.testing.assert_allclose(hess_ours, hess_own, rtol=1e-9,
                                   atol=1e-9 * np.abs(hess_own).max())
        assert np.all(np.isfinite(hess_ours))


def test_ipopt_reaches_the_same_optimum_with_either_derivatives(gait_model):
    plant, planar = gait_model
    problem = MuscleGaitProblem(plant, 8, tx_row=0, max_iter=500)
    guess, reference = reference_guess(
        planar, read_storage(bundled_file("referenceCoordinates.sto")), plant, problem.n)
    bounds = bounds_for(plant, planar, MOCO_BOUNDS, (0.4, 0.6))
    goal = Goal(speed=1.2, effort_weight=10.0, tracking_weight=100.0)   # one clear optimum
    with one_blas_thread():             # as the product solves it
        ours = problem.solve(guess, bounds, goal, reference=reference)
        problem.__dict__["solver"] = cs.nlpsol("own", "ipopt", problem.nlp,
                                               problem._solver_options)
        theirs = problem.solve(guess, bounds, goal, reference=reference)
    assert ours.solved.success and theirs.solved.success
    assert ours.objective == pytest.approx(theirs.objective, rel=1e-4)
    np.testing.assert_allclose(ours.path.q, theirs.path.q, atol=np.radians(0.5))
