"""The compiled-solver cache can never crash a run or change its answer (issue 29, items 1-3).

One small real Ipopt solver is compiled per session; every test copies it into a fresh
cache folder and damages it (truncated, random bytes in its code, modified constants,
empty, a stub of another architecture) or the folder (read-only, another user's). Each
time the solve must give the right answer, in memory, with one warning line, and the
damaged library must be moved aside (``.quarantine-*``).

Read-only folders: the ``read_only`` fixture of conftest.py (``chattr +i`` as root, for
whom permission bits do not stop a write; ``chmod a-w`` otherwise). Another user's
folder: chown to uid 65534 (root only). A test says so when it cannot set its case up.
"""

import logging
import os
import struct
import time

import numpy as np
import pytest

from predgait import cache_library, function_cache
from predgait.problems import solver_cache

pytestmark = pytest.mark.skipif(solver_cache.compiler() is None,
                                reason="no C compiler: the cache is off by design")

OPTIONS = {"print_time": False, "ipopt": {"print_level": 0, "sb": "yes"}}
#: min (x0 - 1.625)^2 + (x1 - p)^2 + 0.375 (x0 - x1)^4, p = 0.5.
CONSTANTS = (1.625, 0.375)


def _nlp():
    import casadi as cs

    x, p = cs.MX.sym("x", 2), cs.MX.sym("p", 1)
    return {"x": x, "p": p, "g": x[0] + x[1],
            "f": (x[0] - CONSTANTS[0]) ** 2 + (x[1] - p) ** 2
            + CONSTANTS[1] * (x[0] - x[1]) ** 4}


def _expected():
    """The answer, from the SX problem in memory (and its stationarity checked)."""
    import casadi as cs

    x, p = cs.SX.sym("x", 2), cs.SX.sym("p", 1)
    nlp = {"x": x, "p": p, "g": x[0] + x[1],
           "f": (x[0] - CONSTANTS[0]) ** 2 + (x[1] - p) ** 2
           + CONSTANTS[1] * (x[0] - x[1]) ** 4}
    x_opt = np.asarray(cs.nlpsol("ref", "ipopt", nlp, OPTIONS)(x0=0, p=0.5)["x"]).ravel()
    cube = 4 * CONSTANTS[1] * (x_opt[0] - x_opt[1]) ** 3
    np.testing.assert_allclose([2 * (x_opt[0] - CONSTANTS[0]) + cube,
                                2 * (x_opt[1] - 0.5) - cube], 0.0, atol=1e-8)
    return x_opt


def _solve():
    import casadi as cs

    solver = solver_cache.ipopt_solver("tiny", _nlp(), OPTIONS)
    return np.asarray(solver(x0=0, p=0.5, lbg=-cs.inf, ubg=cs.inf)["x"]).ravel()


@pytest.fixture
def env(monkeypatch):
    monkeypatch.setenv(solver_cache.SWITCH, "on")
    monkeypatch.setenv(function_cache.WHEN, "now")
    cache_library._WARNED.clear()
    return monkeypatch


@pytest.fixture(scope="session")
def good_library(tmp_path_factory):
    """One compiled library of the small problem (the only compilation of this file)."""
    folder = tmp_path_factory.mktemp("compiled")
    patch = pytest.MonkeyPatch()
    patch.setenv(solver_cache.SWITCH, "on")
    patch.setenv(function_cache.WHEN, "now")
    patch.setenv(solver_cache.FOLDER, str(folder))
    try:
        x = _solve()
    finally:
        patch.undo()
    libraries = list(folder.glob("tiny-*.so"))
    assert len(libraries) == 1, "nothing compiled"
    np.testing.assert_allclose(x, _expected(), atol=1e-7)
    return libraries[0]


def _cache_with(tmp_path, env, library, data=None, name=None):
    """A cache folder holding ``library`` (its bytes replaced by ``data``)."""
    folder = tmp_path / "solvers"
    folder.mkdir(mode=0o700)
    target = folder / (name or library.name)
    target.write_bytes(library.read_bytes() if data is None else data)
    target.chmod(0o600)
    env.setenv(solver_cache.FOLDER, str(folder))
    return folder, target


def _no_compiling(env):
    def refuse(*args):
        raise AssertionError("compiled although the run should solve in memory")

    env.setattr(function_cache, "compile_into", refuse)


def _random_code(data: bytes) -> bytes:
    rng = np.random.default_rng(29)
    middle = len(data) // 2
    return data[:middle] + rng.bytes(4096) + data[middle + 4096:]


def _scaled_constants(data: bytes) -> bytes:
    for value in CONSTANTS:
        assert data.count(struct.pack("<d", value)) >= 1
        data = data.replace(struct.pack("<d", value), struct.pack("<d", value * 1.01))
    return data


