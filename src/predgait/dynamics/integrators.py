"""Integrators of first-order systems x' = f(t, x) behind one interface.

Fixed-step methods run in a tight Python loop here (the thesis' modified Euler method
with a chosen number of iterations, explicit Euler, classical RK4); adaptive and stiff
methods (RK45, Radau, BDF, LSODA) step SciPy's ``OdeSolver`` classes, the engines of
``scipy.integrate.solve_ivp``. Stepping them here rather than through ``solve_ivp``
keeps every method on the same footing: the same divergence check after each step
(with the partial result kept), the same terminal events, a progress bar by time.
CVODES (SUNDIALS' variable-order BDF, through CasADi) runs a whole system written in
CasADi at once (a ``grid_solver``, e.g. :mod:`predgait.dynamics.cvodes_leg`) and returns
the states on the output grid only: divergence and events are then checked on that grid
(events located on the cubic Hermite interpolant between output rows, not root-found by
CVODES), and a system without one runs on SciPy's RK45 at the same tolerances.

Modified Euler (thesis 3.2.4, 3.3.4 Fig. 3.3.7, 4.2 Figs. 4.2.4-4.2.5; Wylie and Barrett
1982): with ``iterations = k`` each step makes k evaluations of f: one at the start of
the step, then k - 1 corrector passes::

    x_{n+1}^(1)   = x_n + h f(t_n, x_n)                                  (predictor)
    x_{n+1}^(j+1) = x_n + h/2 [f(t_n, x_n) + f(t_{n+1}, x_{n+1}^(j))]   (corrector)

so k = 1 is explicit Euler, k = 2 Heun's method (the thesis' "two step Modified
Euler"), and k -> infinity the fixed point of the trapezoidal rule (both order 2; the
thesis found 10 iterations and h = 1 ms safe for most simulations).

The state is generic; for a mechanical system x = [q, v]. ``rhs(t, x)`` must return a
new (nx,) float array each call, not a buffer it overwrites later (Pinocchio's ``aba``
returns ``data.ddq``, which the next call overwrites: copy it or concatenate it).
"""

from __future__ import annotations

import enum
import logging
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from predgait.dynamics.roots import brentq
from predgait.errors import InputError, SimulationDiverged

Rhs = Callable[[float, np.ndarray], np.ndarray]
#: (grid (n+1,), x0 (nx,)) -> (X (n+1, nx), F (n+1, nx)): a whole fixed-step run at once.
Stepper = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]
#: (grid (n+1,), x0 (nx,)) -> (X (n+1, nx), F (n+1, nx), n_rhs): a whole adaptive run
#: reported on the grid; raises :class:`GridSolverFailed` when the solver stops.
GridSolver = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray, int]]
log = logging.getLogger(__name__)


class GridSolverFailed(RuntimeError):
    """A grid solver stopped before the end (its message says why)."""


class Method(enum.Enum):
    """Integration method; values are the strings used in TOML problem files."""

    EULER = "euler"
    MODIFIED_EULER = "modified_euler"
    RK4 = "rk4"
    RK45 = "rk45"
    RADAU = "radau"
    BDF = "bdf"
    LSODA = "lsoda"
    CVODES = "cvodes"

    @property
    def fixed_step(self) -> bool:
        """True for the methods stepped here with a constant step."""
        return self in (Method.EULER, Method.MODIFIED_EULER, Method.RK4)

    @classmethod
    def parse(cls, text: str | Method, *, field: str = "method") -> Method:
        """The member named by ``text`` (case-insensitive), else InputError naming ``field``."""
        if isinstance(text, cls):
            return text
        if isinstance(text, str):
            for member in cls:
                if member.value == text.strip().lower():
                    return member
        valid = ", ".join(member.value for member in cls)
        raise InputError(f"{field}: {text!r} is not an integration method; use one of: {valid}.")


class Status(enum.StrEnum):
    """How an integration (and a simulation) ended; compares equal to its value."""

    COMPLETED = "completed"
    EVENT = "event"
    DIVERGED = "diverged"


class Direction(enum.IntEnum):
    """Which sign change of an event function g triggers the event."""

    RISING = 1
    FALLING = -1
    EITHER = 0


