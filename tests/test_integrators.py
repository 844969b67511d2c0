"""Integrators: discretisations derived by hand, convergence orders, energy, events, divergence.

Known answers: the harmonic oscillator and y' = y cos t (exact solutions), the simple
pendulum's energy, the inverted pendulum's time to fall from the energy integral, and
the thesis' observation (4.2, Figs. 4.2.2 and 4.2.5) that 10 modified-Euler iterations
follow a collapse far better than 1 at h = 0.05 s.
"""

import numpy as np
import pytest
from scipy.integrate import quad

from predgait.dynamics.integrators import (
    Direction,
    Event,
    GridSolverFailed,
    IntegratorOptions,
    Method,
    Status,
    integrate,
)
from predgait.errors import InputError, SimulationDiverged

G, L = 9.81, 1.0  # m/s^2, m (pendulum length)
A_OSC = np.array([[0.0, 1.0], [-1.0, 0.0]])


def oscillator(t, x):
    return np.array([x[1], -x[0]])


def oscillator_exact(t):
    return np.array([np.cos(t), -np.sin(t)])


def exp_sin(t, x):  # non-autonomous: y' = y cos t, y(0) = 1 -> y = exp(sin t)
    return x * np.cos(t)


def exp_sin_exact(t):
    return np.array([np.exp(np.sin(t))])


PROBLEMS = {"oscillator": (oscillator, oscillator_exact, [1.0, 0.0]),
            "exp_sin": (exp_sin, exp_sin_exact, [1.0])}


def pendulum(t, x):  # theta from hanging, rad
    return np.array([x[1], -G / L * np.sin(x[0])])


def inverted(t, x):  # theta from upright, rad
    return np.array([x[1], G / L * np.sin(x[0])])


def energy(x):  # per unit mass, J/kg
    return 0.5 * L**2 * x[:, 1] ** 2 + G * L * (1.0 - np.cos(x[:, 0]))


def options(method, step=1e-3, iterations=10, **kw):
    return IntegratorOptions(method=method, step=step, iterations=iterations, **kw)


def final_error(problem, method, step, iterations):
    rhs, exact, x0 = PROBLEMS[problem]
    result = integrate(rhs, (0.0, 2.0), x0, options=options(method, step, iterations))
    assert result.t[-1] == 2.0
    return np.max(np.abs(result.x[-1] - exact(2.0)))


# --- discretisations derived by hand (linear system x' = A x) ---------------------------

def test_one_step_matches_hand_derived_discretisations():
    h, x0 = 0.1, np.array([1.0, 0.0])
    eye, hA = np.eye(2), 0.1 * A_OSC
    expected = {
        (Method.EULER, 1): (eye + hA) @ x0,
        (Method.MODIFIED_EULER, 1): (eye + hA) @ x0,
        (Method.MODIFIED_EULER, 2): (eye + hA + hA @ hA / 2) @ x0,  # Heun
        (Method.MODIFIED_EULER, 3): (eye + hA + hA @ hA / 2 + hA @ hA @ hA / 4) @ x0,
        (Method.MODIFIED_EULER, 100): np.linalg.solve(eye - hA / 2, (eye + hA / 2) @ x0),
        (Method.RK4, 1): (eye + hA + hA @ hA / 2 + hA @ hA @ hA / 6
                          + hA @ hA @ hA @ hA / 24) @ x0,
    }
    for (method, iterations), x1 in expected.items():
        result = integrate(oscillator, (0.0, h), x0, options=options(method, h, iterations))
        assert result.t.tolist() == [0.0, h]
        np.testing.assert_allclose(result.x[-1], x1, rtol=0, atol=1e-14,
                                   err_msg=f"{method} k={iterations}")


def test_rhs_evaluations_follow_the_thesis_count():
    # 1 s at h = 1 ms with 10 iterations: 10 evaluations per step (+1 at the end).
    result = integrate(oscillator, (0.0, 1.0), [1.0, 0.0],
                       options=options(Method.MODIFIED_EULER, 1e-3, 10))
    assert result.n_rhs_evaluations == 10_001
    assert result.t.shape == (1001,) and result.x.shape == (1001, 2)
    np.testing.assert_allclose(np.diff(result.t), 1e-3, rtol=1e-9)


