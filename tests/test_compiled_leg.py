"""The leg's CasADi fast path (dynamics.compiled_leg) against the Pinocchio engine.

The right-hand side and the ground reaction at random states and times, whole fixed-step
runs (modified Euler, RK4, Euler; fall events, output times, divergence), in CasADi's
virtual machine and compiled; the fallback when a force is not supported; and the cache
of functions (predgait.function_cache): stored once, compiled in the foreground or the
background, pruned.
"""

import os
import time
from dataclasses import replace

import numpy as np
import pytest

from predgait import function_cache
from predgait.dynamics import compiled_leg
from predgait.dynamics.drivers import LegDrivers
from predgait.dynamics.falls import FallLimit
from predgait.dynamics.forces import JointFeedback
from predgait.dynamics.forward import LegSystem, simulate_leg
from predgait.dynamics.integrators import IntegratorOptions, Method
from predgait.dynamics.inverse_trial import bundled_inverse
from predgait.dynamics.passive import ExponentialLimits, LinearSpringDamper, PassiveJoint
from predgait.errors import SimulationDiverged

needs_compiler = pytest.mark.skipif(function_cache.compiler() is None,
                                    reason="no C compiler")
PASSIVE = {"knee": PassiveJoint((LinearSpringDamper(10.0, 20.0),
                                 ExponentialLimits(c_limit=2.0))),
           "hip": PassiveJoint((LinearSpringDamper(5.0, 1.0, 0.1),))}


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """The cache on in a fresh folder, compiling in the foreground; memos emptied."""
    monkeypatch.setenv(function_cache.SWITCH, "on")
    monkeypatch.setenv(function_cache.FOLDER, str(tmp_path / "cache"))
    monkeypatch.setenv(function_cache.WHEN, "now")
    monkeypatch.setattr(compiled_leg, "_STEPS", {})
    compiled_leg.leg_dynamics.cache_clear()
    yield tmp_path / "cache"
    compiled_leg.leg_dynamics.cache_clear()


@pytest.fixture(scope="module")
def inverse():
    return bundled_inverse("right")


def configurations(inverse):
    """(name, drivers, feedback): lab hip load; passive + thigh-frame hip + feedback."""
    plain = LegDrivers.from_inverse(inverse)
    rich = replace(LegDrivers.from_inverse(inverse, passive=PASSIVE), hip_in_thigh_frame=True)
    feedback = JointFeedback(np.arange(3, 5), rich.reference, 50.0, np.array([5.0, 3.0]))
    return [("lab hip", plain, None), ("passive, thigh hip, feedback", rich, feedback)]


def test_right_hand_side_and_reaction_equal_pinocchio(inverse, cache, monkeypatch):
    monkeypatch.setattr(function_cache, "compiler", lambda: None)
    rng = np.random.default_rng(3)
    for name, drivers, feedback in configurations(inverse):
        system = LegSystem(inverse.model, drivers, feedback=feedback)
        fast = compiled_leg.fast_leg(system)
        assert fast is not None, name
        for _ in range(10):
            t = rng.uniform(0.0, 1.2)
            x = rng.normal(size=4) * [0.3, 0.5, 2.0, 2.0]
            xdot, reaction = (np.asarray(r).ravel() for r in fast.rhs(x, fast.inputs([t])[0]))
            q, v, a = system.full_state(t, x)
            a_free, expected_reaction = system.solve(t, q, v, a)
            expected = system(t, x)
            np.testing.assert_allclose(xdot, expected, rtol=1e-10,
                                       atol=1e-10 * np.abs(expected).max(), err_msg=name)
            np.testing.assert_allclose(reaction, expected_reaction, rtol=1e-10,
                                       atol=1e-10 * np.abs(expected_reaction).max())


def _assert_same_run(fast, reference):
    assert (fast.status, fast.event, fast.n_rhs_evaluations) == (
        reference.status, reference.event, reference.n_rhs_evaluations)
    np.testing.assert_allclose(fast.t, reference.t, rtol=0, atol=1e-12)
    np.testing.assert_allclose(fast.q, reference.q, rtol=0, atol=1e-9)
    np.testing.assert_allclose(fast.v, reference.v, rtol=0, atol=1e-7)
    for name in ("a", "reaction", "grf"):
        got, want = getattr(fast, name), getattr(reference, name)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-8 * np.abs(want).max())


@pytest.mark.parametrize("compiled", [False, pytest.param(True, marks=needs_compiler)])
def test_whole_runs_equal_the_pinocchio_engine(inverse, cache, monkeypatch, compiled):
    if not compiled:
        monkeypatch.setattr(function_cache, "compiler", lambda: None)
    runs = [(Method.MODIFIED_EULER, 10, None), (Method.RK4, 1, np.linspace(0.0, 0.6, 37)),
            (Method.EULER, 1, None)]
    for (_, drivers, feedback), (method, iterations, t_eval) in zip(
            configurations(inverse) * 2, runs, strict=False):
        options = IntegratorOptions(method=method, step=1e-3, iterations=iterations)
        kwargs = {"feedback": feedback, "options": options, "t_eval": t_eval,
                  "fall": FallLimit(segment_angle_deg=60.0)}
        fast = simulate_leg(inverse.model, drivers, (0.0, 0.6), **kwargs)
        assert LegSystem(inverse.model, drivers, feedback=feedback).fast_path(options)
        monkeypatch.setenv(function_cache.SWITCH, "off")
        reference = simulate_leg(inverse.model, drivers, (0.0, 0.6), **kwargs)
        monkeypatch.setenv(function_cache.SWITCH, "on")
        _assert_same_run(fast, reference)
    assert bool(list(cache.glob("leg_step*.so"))) == compiled
    assert reference.status == "event"  # the open-loop leg falls within 0.6 s