#: Keys of a problem file's [integrator] table.
OPTION_KEYS = ("method", "step", "iterations", "rtol", "atol", "max_step")


@dataclass(frozen=True)
class IntegratorOptions:
    """Options of :func:`integrate`.

    Attributes:
        method: Integration method.
        step: Step of fixed-step methods and output grid of adaptive ones, s (1e-6..0.1);
            for CVODES also the grid on which divergence and events are checked.
        iterations: Modified Euler only: evaluations of f per step (1..100): 1 = explicit
            Euler, 2 = Heun (predictor + one corrector), k = predictor + k - 1 correctors.
        rtol: Relative tolerance of adaptive methods.
        atol: Absolute tolerance of adaptive methods (state units).
        max_step: Largest step of adaptive methods, s; None for no limit.
    """

    method: Method = Method.RK4
    step: float = 1e-3
    iterations: int = 10
    rtol: float = 1e-6
    atol: float = 1e-8
    max_step: float | None = None

    def __post_init__(self):
        if not isinstance(self.method, Method):
            raise InputError(f"integrator option 'method': {self.method!r} is not a Method; "
                             "convert strings with Method.parse().")
        _check_number("step", self.step, 1e-6, 0.1, " s")
        if isinstance(self.iterations, bool) or not isinstance(self.iterations, int | np.integer):
            raise InputError(f"integrator option 'iterations': {self.iterations!r} is not an "
                             "integer; give a whole number from 1 to 100.")
        _check_number("iterations", self.iterations, 1, 100, "")
        _check_number("rtol", self.rtol, 1e-14, 0.1, "")
        _check_number("atol", self.atol, 1e-16, 1e3, "")
        if self.max_step is not None:
            _check_number("max_step", self.max_step, 1e-9, math.inf, " s")

    @classmethod
    def from_table(cls, table, *, default: IntegratorOptions | None = None,
                   keys: Sequence[str] = OPTION_KEYS) -> IntegratorOptions:
        """Options from a problem file's ``[integrator]`` table: THE integrator parser.

        Args:
            table: A :class:`predgait.problemfile.Table` (e.g. ``problem.table("integrator")``).
            default: Values of the keys the table leaves out (default: the class defaults).
            keys: The keys this kind of problem accepts (others are refused).

        Raises:
            InputError: Naming the file, key and line: unknown key, wrong type, or a value
                outside the bounds checked by the options themselves.
        """
        table.check_keys(tuple(keys))
        values = {}
        if table.has("method"):
            values["method"] = table.choice("method", Method)
        for key in ("step", "rtol", "atol", "max_step"):
            if table.has(key):
                values[key] = table.number(key)
        if table.has("iterations"):
            values["iterations"] = table.get("iterations", int)
        try:
            return replace(default or cls(), **values)
        except InputError as exc:
            bad = next((k for k in values if f"'{k}'" in str(exc)), next(iter(values), "method"))
            raise table.error(bad, str(exc)) from None


def _check_number(name, value, low, high, unit):
    if isinstance(value, bool) or not isinstance(value, int | float | np.number):
        raise InputError(f"integrator option {name!r}: {value!r} is not a number.")
    if not (low <= value <= high):
        raise InputError(f"integrator option {name!r} = {value:g}{unit} is outside "
                         f"{low:g}..{high:g}{unit}.")


@dataclass(frozen=True)
class Event:
    """A terminal event: integration stops where ``function(t, x)`` changes sign.

    Attributes:
        name: Name reported in :attr:`Integration.event_name` (e.g. "fall").
        function: g(t, x) -> float, t in s, x (nx,).
        direction: Sign change that triggers (RISING: - to +, FALLING: + to -).
    """

    name: str
    function: Callable[[float, np.ndarray], float]
    direction: Direction = Direction.EITHER

    def __post_init__(self):
        try:
            object.__setattr__(self, "direction", Direction(self.direction))
        except ValueError:
            raise InputError(f"event {self.name!r}: direction {self.direction!r} is not "
                             "one of RISING (1), FALLING (-1), EITHER (0).") from None

    @classmethod
    def state_crosses(cls, name: str, index: int, limit: float, *,
                      direction: Direction = Direction.RISING, absolute: bool = False) -> Event:
        """Event when x[index] (|x[index]| if ``absolute``) crosses ``limit``.

        For a fall: a segment angle passing +-60 deg (``absolute=True``, limit in rad),
        or the hip height dropping below a limit (``direction=Direction.FALLING``, m).
        """
        if absolute:
            return cls(name, lambda t, x: abs(x[index]) - limit, direction)
        return cls(name, lambda t, x: x[index] - limit, direction)