def test_short_last_step_ends_at_t_end():
    result = integrate(oscillator, (0.0, 0.0105), [1.0, 0.0], options=options(Method.RK4, 1e-3))
    assert result.t[-1] == 0.0105 and result.t.size == 12
    np.testing.assert_allclose(result.x[-1], oscillator_exact(0.0105), atol=1e-14)


# --- convergence orders ------------------------------------------------------------------

STEPS = np.array([0.04, 0.02, 0.01, 0.005])


@pytest.mark.parametrize("problem", sorted(PROBLEMS))
@pytest.mark.parametrize("method, iterations, order", [
    (Method.EULER, 1, 1), (Method.MODIFIED_EULER, 1, 1), (Method.MODIFIED_EULER, 2, 2),
    (Method.MODIFIED_EULER, 30, 2), (Method.RK4, 1, 4)],
    ids=["euler", "modified_euler_1", "modified_euler_2", "modified_euler_30", "rk4"])
def test_convergence_order(problem, method, iterations, order):
    errors = [final_error(problem, method, h, iterations) for h in STEPS]
    slope = np.polyfit(np.log(STEPS), np.log(errors), 1)[0]
    assert abs(slope - order) < 0.15, f"slope {slope:.3f}, errors {errors}"


@pytest.mark.parametrize("problem", sorted(PROBLEMS))
def test_more_iterations_reduce_error_of_heun(problem):
    # Heun's local error is -h^3 y'''/6, the trapezoidal rule's (k -> inf) +h^3 y'''/12.
    for h in (0.02, 0.01):
        heun = final_error(problem, Method.MODIFIED_EULER, h, 2)
        many = final_error(problem, Method.MODIFIED_EULER, h, 30)
        assert many < 0.7 * heun


# --- energy of the undamped simple pendulum ----------------------------------------------

@pytest.mark.parametrize("method, step, tolerance", [
    (Method.RK4, 1e-3, 1e-10), (Method.RADAU, 1e-2, 1e-7), (Method.MODIFIED_EULER, 1e-3, 1e-5)])
def test_pendulum_energy_is_conserved(method, step, tolerance):
    result = integrate(pendulum, (0.0, 10.0), [1.0, 0.0],
                       options=options(method, step, rtol=1e-8, atol=1e-10))
    e = energy(result.x)
    assert result.t[-1] == 10.0
    assert np.max(np.abs(e - e[0])) / e[0] < tolerance


def test_explicit_euler_gains_energy():
    # One iteration = explicit Euler: |1 + i h w| > 1, the pendulum swings ever higher.
    result = integrate(pendulum, (0.0, 10.0), [1.0, 0.0],
                       options=options(Method.MODIFIED_EULER, 1e-3, 1))
    e = energy(result.x)
    assert e[-1] > 1.05 * e[0]
    assert np.all(e[1000::1000] > e[0])  # gains at every second, not a fluctuation


# --- the thesis' collapse with a large step (4.2, Figs. 4.2.2b and 4.2.5) --------------

def test_ten_iterations_follow_collapse_better_than_one_at_large_step():
    x0, t_end = [np.radians(5.0), 0.0], 0.6
    reference = integrate(inverted, (0.0, t_end), x0,
                          options=options(Method.RADAU, 0.05, rtol=1e-11, atol=1e-13))
    errors = {}
    for k in (1, 2, 10):
        result = integrate(inverted, (0.0, t_end), x0,
                           options=options(Method.MODIFIED_EULER, 0.05, k))
        np.testing.assert_allclose(result.t, reference.t, atol=1e-12)
        errors[k] = np.max(np.abs(result.x[:, 0] - reference.x[:, 0]))
    assert errors[10] < 0.1 * errors[1]  # 1 -> 10 iterations: order-of-magnitude better
    assert errors[10] < errors[2] < errors[1]
    assert np.degrees(errors[1]) > 1.0  # explicit Euler lags the fall by over a degree


# --- events: time to fall -----------------------------------------------------------------

THETA0, THETA_FALL = np.radians(5.0), np.radians(60.0)