def test_divergence_is_reported_at_the_same_step(cache, monkeypatch):
    from predgait.models.loading import load_model

    monkeypatch.setattr(function_cache, "compiler", lambda: None)
    model = load_model("leg")
    drivers = LegDrivers.still(joint_torque=(3e4, -3e4))
    options = IntegratorOptions(method=Method.EULER, step=0.01)
    errors = []
    for switch in ("on", "off"):
        monkeypatch.setenv(function_cache.SWITCH, switch)
        with pytest.raises(SimulationDiverged) as caught:
            simulate_leg(model, drivers, (0.0, 10.0), np.zeros(4), options=options)
        errors.append(caught.value)
    assert str(errors[0]) == str(errors[1])
    np.testing.assert_allclose(errors[0].partial.q, errors[1].partial.q, rtol=1e-12)


def test_unsupported_forces_and_cache_off_fall_back(inverse, cache, monkeypatch):
    drivers = LegDrivers.from_inverse(inverse)
    system = LegSystem(inverse.model, drivers, free=("knee",))
    assert compiled_leg.fast_leg(system) is None
    monkeypatch.setenv(function_cache.SWITCH, "off")
    assert compiled_leg.fast_leg(LegSystem(inverse.model, drivers)) is None


def test_stored_functions_are_built_once(cache):
    import casadi as cs

    built = []

    def build():
        x = cs.SX.sym("x")
        built.append(1)
        return cs.Function("square", [x], [x * x])

    first = function_cache.stored("square", "k1", build)
    again = function_cache.stored("square", "k1", build)
    assert len(built) == 1 and float(again(3.0)) == float(first(3.0)) == 9.0
    assert (cache / "square-k1.casadi").is_file()


@needs_compiler
def test_background_worker_compiles_every_queued_function(cache, monkeypatch):
    import casadi as cs

    monkeypatch.setenv(function_cache.WHEN, "background")
    x = cs.SX.sym("x", 2)
    functions = [cs.Function("rosen", [x], [(1 - x[0]) ** 2 + 100 * (x[1] - x[0] ** 2) ** 2]),
                 cs.Function("sphere", [x], [x[0] ** 2 + x[1] ** 2])]
    for function in functions:  # not waited for: the second is queued for the same worker
        assert function_cache.compiled(function, "k2") is None
    deadline = time.time() + 180
    while list(cache.glob(".pending-*")) and time.time() < deadline:
        time.sleep(0.5)
    for function in functions:
        loaded = function_cache.compiled(function, "k2")
        assert loaded is not None and float(loaded([0.5, 0.2])) == float(function([0.5, 0.2]))
    assert not list(cache.glob(".build-*")) and not (cache / ".worker").exists()


def test_passive_values_and_gains_are_parameters_not_structure(inverse, cache, monkeypatch):
    """One step function (one library) serves every value of the elements and gains; a
    zero (no stop damping) is structure, as in the numeric element."""
    monkeypatch.setattr(function_cache, "compiler", lambda: None)

    def key(passive, kp=50.0):
        drivers = LegDrivers.from_inverse(inverse, passive=passive)
        feedback = JointFeedback(np.arange(3, 5), drivers.reference, kp, 5.0)
        return compiled_leg.fast_leg(LegSystem(inverse.model, drivers, feedback=feedback))._key

    def knee(k, c, c_limit):
        return {"knee": PassiveJoint((LinearSpringDamper(k, c),
                                      ExponentialLimits(c_limit=c_limit)))}

    assert key(knee(10.0, 20.0, 2.0)) == key(knee(100.0, 100.0, 1.0), kp=80.0)
    assert key(knee(10.0, 20.0, 2.0)) != key(knee(10.0, 20.0, 0.0))
    other = {"knee": PassiveJoint((LinearSpringDamper(100.0, 100.0),
                                   ExponentialLimits(k_lower=0.5, c_limit=1.0)))}
    options = IntegratorOptions(method=Method.MODIFIED_EULER, step=1e-3, iterations=4)
    drivers = LegDrivers.from_inverse(inverse, passive=other)
    fast = simulate_leg(inverse.model, drivers, (0.0, 0.4), options=options)
    monkeypatch.setenv(function_cache.SWITCH, "off")
    _assert_same_run(fast, simulate_leg(inverse.model, drivers, (0.0, 0.4), options=options))


def test_prune_removes_old_then_least_recently_used(tmp_path):
    now = time.time()
    for name, age_days, size in (("old.so", 90, 10), ("a.casadi", 3, 400), ("b.so", 2, 400),
                                 ("c.so", 1, 400)):
        path = tmp_path / name
        path.write_bytes(b"x" * size)
        os.utime(path, (now - age_days * 86400, now - age_days * 86400))
    function_cache.prune(tmp_path, max_bytes=900, max_age_days=60)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b.so", "c.so"]