FallEvent = Event


@dataclass(frozen=True, eq=False)
class Integration:
    """Result of :func:`integrate`.

    Attributes:
        t: (n,) output times, s. The last row is the event point when status is EVENT
            and the last finite state when status is DIVERGED.
        x: (n, nx) states at ``t``.
        method: Method used.
        status: COMPLETED, EVENT or DIVERGED.
        event_name: Name of the event that stopped the run, or None.
        event_time: Its time, s, or None.
        n_rhs_evaluations: Calls of ``rhs`` (including finite-difference Jacobians).
        message: One line saying how the run ended.
    """

    t: np.ndarray
    x: np.ndarray
    method: Method
    status: Status
    event_name: str | None
    event_time: float | None
    n_rhs_evaluations: int
    message: str


def integrate(rhs: Rhs, t_span: tuple[float, float], x0, *,
              options: IntegratorOptions | None = None, t_eval=None,
              events: Sequence[Event] = (), progress: bool = False,
              divergence_limit: float = 1e6,
              state_names: Sequence[str] | None = None,
              stepper: Stepper | None = None,
              grid_solver: GridSolver | None = None) -> Integration:
    """Integrate x' = rhs(t, x) from ``t_span[0]`` to ``t_span[1]``.

    Fixed-step methods return every step (a shorter last step ends exactly at t_end);
    adaptive ones return the grid t0, t0 + step, ..., t_end. With ``t_eval`` both return
    those times instead (cubic Hermite interpolation between fixed steps, SciPy's dense
    output for adaptive methods). Events: a sign change of g over a step is located with
    Brent's method on the step's interpolant (cubic Hermite from the end states and
    slopes for fixed steps, O(h^4), rather than linear interpolation of g, O(h^2);
    SciPy's dense output for adaptive methods, as ``solve_ivp`` does).

    Args:
        rhs: f(t, x) -> (nx,) new array; t in s.
        t_span: (t0, t_end), s, t_end > t0.
        x0: (nx,) initial state.
        options: Integrator options (default ``IntegratorOptions()``: RK4, 1 ms).
        t_eval: Optional increasing output times within t_span, s.
        events: Terminal events; the first to trigger ends the run.
        progress: Show a tqdm progress bar (hidden when stderr is not a terminal).
        divergence_limit: A state with NaN/Inf or |x_i| above this stops the run.
        state_names: Optional (nx,) names used in messages.
        stepper: Optional ``(grid, x0) -> (X, F)`` that computes a fixed-step run of
            ``rhs`` with ``options`` on the step grid at once (every row X_i and
            F_i = rhs(t_i, X_i)), e.g. compiled (:mod:`predgait.dynamics.compiled_leg`);
            divergence, events and output are then checked on its rows as they are here
            after each step. Ignored by adaptive methods.
        grid_solver: CVODES only: ``(grid, x0) -> (X, F, n_rhs)``, the whole run on the
            output grid (t_eval with t0 and t_end added, else the ``step`` grid).
            Divergence and events are checked on those rows: an event is detected at
            output-grid resolution and located on the rows' cubic Hermite interpolant.
            Without one, or when it fails, the run is SciPy's RK45 at the same
            tolerances (a one-line warning; ``Integration.method`` says RK45).

    Returns:
        The :class:`Integration`.

    Raises:
        SimulationDiverged: A state became NaN/Inf or exceeded ``divergence_limit``, or
            the adaptive solver failed; ``.partial`` holds the Integration so far.
        InputError: Bad t_span, x0, t_eval, state_names or events.
    """
    options = IntegratorOptions() if options is None else options
    t0, t1 = (float(v) for v in t_span)
    if not (math.isfinite(t0) and math.isfinite(t1) and t1 > t0):
        raise InputError(f"t_span {tuple(t_span)!r} must be two finite times with end > start.")
    x0 = np.array(x0, dtype=float).reshape(-1)
    if not np.all(np.isfinite(x0)):
        raise InputError(f"initial state has NaN/Inf at index {int(np.argmin(np.isfinite(x0)))}.")
    names = tuple(state_names) if state_names is not None else None
    if names is not None and len(names) != x0.size:
        raise InputError(f"state_names has {len(names)} names for {x0.size} states.")
    if t_eval is not None:
        t_eval = np.asarray(t_eval, dtype=float).reshape(-1)
        if (t_eval.size == 0 or np.any(np.diff(t_eval) <= 0) or t_eval[0] < t0 - 1e-12
                or t_eval[-1] > t1 + 1e-12):
            raise InputError(f"t_eval must be increasing times within [{t0:g}, {t1:g}] s.")
    events = tuple(events)
    if not all(isinstance(event, Event) for event in events):
        raise InputError("events must be Event instances.")
    run = _Run(rhs, options, names, float(divergence_limit), t_eval, stepper)
    bar = _progress_bar(progress, options, t0, t1)
    try:
        if options.method.fixed_step:
            return _fixed_step(run, t0, t1, x0, events, bar)
        if options.method is Method.CVODES:
            if grid_solver is None:
                log.warning("cvodes needs a system written in CasADi (the leg with the "
                            "solver cache on and sampled drivers): running rk45 instead")
            else:
                try:
                    return _on_grid(run, grid_solver, t0, t1, x0, events, bar)
                except GridSolverFailed as exc:
                    log.warning("cvodes stopped (%s): running rk45 instead", exc)
            run = replace(run, options=replace(options, method=Method.RK45))
        return _adaptive(run, t0, t1, x0, events, bar)
    finally:
        if bar is not None:
            bar.close()