def time_to_fall_exact():
    # Energy: theta'^2 = 2 g/L (cos theta0 - cos theta); t = integral of dtheta / theta'.
    # cos a - cos b = 2 sin((a + b)/2) sin((b - a)/2) and sin(d/2) = (d/2) sinc(d/2pi)
    # leave d^-1/2 (d = theta - theta0) times a smooth function: quad's algebraic weight.
    def smooth(theta):
        d = theta - THETA0
        return 1.0 / np.sqrt(2 * G / L * np.sin((theta + THETA0) / 2) * np.sinc(d / 2 / np.pi))

    value, _ = quad(smooth, THETA0, THETA_FALL, weight="alg", wvar=(-0.5, 0.0),
                    epsabs=1e-13, epsrel=1e-12)
    return value


@pytest.mark.parametrize("method, tolerance", [
    (Method.RK4, 1e-9), (Method.MODIFIED_EULER, 1e-5), (Method.EULER, 5e-3),
    (Method.RK45, 1e-4), (Method.RADAU, 1e-4), (Method.BDF, 1e-4), (Method.LSODA, 1e-4)])
def test_time_to_fall(method, tolerance):
    fall = Event.state_crosses("fall", 0, THETA_FALL, absolute=True)
    result = integrate(inverted, (0.0, 3.0), [THETA0, 0.0], options=options(method),
                       events=[fall])
    exact = time_to_fall_exact()
    assert result.status is Status.EVENT and result.event_name == "fall"
    assert abs(result.event_time - exact) < tolerance
    assert result.t[-1] == result.event_time
    assert abs(result.x[-1, 0] - THETA_FALL) < 1e-6 or method is Method.EULER
    assert np.all(np.diff(result.t) > 0)


@pytest.mark.parametrize("method", [Method.RK4, Method.RADAU])
def test_event_direction_and_earliest_event(method):
    falling = Event("never", lambda t, x: x[0] - np.radians(30.0), Direction.FALLING)
    late = Event.state_crosses("late", 0, np.radians(50.0))
    early = Event.state_crosses("early", 0, np.radians(40.0))
    result = integrate(inverted, (0.0, 3.0), [THETA0, 0.0], options=options(method),
                       events=[falling, late, early])
    assert result.event_name == "early"
    assert abs(result.x[-1, 0] - np.radians(40.0)) < 1e-6


@pytest.mark.parametrize("method", [Method.MODIFIED_EULER, Method.RK45])
def test_event_with_t_eval_ends_at_event(method):
    t_eval = np.linspace(0.0, 3.0, 31)
    result = integrate(inverted, (0.0, 3.0), [THETA0, 0.0], options=options(method),
                       t_eval=t_eval, events=[Event.state_crosses("fall", 0, THETA_FALL)])
    exact = time_to_fall_exact()
    assert np.all(result.t[:-1] == t_eval[t_eval < exact])
    assert abs(result.t[-1] - exact) < 1e-3


def test_no_event_completes():
    result = integrate(pendulum, (0.0, 2.0), [0.5, 0.0], options=options(Method.RK4),
                       events=[Event.state_crosses("fall", 0, 1.0, absolute=True)])
    assert result.status is Status.COMPLETED and result.event_time is None


# --- output grids ---------------------------------------------------------------------

@pytest.mark.parametrize("method, tolerance", [
    (Method.RK4, 1e-9), (Method.MODIFIED_EULER, 1e-5), (Method.RADAU, 1e-6), (Method.LSODA, 1e-5)])
def test_t_eval_output(method, tolerance):
    t_eval = np.array([0.0, 0.0123, 0.5, 1.337, 2.0])
    result = integrate(oscillator, (0.0, 2.0), [1.0, 0.0], options=options(method),
                       t_eval=t_eval)
    np.testing.assert_array_equal(result.t, t_eval)
    np.testing.assert_allclose(result.x, oscillator_exact(t_eval).T, atol=tolerance)


def test_adaptive_output_on_step_grid():
    result = integrate(oscillator, (0.0, 1.0), [1.0, 0.0],
                       options=options(Method.RK45, step=0.01, rtol=1e-9, atol=1e-12))
    np.testing.assert_allclose(result.t, np.linspace(0.0, 1.0, 101), atol=1e-12)
    np.testing.assert_allclose(result.x, oscillator_exact(result.t).T, atol=1e-8)


