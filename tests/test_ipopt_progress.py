"""Live Ipopt progress (predgait.problems.ipopt_progress): every N iterations, stages, off."""

import casadi as cs
import numpy as np
import pytest

from predgait.problems import ipopt_progress as progress

X = cs.SX.sym("x", 2)
P = cs.SX.sym("p")
#: Rosenbrock with x0 + x1 in [0.5, 1]: its start (-1, 1) violates the lower bound by 0.5.
NLP = {"x": X, "p": P, "f": (X[0] - P) ** 2 + 100 * (X[1] - X[0] ** 2) ** 2, "g": X[0] + X[1]}


def solve(lines, every):
    with progress.reporting(every, lines.append):
        progress.stage("stage 1/1: a test")
        solver = cs.nlpsol("s", "ipopt", NLP, {
            "ipopt": {"print_level": 0, "sb": "yes"}, "print_time": False,
            **progress.callback_options("s", 2, 1, 1)})
        with progress.solving("rosenbrock", 0.5, 1.0):
            out = solver(x0=[-1.0, 1.0], p=1.0, lbg=0.5, ubg=1.0)
    return solver.stats(), out


def test_a_line_every_n_iterations_with_objective_and_violation():
    lines = []
    stats, _ = solve(lines, every=3)
    count = stats["iter_count"]
    iters = [line for line in lines if ": iter " in line]
    assert [int(line.split()[-7]) for line in iters] == list(range(0, count + 1, 3))
    first = iters[0].split()
    # At the start (-1, 1): objective (-1 - 1)^2 + 100 (1 - 1)^2 = 4, violation 0.5 - 0 = 0.5.
    assert float(first[-5]) == pytest.approx(4.0) and float(first[-1]) == pytest.approx(0.5)
    assert lines[0] == "stage 1/1: a test" and lines[1] == "rosenbrock: Ipopt started"
    assert lines[-1].startswith(f"rosenbrock: Ipopt stopped after {count} iterations")


def test_nothing_is_attached_or_printed_when_off():
    lines = []
    solve(lines, every=0)
    assert lines == []
    assert progress.callback_options("s", 2, 1) == {} and not progress.active()


def test_violation_of_bounds():
    g = np.array([0.0, 2.0, -1.0])
    assert progress.violation(g, np.array([0.0]), np.array([1.0])) == 1.0
    assert progress.violation(g, np.array([-np.inf, -np.inf, 0.5]),
                              np.array([np.inf, 2.5, np.inf])) == 1.5
    assert progress.violation(np.zeros(0), np.zeros(0), np.zeros(0)) == 0.0
