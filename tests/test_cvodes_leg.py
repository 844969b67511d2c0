"""The leg's CVODES runs (dynamics.cvodes_leg, method "cvodes") against SciPy on Pinocchio.

The drivers written in CasADi against the engine's splines; the bundled re-synthesis
window of problems/resynthesis.toml (fall at 80 deg) against SciPy's RK45 at tight
tolerance on the Pinocchio engine (same fall, same motion); passive elements and
feedback; the fallback to RK45 with a warning when the leg cannot be written in CasADi.
"""

import logging
from dataclasses import replace
from pathlib import Path

import casadi as cs
import numpy as np
import pytest

from predgait import function_cache
from predgait.dynamics import compiled_leg, cvodes_leg
from predgait.dynamics.drivers import LegDrivers
from predgait.dynamics.falls import FallLimit
from predgait.dynamics.forces import JointFeedback
from predgait.dynamics.forward import LegSystem, simulate_leg
from predgait.dynamics.integrators import IntegratorOptions, Method
from predgait.dynamics.inverse_trial import bundled_inverse
from predgait.dynamics.passive import LinearSpringDamper, PassiveJoint
from predgait.problemfile import Table

TIGHT = IntegratorOptions(method=Method.RK45, rtol=1e-11, atol=1e-11, step=1e-3)
CVODES = IntegratorOptions(method=Method.CVODES, rtol=1e-8, atol=1e-8, step=1e-3)


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """The cache on in a fresh folder, the virtual machine only (no compiling)."""
    monkeypatch.setenv(function_cache.SWITCH, "on")
    monkeypatch.setenv(function_cache.FOLDER, str(tmp_path / "cache"))
    monkeypatch.setattr(function_cache, "compiler", lambda: None)
    monkeypatch.setattr(compiled_leg, "_STEPS", {})
    compiled_leg.leg_dynamics.cache_clear()
    yield
    compiled_leg.leg_dynamics.cache_clear()


@pytest.fixture(scope="module")
def inverse():
    return bundled_inverse("right")


def test_method_is_read_from_an_integrator_table():
    table = Table({"method": "cvodes", "rtol": 1e-7}, Path("p.toml"), "integrator")
    assert IntegratorOptions.from_table(table).method is Method.CVODES


def test_drivers_in_casadi_equal_the_engine_splines(inverse, cache):
    drivers = LegDrivers.from_inverse(inverse, passive={"knee": PassiveJoint(
        (LinearSpringDamper(10.0, 20.0),))})
    feedback = JointFeedback(np.arange(3, 5), drivers.reference, 50.0, np.array([5.0, 3.0]))
    fast = compiled_leg.fast_leg(LegSystem(inverse.model, drivers, feedback=feedback))
    t = cs.SX.sym("t")
    u_of_t = cs.Function("u", [t], [cvodes_leg.time_inputs(fast, t)])
    times = np.r_[-0.01, np.random.default_rng(5).uniform(0.0, 1.2, 20), 5.0]  # held ends
    expected = fast.inputs(times)
    got = np.asarray(u_of_t(times[None, :])).T
    np.testing.assert_allclose(got, expected, rtol=1e-11, atol=1e-11 * np.abs(expected).max())


def test_resynthesis_window_equals_scipy_on_pinocchio(inverse, cache, monkeypatch):
    drivers = LegDrivers.from_inverse(inverse)
    fall = FallLimit(segment_angle_deg=80.0)   # problems/resynthesis.toml: 0..1.2 s
    # the driven leg is unstable: CVODES' error is ~1e3 x its tolerance here (1e-8: 2e-5
    # rad, 1e-9: 3e-6, 1e-10: 6e-7 against Radau at 1e-12), so 1e-10 for a 2e-6 check
    options = replace(CVODES, rtol=1e-10, atol=1e-10)
    ours = simulate_leg(inverse.model, drivers, (0.0, 1.2), options=options, fall=fall)
    monkeypatch.setenv(function_cache.SWITCH, "off")
    reference = simulate_leg(inverse.model, drivers, (0.0, 1.2), options=TIGHT, fall=fall)
    assert ours.status == reference.status == "event"
    assert ours.event == reference.event and ours.event.startswith("fall")
    assert abs(ours.time_to_fall - reference.time_to_fall) < 1e-6
    n = min(len(ours.t), len(reference.t)) - 1   # the grid rows before the event row
    np.testing.assert_array_equal(ours.t[:n], reference.t[:n])
    np.testing.assert_allclose(ours.q[:n], reference.q[:n], atol=2e-6)
    np.testing.assert_allclose(ours.a[:n], reference.a[:n], atol=1e-3)
    np.testing.assert_allclose(ours.grf[:n], reference.grf[:n], atol=1e-2)


def test_passive_and_feedback_run_on_output_times(inverse, cache, monkeypatch):
    drivers = LegDrivers.from_inverse(inverse, passive={"knee": PassiveJoint(
        (LinearSpringDamper(10.0, 20.0),))})
    feedback = JointFeedback(np.arange(3, 5), drivers.reference, 50.0, np.array([5.0, 3.0]))
    t_eval = np.linspace(0.05, 0.5, 10)
    ours = simulate_leg(inverse.model, drivers, (0.0, 0.5), feedback=feedback,
                        options=CVODES, t_eval=t_eval)
    monkeypatch.setenv(function_cache.SWITCH, "off")
    reference = simulate_leg(inverse.model, drivers, (0.0, 0.5), feedback=feedback,
                             options=TIGHT, t_eval=t_eval)
    assert ours.status == "completed" and "cvodes" in ours.message
    np.testing.assert_array_equal(ours.t, t_eval)
    np.testing.assert_allclose(ours.q, reference.q, atol=1e-6)


def test_falls_back_to_rk45_with_a_warning(inverse, cache, monkeypatch, caplog):
    thigh = replace(LegDrivers.from_inverse(inverse), hip_in_thigh_frame=True)
    with caplog.at_level(logging.WARNING):
        sim = simulate_leg(inverse.model, thigh, (0.0, 0.1), options=CVODES)
    assert sim.status == "completed" and "rk45" in sim.message
    assert sim.options.method is Method.RK45   # what ran, for summaries
    assert "running rk45 instead" in caplog.text
    caplog.clear()
    monkeypatch.setenv(function_cache.SWITCH, "off")
    with caplog.at_level(logging.WARNING):
        sim = simulate_leg(inverse.model, LegDrivers.from_inverse(inverse), (0.0, 0.1),
                           options=CVODES)
    assert "rk45" in sim.message and len(caplog.records) == 1