def test_progress_bar_does_not_change_results():
    for method in (Method.MODIFIED_EULER, Method.RADAU):
        a = integrate(oscillator, (0.0, 1.0), [1.0, 0.0], options=options(method))
        b = integrate(oscillator, (0.0, 1.0), [1.0, 0.0], options=options(method), progress=True)
        np.testing.assert_array_equal(a.x, b.x)


# --- divergence ---------------------------------------------------------------------------

def blow_up(t, x):  # x0' = x0^2: x0 = 1 / (1 - t) for x0(0) = 1, infinite at t = 1
    return np.array([0.0, x[1] ** 2])


@pytest.mark.parametrize("method", [Method.EULER, Method.MODIFIED_EULER, Method.RK4,
                                    Method.RK45, Method.RADAU, Method.BDF])
def test_divergence_raises_with_partial_result(method):
    with pytest.raises(SimulationDiverged) as caught:
        integrate(blow_up, (0.0, 2.0), [0.0, 1.0], options=options(method),
                  state_names=("hip", "knee"))
    message, partial = str(caught.value), caught.value.partial
    assert "'knee' (index 1)" in message and "divergence limit" in message
    assert partial.status is Status.DIVERGED and partial.message == message
    assert 0.9 < partial.t[-1] < 1.05
    assert np.all(np.isfinite(partial.x)) and np.all(np.abs(partial.x) <= 1e6)
    assert partial.x.shape == (partial.t.size, 2)
    np.testing.assert_allclose(partial.x[:50, 1], 1.0 / (1.0 - partial.t[:50]), rtol=1e-2)


def nan_after_half_second(t, x):
    return np.array([1.0, np.nan if t > 0.5 else 0.0, 0.0])


def test_nan_names_the_state_index():
    with pytest.raises(SimulationDiverged) as caught:
        integrate(nan_after_half_second, (0.0, 1.0), [0.0, 0.0, 0.0],
                  options=options(Method.MODIFIED_EULER))
    assert "index 1" in str(caught.value) and "not finite" in str(caught.value)
    partial = caught.value.partial
    assert abs(partial.t[-1] - 0.5) < 2e-3 and np.all(np.isfinite(partial.x))


def test_nan_in_adaptive_solver_names_the_state():
    with pytest.raises(SimulationDiverged) as caught:
        integrate(nan_after_half_second, (0.0, 1.0), [0.0, 0.0, 0.0],
                  options=options(Method.RK45), state_names=("a", "b", "c"))
    assert "'b' (index 1)" in str(caught.value)
    assert caught.value.partial.t[-1] <= 0.5 + 1e-9


def test_divergence_limit_is_configurable():
    result = integrate(blow_up, (0.0, 0.9), [0.0, 1.0], options=options(Method.RK4))
    assert result.status is Status.COMPLETED  # x = 10 at t = 0.9
    with pytest.raises(SimulationDiverged, match="limit 5"):
        integrate(blow_up, (0.0, 0.9), [0.0, 1.0], options=options(Method.RK4),
                  divergence_limit=5.0)


# --- options and inputs ---------------------------------------------------------------

def test_method_parse():
    assert Method.parse("modified_euler", field="f") is Method.MODIFIED_EULER
    assert Method.parse(" RK4 ", field="f") is Method.RK4
    assert Method.parse(Method.BDF, field="f") is Method.BDF
    with pytest.raises(InputError, match=r"simulate\.method.*'heun'.*modified_euler.*lsoda"):
        Method.parse("heun", field="simulate.method")
    assert [m.fixed_step for m in Method] == [True, True, True, False, False, False, False,
                                                   False]


@pytest.mark.parametrize("field, value", [
    ("step", 0.0), ("step", 0.5), ("step", 1e-7), ("step", "1e-3"), ("iterations", 0),
    ("iterations", 101), ("iterations", 2.5), ("iterations", True), ("rtol", 0.0),
    ("atol", -1.0), ("max_step", 0.0), ("method", "rk4")])
def test_option_validation_names_the_field(field, value):
    with pytest.raises(InputError, match=f"'{field}'"):
        IntegratorOptions(**{field: value})