DAMAGES = {"truncated": lambda data: data[: len(data) // 2],
           "random bytes in its code": _random_code,
           "modified constants": _scaled_constants,
           "empty": lambda data: b""}


@pytest.mark.parametrize("damage", list(DAMAGES))
def test_damaged_library_is_quarantined_and_the_run_solves_in_memory(
        damage, good_library, tmp_path, env, caplog):
    folder, target = _cache_with(tmp_path, env, good_library,
                                 DAMAGES[damage](good_library.read_bytes()))
    _no_compiling(env)
    with caplog.at_level(logging.WARNING):
        x = _solve()
    np.testing.assert_allclose(x, _expected(), atol=1e-7)
    assert not target.exists() and len(list(folder.glob(".quarantine-tiny-*"))) == 1
    lines = [r.getMessage() for r in caplog.records if "tiny" in r.getMessage()]
    assert len(lines) == 1 and "does not match its hash" in lines[0], lines
    assert "solving in memory" in lines[0]


def test_modified_constants_would_change_the_answer(good_library, tmp_path):
    """The damage above matters: loaded unchecked, the modified library answers wrong."""
    import casadi as cs

    modified = tmp_path / "modified.so"
    modified.write_bytes(_scaled_constants(good_library.read_bytes()))
    solver = cs.nlpsol("tiny", "ipopt", str(modified), OPTIONS)
    x = np.asarray(solver(x0=0, p=0.5, lbg=-cs.inf, ubg=cs.inf)["x"]).ravel()
    assert np.abs(x - _expected()).max() > 5e-3


def _other_architecture(data: bytes) -> bytes:
    """The ELF header's e_machine set to AArch64 (183)."""
    assert data[:4] == b"\x7fELF"
    return data[:18] + struct.pack("<H", 183) + data[20:]


@pytest.mark.parametrize("hash_renamed", [False, True])
def test_library_of_another_architecture_is_quarantined(good_library, tmp_path, env,
                                                        caplog, hash_renamed):
    """Under its own name (hash check) and renamed to its hash (then loading fails)."""
    data = _other_architecture(good_library.read_bytes())
    stem = good_library.stem.rsplit("-", 1)[0]
    name = f"{stem}-{cache_library.digest_of(data)}.so" if hash_renamed else None
    folder, target = _cache_with(tmp_path, env, good_library, data, name)
    _no_compiling(env)
    with caplog.at_level(logging.WARNING):
        x = _solve()
    np.testing.assert_allclose(x, _expected(), atol=1e-7)
    assert not target.exists() and len(list(folder.glob(".quarantine-*"))) == 1
    lines = [r.getMessage() for r in caplog.records if "tiny" in r.getMessage()]
    assert len(lines) == 1, lines
    assert ("fails to load" if hash_renamed else "does not match its hash") in lines[0]


def test_intact_library_is_loaded_not_compiled(good_library, tmp_path, env, caplog):
    folder, target = _cache_with(tmp_path, env, good_library)
    _no_compiling(env)
    loaded = []
    real = cache_library.find
    env.setattr(cache_library, "find", lambda *a: loaded.append(1) or real(*a))
    with caplog.at_level(logging.WARNING):
        x = _solve()
    np.testing.assert_allclose(x, _expected(), atol=1e-7)
    assert loaded and target.exists() and not caplog.records


def test_library_key_follows_the_compiler_and_machine(monkeypatch):
    first = function_cache.library_stem("tiny", "k")
    monkeypatch.setattr(cache_library, "_compiler_version", lambda c: "gcc (other) 99.1")
    assert function_cache.library_stem("tiny", "k") != first
    monkeypatch.undo()
    monkeypatch.setattr(cache_library.platform, "machine", lambda: "aarch64")
    assert function_cache.library_stem("tiny", "k") != first


def test_library_that_crashes_its_test_call_is_never_published(tmp_path, env, caplog):
    """A compiler whose libraries crash when loaded (a constructor raising SIGSEGV): the
    crash happens in the child process, the run goes on in memory."""
    import casadi as cs

    crash = tmp_path / "crash.c"
    crash.write_text("#include <signal.h>\n"
                     "__attribute__((constructor)) static void boom(void) { raise(SIGSEGV); }\n")
    wrapper = tmp_path / "cc-crash"
    wrapper.write_text(f"#!/bin/sh\nexec {solver_cache.compiler()} \"$@\" {crash}\n")
    wrapper.chmod(0o755)
    env.setenv("CC", str(wrapper))
    env.setenv(solver_cache.FOLDER, str(tmp_path / "solvers"))
    x = cs.SX.sym("x", 2)
    function = cs.Function("sphere", [x], [x[0] ** 2 + x[1] ** 2])
    with caplog.at_level(logging.WARNING):
        assert function_cache.compiled(function, "k") is None
    assert not list((tmp_path / "solvers").glob("*.so"))
    assert not list((tmp_path / "solvers").glob(".build-*"))
    assert len(list((tmp_path / "solvers").glob(".quarantine-sphere-*"))) == 1
    assert "crashed (SIGSEGV)" in caplog.text


def _one_warning_of_two_runs(caplog, folder):
    with caplog.at_level(logging.WARNING):
        first, second = _solve(), _solve()
    np.testing.assert_allclose(first, _expected(), atol=1e-7)
    np.testing.assert_allclose(second, _expected(), atol=1e-7)
    lines = [r.getMessage() for r in caplog.records]
    assert len(lines) == 1 and str(folder) in lines[0] and "solving in memory" in lines[0], \
        lines
    return lines[0]


def test_full_cache_on_a_read_only_folder_solves_in_memory(good_library, tmp_path, env,
                                                           caplog, read_only):
    folder, target = _cache_with(tmp_path, env, good_library)
    read_only(target, folder)
    _no_compiling(env)
    assert "read-only" in _one_warning_of_two_runs(caplog, folder)
    assert sorted(p.name for p in folder.iterdir()) == [good_library.name]


def test_empty_unwritable_cache_solves_in_memory(tmp_path, env, caplog, read_only):
    folder = tmp_path / "solvers"
    folder.mkdir(mode=0o700)
    read_only(folder)
    env.setenv(solver_cache.FOLDER, str(folder))
    _no_compiling(env)
    assert "read-only" in _one_warning_of_two_runs(caplog, folder)


def test_cache_of_another_user_is_not_used(good_library, tmp_path, env, caplog):
    if os.geteuid() != 0:
        pytest.skip("needs root to give the folder to another user")
    folder, target = _cache_with(tmp_path, env, good_library)
    os.chown(target, 65534, 65534)
    os.chown(folder, 65534, 65534)
    _no_compiling(env)
    assert "belongs to another user" in _one_warning_of_two_runs(caplog, folder)
    assert target.exists()


def test_cache_writable_by_others_is_not_used(good_library, tmp_path, env, caplog):
    folder, _ = _cache_with(tmp_path, env, good_library)
    folder.chmod(0o777)
    _no_compiling(env)
    assert "writable by other users" in _one_warning_of_two_runs(caplog, folder)


def test_concurrent_writers_each_publish_a_whole_file(good_library, tmp_path, env):
    """Two writers of the same library: unique temporary folders, one rename each; a
    reader finds a whole, checked file whatever the order."""
    import casadi as cs

    folder, _ = _cache_with(tmp_path, env, good_library)
    stem = good_library.stem.rsplit("-", 1)[0]
    env.setattr(cache_library, "test_in_child", lambda *a, **k: None)
    published = []
    for tag in (b"A", b"B"):
        build = folder / f".build-{tag.decode()}"
        build.mkdir()
        (build / "lib.so").write_bytes(good_library.read_bytes() + tag * 64)
        published.append(cache_library.publish(build / "lib.so", folder, stem, ["nlp"]))
    assert len(set(published)) == 2 and all(p.exists() for p in published)
    now = time.time()
    os.utime(published[1], (now + 10, now + 10))
    found, quarantined = cache_library.find(folder, stem)
    assert found == published[1] and not quarantined
    solver = cs.nlpsol("tiny", "ipopt", str(found), OPTIONS)  # trailing bytes: loads
    x = np.asarray(solver(x0=0, p=0.5, lbg=-cs.inf, ubg=cs.inf)["x"]).ravel()
    np.testing.assert_allclose(x, _expected(), atol=1e-7)


def test_damaged_serialised_function_is_rebuilt(tmp_path, env, caplog):
    import casadi as cs

    env.setenv(solver_cache.FOLDER, str(tmp_path / "solvers"))

    def build():
        x = cs.SX.sym("x")
        return cs.Function("cube", [x], [2.5 * x ** 3])

    assert float(function_cache.stored("cube", "k1", build)(2.0)) == 20.0
    path = tmp_path / "solvers" / "cube-k1.casadi"
    text = path.read_text()
    head, body = text.split("\n", 1)
    changed = body.replace(body[len(body) // 2], "x" if body[len(body) // 2] != "x" else "y", 1)
    path.write_text(f"{head}\n{changed}")
    with caplog.at_level(logging.WARNING):
        assert float(function_cache.stored("cube", "k1", build)(2.0)) == 20.0
    assert "does not match its hash" in caplog.text
    assert path.read_text() == text  # rebuilt and stored again


def test_child_test_call_reports_a_crash_without_crashing_us(good_library, tmp_path):
    library = tmp_path / "random.so"
    library.write_bytes(_random_code(good_library.read_bytes()))
    problem = cache_library.test_in_child(library, ["nlp_f"])
    assert problem is not None and problem.startswith("a test call")
    assert cache_library.test_in_child(good_library, ["nlp", "nlp_f", "nlp_hess_l"]) is None
