"""Compiled solver cache (problems.solver_cache): the compiled MX solver finds what the
in-memory SX solver finds, a second build loads the library instead of compiling, the
first run solves in memory while the compiler runs in the background, the key follows the
problem's structure, and a failing compiler falls back to the in-memory solver."""

import time

import numpy as np
import pytest

from predgait import function_cache
from predgait.dynamics.drivers import LegDrivers
from predgait.dynamics.inverse_trial import bundled_inverse
from predgait.problems import fitting, solver_cache
from predgait.problems.collocation import NodeData

needs_compiler = pytest.mark.skipif(solver_cache.compiler() is None,
                                    reason="no C compiler: the cache is off by design")


@pytest.fixture(scope="module")
def knee_nodes():
    inverse = bundled_inverse("right")
    return inverse.model, NodeData.from_drivers(LegDrivers.from_inverse(inverse), 0.0, 0.3, 24)


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """The cache on, in a fresh folder, compiling in the foreground; the problems'
    in-process memo emptied around."""
    monkeypatch.setenv(solver_cache.SWITCH, "on")
    monkeypatch.setenv(function_cache.WHEN, "now")
    monkeypatch.setenv(solver_cache.FOLDER, str(tmp_path / "solvers"))
    fitting._knee_problem.cache_clear()
    yield tmp_path / "solvers"
    fitting._knee_problem.cache_clear()


def fit(model, nodes):
    fitting._knee_problem.cache_clear()
    return fitting.fit_knee(model, nodes)


@needs_compiler
def test_compiled_solver_equals_the_in_memory_one_and_is_reused(knee_nodes, cache,
                                                                monkeypatch):
    model, nodes = knee_nodes
    compiled = fit(model, nodes)
    libraries = list(cache.glob("*.so"))
    assert len(libraries) == 1 and not list(cache.glob(".build-*"))

    def no_compiling(*args):
        raise AssertionError("compiled again although the library is cached")

    monkeypatch.setattr(function_cache, "compile_into", no_compiling)
    again = fit(model, nodes)
    assert again.parameters == compiled.parameters
    monkeypatch.setenv(solver_cache.SWITCH, "off")
    in_memory = fit(model, nodes)
    assert list(cache.glob("*.so")) == libraries
    for name, value in in_memory.parameters.items():
        assert compiled.parameters[name] == pytest.approx(value, rel=1e-5, abs=1e-7), name
    np.testing.assert_allclose(compiled.x, in_memory.x, atol=1e-7)


@needs_compiler
def test_key_follows_the_structure_not_the_run(knee_nodes, cache):
    import casadi as cs

    x, p = cs.MX.sym("x", 3), cs.MX.sym("p", 2)
    nlp = {"x": x, "p": p, "f": cs.sumsqr(x[:2] - p), "g": x[2] - x[0]}
    key = solver_cache.solver_key("s", nlp, {"ipopt": {"tol": 1e-8}})
    rebuilt = {"x": x, "p": p, "f": cs.sumsqr(x[:2] - p), "g": x[2] - x[0]}
    assert solver_cache.solver_key("s", rebuilt, {"ipopt": {"tol": 1e-8}}) == key
    assert solver_cache.solver_key("s", nlp, {"ipopt": {"tol": 1e-6}}) != key
    changed = dict(nlp, g=x[2] - 2 * x[0])
    assert solver_cache.solver_key("s", changed, {"ipopt": {"tol": 1e-8}}) != key


@needs_compiler
def test_a_failing_compiler_leaves_the_in_memory_solver(knee_nodes, cache, monkeypatch,
                                                         caplog):
    model, nodes = knee_nodes
    monkeypatch.setenv("CC", "false")     # a compiler that always fails
    result = fit(model, nodes)
    assert result.solved.success
    assert not list(cache.glob("*.so")) and not list(cache.glob(".build-*"))
    assert not list(cache.glob(".pending-*"))
    assert "not compiled" in caplog.text


@needs_compiler
def test_first_run_solves_in_memory_while_compiling_in_the_background(knee_nodes, cache,
                                                                       monkeypatch):
    model, nodes = knee_nodes
    monkeypatch.setenv(function_cache.WHEN, "background")
    first = fit(model, nodes)
    deadline = time.time() + 300
    while list(cache.glob(".pending-*")) and time.time() < deadline:
        time.sleep(1.0)
    libraries = list(cache.glob("*.so"))
    assert len(libraries) == 1 and not list(cache.glob(".build-*"))
    loaded = fit(model, nodes)
    for name, value in first.parameters.items():
        assert loaded.parameters[name] == pytest.approx(value, rel=1e-5, abs=1e-7), name


def test_off_switch_and_folder(monkeypatch, tmp_path):
    import casadi as cs

    monkeypatch.setenv(solver_cache.SWITCH, "off")
    assert not solver_cache.enabled() and solver_cache.symbol_type() is cs.SX
    monkeypatch.delenv(solver_cache.FOLDER, raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert solver_cache.cache_folder() == tmp_path / "predgait" / "solvers"