def _integrator_table(tmp_path, text):
    from predgait.problemfile import load_problem

    path = tmp_path / "p.toml"
    path.write_text("[integrator]\n" + text)
    return load_problem(path).table("integrator")


def test_options_from_table(tmp_path):
    """The one [integrator] parser: values, defaults, allowed keys, errors with key and line."""
    opts = IntegratorOptions.from_table(_integrator_table(
        tmp_path, 'method = "modified_euler"\nstep = 5e-4\niterations = 15\n'))
    assert opts == IntegratorOptions(Method.MODIFIED_EULER, 5e-4, 15)
    default = IntegratorOptions(method=Method.RK4, step=2e-3)
    assert IntegratorOptions.from_table(_integrator_table(tmp_path, ""), default=default) \
        == default
    with pytest.raises(InputError, match=r"iteration.*line 2"):
        IntegratorOptions.from_table(_integrator_table(tmp_path, "iteration = 3\n"))
    with pytest.raises(InputError, match=r"'step'.*line 2|line 2.*'step'"):
        IntegratorOptions.from_table(_integrator_table(tmp_path, "step = 1.0\n"))
    with pytest.raises(InputError, match="method"):
        IntegratorOptions.from_table(_integrator_table(tmp_path, 'method = "euler2"\n'))
    with pytest.raises(InputError, match="rtol"):
        IntegratorOptions.from_table(_integrator_table(tmp_path, "rtol = 1e-3\n"),
                                     keys=("method", "step"))


@pytest.mark.parametrize("kwargs, match", [
    ({"t_span": (1.0, 0.0)}, "t_span"),
    ({"x0": [np.nan, 0.0]}, "index 0"),
    ({"t_eval": [0.0, 2.0]}, "t_eval"),
    ({"t_eval": [0.5, 0.2]}, "t_eval"),
    ({"state_names": ("a",)}, "state_names"),
    ({"events": [lambda t, x: x[0]]}, "Event")])
def test_bad_inputs(kwargs, match):
    args = {"t_span": (0.0, 1.0), "x0": [1.0, 0.0]} | kwargs
    with pytest.raises(InputError, match=match):
        integrate(oscillator, args.pop("t_span"), args.pop("x0"), **args)


def test_event_direction_validated():
    with pytest.raises(InputError, match="direction"):
        Event("x", lambda t, x: x[0], 2)
    assert Event("x", lambda t, x: x[0], -1).direction is Direction.FALLING


def test_cvodes_grid_solver_rows_events_and_fallback(caplog):
    """x' = -x: rows from a grid solver (the exact solution), the event x = 0.5 at ln 2
    located on the output grid's Hermite interpolant; without a solver, or when it
    fails, RK45 at the same tolerances with a warning."""
    def exact(grid, x0):
        X = x0[None, :] * np.exp(-(grid - grid[0]))[:, None]
        return X, -X, 7

    options = IntegratorOptions(method=Method.CVODES, step=0.01, rtol=1e-8, atol=1e-10)
    half = Event("half", lambda t, x: x[0] - 0.5, Direction.FALLING)
    run = integrate(lambda t, x: -x, (0.0, 2.0), [1.0], options=options, events=[half],
                    grid_solver=exact)
    assert run.status == "event" and run.method is Method.CVODES
    assert run.n_rhs_evaluations == 7 and abs(run.event_time - np.log(2.0)) < 1e-8
    assert np.allclose(run.t[:-1], 0.01 * np.arange(len(run.t) - 1))
    t_eval = np.array([0.25, 0.5])
    run = integrate(lambda t, x: -x, (0.0, 1.0), [1.0], options=options, t_eval=t_eval,
                    grid_solver=exact)
    np.testing.assert_allclose(run.x[:, 0], np.exp(-t_eval), rtol=1e-14)

    def failing(grid, x0):
        raise GridSolverFailed('CVode returned "CV_TOO_MUCH_WORK"')

    for solver in (None, failing):
        caplog.clear()
        with caplog.at_level("WARNING"):
            run = integrate(lambda t, x: -x, (0.0, 1.0), [1.0], options=options,
                            grid_solver=solver)
        assert run.method is Method.RK45 and "running rk45 instead" in caplog.text
        assert abs(run.x[-1, 0] - np.exp(-1.0)) < 1e-7