@dataclass(frozen=True)
class _Run:
    rhs: Rhs
    options: IntegratorOptions
    names: tuple[str, ...] | None
    limit: float
    t_eval: np.ndarray | None
    stepper: Stepper | None = None

    def name(self, index: int) -> str:
        return f"{self.names[index]!r} (index {index})" if self.names else f"index {index}"

    def result(self, t, x, status, nfev, message, event=None, event_time=None):
        return Integration(t=t, x=x, method=self.options.method, status=status,
                           event_name=event, event_time=event_time,
                           n_rhs_evaluations=nfev, message=message)

    def diverged(self, t_out, x_out, t_bad, index, what, nfev, reason=None):
        """Raise SimulationDiverged naming state ``index``; ``.partial`` ends at t_out[-1]."""
        opts = self.options
        how = (f"{opts.method.value}, step {opts.step:g} s" if opts.method.fixed_step
               else f"{opts.method.value}, rtol {opts.rtol:g}, atol {opts.atol:g}")
        if opts.method is Method.MODIFIED_EULER:
            how += f", {opts.iterations} iterations"
        cause = f"{reason}; " if reason else ""
        message = (f"simulation diverged at t = {t_bad:.6g} s ({how}): {cause}state "
                   f"{self.name(index)} {what}; the last finite state is at "
                   f"t = {t_out[-1]:.6g} s. Try a smaller step, more iterations or a stiff "
                   "method (radau, bdf), or stop earlier with a fall event.")
        partial = self.result(t_out, x_out, Status.DIVERGED, nfev, message)
        raise SimulationDiverged(message, partial=partial)


def _offender(x, limit):
    """(index, description) of the first non-finite state, else of the largest |x|."""
    bad = ~np.isfinite(x)
    if bad.any():
        index = int(np.argmax(bad))
        return index, f"= {x[index]} (not finite)"
    index = int(np.argmax(np.abs(x)))
    return index, f"= {x[index]:.4g} (|x| above the divergence limit {limit:g})"


def _n_steps(t0, t1, step):
    return max(1, math.ceil((t1 - t0) / step - 1e-9))


def _progress_bar(progress, options, t0, t1):
    """A tqdm bar in steps (fixed-step) or simulated seconds (adaptive), or None."""
    if not progress:
        return None
    from tqdm import tqdm

    method = options.method
    if method.fixed_step:
        total, unit = _n_steps(t0, t1, options.step), "step"
    else:
        total, unit = t1 - t0, "s"
    return tqdm(total=total, unit=unit, desc=f"integrating ({method.value})", disable=None,
                leave=False)


def _is_bad(x, limit):
    return not bool(np.all(np.isfinite(x))) or bool(np.any(np.abs(x) > limit))


def _fixed_step(run, t0, t1, x0, events, bar):
    """Euler, modified Euler and RK4 on a constant step, loop kept lean."""
    rhs, opts, limit = run.rhs, run.options, run.limit
    n = _n_steps(t0, t1, opts.step)
    grid = t0 + opts.step * np.arange(n + 1.0)
    grid[-1] = t1
    times = grid.tolist()
    kind = 2 if opts.method is Method.RK4 else (
        1 if opts.method is Method.MODIFIED_EULER and opts.iterations > 1 else 0)
    correctors = range(opts.iterations - 1)
    per_step = 4 if kind == 2 else (opts.iterations if kind == 1 else 1)
    if run.stepper is not None:
        X, F = run.stepper(grid, x0)
        return _checked_rows(run, grid, X, F, events, bar, lambda i: 1 + i * per_step)
    f = np.array(rhs(t0, x0), dtype=float)
    if f.shape != x0.shape:
        raise ValueError(f"rhs returned shape {f.shape}, expected {x0.shape}.")
    X = np.empty((n + 1, x0.size))
    F = np.empty((n + 1, x0.size))
    X[0], F[0] = x0, f
    lim2 = limit * limit
    g_prev = [event.function(t0, x0) for event in events]
    stride = max(1, n // 100)
    x, t = x0, t0
    for i in range(n):
        tn = times[i + 1]
        h = tn - t
        if kind == 1:
            h2 = 0.5 * h
            base = x + h2 * f
            xp = x + h * f
            for _ in correctors:
                xp = base + h2 * rhs(tn, xp)
            x = xp
        elif kind == 0:
            x = x + h * f
        else:
            h2 = 0.5 * h
            tm = t + h2
            k2 = rhs(tm, x + h2 * f)
            k3 = rhs(tm, x + h2 * k2)
            k4 = rhs(tn, x + h * k3)
            x = x + (h / 6.0) * (f + k4 + 2.0 * (k2 + k3))
        X[i + 1] = x
        if not x.dot(x) <= lim2 and _is_bad(x, limit):
            t_out, x_out = _output(grid[: i + 1], X[: i + 1], F[: i + 1], run.t_eval,
                                   end=t, x_end=X[i])
            run.diverged(t_out, x_out, tn, *_offender(x, limit), i * per_step + per_step)
        f = rhs(tn, x)
        F[i + 1] = f
        t = tn
        if events:
            ended = _step_event(run, events, g_prev, times, X, F, i, 1 + (i + 1) * per_step)
            if ended is not None:
                return ended
        if bar is not None and (i % stride == 0 or i == n - 1):
            bar.n = i + 1
            bar.refresh()
    t_out, x_out = _output(grid, X, F, run.t_eval)
    return run.result(t_out, x_out, Status.COMPLETED, 1 + n * per_step,
                      f"completed {n} steps to t = {t1:g} s")


def _step_event(run, events, g_prev, times, X, F, i, nfev):
    """The EVENT result if an event triggers over step i, else None.

    Rows i and i + 1 of X and F are done; the event is located on the step's cubic
    Hermite interpolant. ``nfev``: right-hand sides reported with the result.
    """
    ta, tn = times[i], times[i + 1]

    def dense(s):
        return _hermite(ta, tn, X[i], F[i], X[i + 1], F[i + 1], s)

    hit = _event_hit(events, g_prev, ta, tn, X[i + 1], dense)
    if hit is None:
        return None
    name, t_ev = hit
    grid = np.asarray(times[: i + 2])
    t_out, x_out = _output(grid, X[: i + 2], F[: i + 2], run.t_eval, end=t_ev,
                           x_end=dense(t_ev))
    return run.result(t_out, x_out, Status.EVENT, nfev,
                      f"event {name!r} at t = {t_ev:.6g} s", name, t_ev)


def _on_grid(run, grid_solver, t0, t1, x0, events, bar):
    """CVODES through ``grid_solver``: the rows on the output grid, then the checks."""
    if run.t_eval is None:
        grid = t0 + run.options.step * np.arange(_n_steps(t0, t1, run.options.step) + 1.0)
        grid[-1] = t1
    else:
        inner = run.t_eval[(run.t_eval > t0) & (run.t_eval < t1)]
        grid = np.concatenate([[t0], inner, [t1]])
    X, F, nfev = grid_solver(grid, x0)
    return _checked_rows(run, grid, X, F, events, bar, lambda i: nfev,
                         f"output steps of cvodes ({nfev} right-hand sides)")


def _checked_rows(run, grid, X, F, events, bar, count, steps="steps"):
    """:func:`_fixed_step`'s checks on precomputed rows X, F on ``grid``, in order.

    ``count(i)``: right-hand sides spent up to row i (reported with the result);
    ``steps``: what the rows are, for the message.
    """
    x0 = X[0]
    n, t1 = len(grid) - 1, float(grid[-1])
    bad = ~np.all(np.isfinite(X), axis=1) | np.any(np.abs(X) > run.limit, axis=1)
    first_bad = int(np.argmax(bad)) if bad.any() else n + 1
    g_prev = [event.function(grid[0], x0) for event in events]
    times = grid.tolist()
    for i in range(min(n, first_bad - 1) if events else 0):
        ended = _step_event(run, events, g_prev, times, X, F, i, count(i + 1))
        if ended is not None:
            return ended
    if first_bad <= n:
        i = first_bad - 1
        t_out, x_out = _output(grid[: i + 1], X[: i + 1], F[: i + 1], run.t_eval,
                               end=times[i], x_end=X[i])
        run.diverged(t_out, x_out, times[i + 1], *_offender(X[i + 1], run.limit),
                     count(i + 1))
    if bar is not None:
        bar.n = n
        bar.refresh()
    t_out, x_out = _output(grid, X, F, run.t_eval)
    return run.result(t_out, x_out, Status.COMPLETED, count(n),
                      f"completed {n} {steps} to t = {t1:g} s")


def _hermite(ta, tb, xa, fa, xb, fb, t):
    """Cubic Hermite interpolant on [ta, tb] at t: scalars -> (nx,), (m,) rows -> (m, nx)."""
    ta = np.asarray(ta, dtype=float)[..., None]
    h = np.asarray(tb, dtype=float)[..., None] - ta
    s = (np.asarray(t, dtype=float)[..., None] - ta) / h
    s2, s3 = s * s, s * s * s
    return ((2 * s3 - 3 * s2 + 1) * xa + (s3 - 2 * s2 + s) * h * fa
            + (3 * s2 - 2 * s3) * xb + (s3 - s2) * h * fb)


def _output(grid, X, F, t_eval, *, end=None, x_end=None):
    """Output rows: the step grid or Hermite interpolation at t_eval, up to ``end``.

    ``grid``, ``X``, ``F`` hold the computed steps (F = f(t, X) on every row). With
    ``end`` (an event or the last finite state) rows after it are dropped and the row
    (end, x_end) closes the output.
    """
    tail = end is not None
    if not tail:
        end = grid[-1]
    tol = 1e-12 * max(1.0, abs(end))
    if t_eval is None:
        keep = grid <= end + tol
        t_out, x_out = grid[keep], X[keep]
    else:
        t_out = t_eval[t_eval <= end + tol]
        if len(grid) == 1:
            x_out = np.repeat(X[:1], t_out.size, axis=0)
        else:
            j = np.clip(np.searchsorted(grid, t_out, side="right") - 1, 0, len(grid) - 2)
            x_out = _hermite(grid[j], grid[j + 1], X[j], F[j], X[j + 1], F[j + 1], t_out)
    if tail and (t_out.size == 0 or t_out[-1] < end - tol):
        return _with_last(t_out, x_out.reshape(-1, X.shape[1]), (end, x_end))
    return np.array(t_out, dtype=float), np.array(x_out, dtype=float).reshape(-1, X.shape[1])


def _event_hit(events, g_prev, t_old, t_new, x_new, interpolant):
    """Earliest event triggered over [t_old, t_new] as (name, t), or None; updates g_prev.

    The root of g(t, interpolant(t)) is found with Brent's method (as ``solve_ivp``;
    :func:`predgait.dynamics.roots.brentq`, the same iterates as SciPy's).
    """
    hit = None
    for j, event in enumerate(events):
        g_old, g_new = g_prev[j], float(event.function(t_new, x_new))
        g_prev[j] = g_new
        rising, falling = g_old < 0.0 <= g_new, g_old > 0.0 >= g_new
        if (rising and event.direction >= 0) or (falling and event.direction <= 0):
            root = t_new if g_new == 0.0 else brentq(
                lambda t, e=event: e.function(t, interpolant(t)), t_old, t_new,
                xtol=1e-14, rtol=4 * np.finfo(float).eps)
            if hit is None or root < hit[1]:
                hit = (event.name, root)
    return hit


def _adaptive(run, t0, t1, x0, events, bar):
    """RK45/Radau/BDF/LSODA through SciPy's OdeSolver steppers."""
    from scipy import integrate as spi

    opts, limit = run.options, run.limit
    solver_class = {Method.RK45: spi.RK45, Method.RADAU: spi.Radau, Method.BDF: spi.BDF,
                    Method.LSODA: spi.LSODA}[opts.method]
    count, last_call = [0], [t0, None]

    def fun(t, x):
        count[0] += 1
        last_call[:] = t, run.rhs(t, x)
        return last_call[1]

    if run.t_eval is not None:
        t_out = run.t_eval
    else:
        n = _n_steps(t0, t1, opts.step)
        t_out = np.minimum(t0 + opts.step * np.arange(n + 1.0), t1)
    x_out = np.empty((t_out.size, x0.size))
    filled = 0
    if t_out[0] <= t0:
        x_out[0], filled = x0, 1
    solver = solver_class(fun, t0, x0, t1, rtol=opts.rtol, atol=opts.atol,
                          max_step=opts.max_step or np.inf)
    g_prev = [event.function(t0, x0) for event in events]
    t_old, x_old = t0, x0
    while solver.status == "running":
        solver_message = solver.step()
        t_new, x_new = solver.t, solver.y
        if solver.status == "failed" or _is_bad(x_new, limit):
            index, what, reason = *_offender(x_new, limit), None
            if solver.status == "failed":  # name the derivative that stalled the solver
                t_f, f_f = last_call[0], np.asarray(last_call[1], dtype=float)
                if np.all(np.isfinite(f_f)):
                    t_f, f_f = t_old, np.asarray(run.rhs(t_old, x_old), dtype=float)
                index = _offender(f_f, np.inf)[0]
                what = f"has derivative {f_f[index]:.4g} at t = {t_f:.6g} s"
                reason = f"the {opts.method.value} solver failed ({solver_message})"
            last = (t_old, x_old) if filled == 0 or t_out[filled - 1] < t_old else None
            run.diverged(*_with_last(t_out[:filled], x_out[:filled], last), t_new, index, what,
                         count[0], reason)
        # the interpolant only when an event is watched or an output time is passed
        needed = events or (filled < t_out.size and t_out[filled] <= t_new)
        dense = solver.dense_output() if needed else None
        hit = _event_hit(events, g_prev, t_old, t_new, x_new, dense) if events else None
        t_stop = t_new if hit is None else hit[1]
        end = filled + int(np.searchsorted(t_out[filled:], t_stop, side="right"))
        if end > filled:
            x_out[filled:end] = dense(t_out[filled:end]).T
            filled = end
        if hit is not None:
            last = (hit[1], dense(hit[1])) if filled == 0 or t_out[filled - 1] < hit[1] else None
            return run.result(*_with_last(t_out[:filled], x_out[:filled], last), Status.EVENT,
                              count[0], f"event {hit[0]!r} at t = {hit[1]:.6g} s", *hit)
        if bar is not None:
            bar.n = t_new - t0
            bar.refresh()
        t_old, x_old = t_new, x_new
    if filled < t_out.size:  # times at t_end lost to round-off
        x_out[filled:] = x_old
    return run.result(t_out.copy(), x_out, Status.COMPLETED, count[0],
                      f"completed to t = {t1:g} s ({opts.method.value})")


def _with_last(t, x, last):
    if last is None:
        return t.copy(), x.copy()
    return np.append(t, last[0]), np.vstack([x, np.asarray(last[1])[None, :]])
