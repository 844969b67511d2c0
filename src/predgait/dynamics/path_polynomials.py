"""Smooth muscle-tendon lengths for the optimiser: polynomials of the spanned coordinates.

Falisse A, Serrancoli G, Dembia CL, Gillis J, De Groote F (2019) Algorithmic differentiation
improves the computational efficiency of OpenSim-based trajectory optimization of human
movement. PLOS ONE 14:e0217730: each muscle-tendon length is a polynomial of the coordinates
the muscle spans, fitted by least squares to the exact geometry sampled over the range of
motion, its moment arms being the polynomial's derivatives (-dl/dq). Lengths and moment arms are
fitted together (one least-squares system, both in m); the degree is the
lowest, per muscle, that meets the error goals on the samples (else the best up to the
maximum). Coordinates are scaled to [-1, 1] over their fitting range for conditioning.

A ConditionalPathPoint makes the exact moment arm jump where it switches; a smooth
polynomial then runs between the two sides (its error there is what the fit reports).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from predgait.dynamics.muscle_curves import lib

#: Fit goals on the samples, m: max length error and max moment-arm error.
LENGTH_GOAL = 0.1e-3
ARM_GOAL = 0.4e-3
#: Every HOLD_OUT-th sample validates the degree instead of entering the fit.
HOLD_OUT = 4
#: Highest total degree tried, by number of spanned coordinates (more: the last).
MAX_DEGREE = (20, 20, 10)


def exponents(n_variables: int, degree: int) -> np.ndarray:
    """(n_terms, n_variables) degrees of all products of total degree <= ``degree``."""
    rows = [e for e in itertools.product(range(degree + 1), repeat=n_variables)
            if sum(e) <= degree]
    return np.array(sorted(rows, key=lambda e: (sum(e), tuple(-x for x in e))), dtype=int)


@dataclass(frozen=True)
class PathPolynomial:
    """l(q) = sum_k c_k prod_j T_e_kj(x_j), x_j = (q_j - centre_j) / half_range_j.

    T_n are Chebyshev polynomials of the first kind (T_0 = 1, T_1 = x,
    T_n+1 = 2 x T_n - T_n-1): the same polynomials as monomials, better conditioned.

    Attributes:
        muscle: Muscle name.
        columns: Columns of the spanned coordinates in the coordinate vector.
        centre: Centre of each spanned coordinate's fitting range (rad or m).
        half_range: Half-width of each fitting range (rad or m).
        powers: (n_terms, n_spanned) Chebyshev degrees.
        coefficients: (n_terms,) m.
        length_error: Max |l - exact| on all the samples, m.
        arm_error: Max |moment arm - exact| on all the samples, m.
        agrees: (n_spanned, 2) ranges where the exact data followed OpenSim's switching
            conditional points (None: the whole fitting range); see
            :func:`predgait.dynamics.muscle_paths.branch_ranges`.
    """

    muscle: str
    columns: tuple[int, ...]
    centre: tuple[float, ...]
    half_range: tuple[float, ...]
    powers: tuple[tuple[int, ...], ...]
    coefficients: tuple[float, ...]
    length_error: float = 0.0
    arm_error: float = 0.0
    agrees: tuple[tuple[float, float], ...] | None = None

    @property
    def opensim_ranges(self) -> np.ndarray:
        """(n_spanned, 2): where the polynomial approximates OpenSim's own path."""
        return self.ranges if self.agrees is None else np.array(self.agrees, float)

    @property
    def degree(self) -> int:
        """Total degree."""
        return max(sum(p) for p in self.powers)

    @property
    def ranges(self) -> np.ndarray:
        """(n_spanned, 2) fitting range of each spanned coordinate: where the fit holds."""
        c, h = np.array(self.centre), np.array(self.half_range)
        return np.stack([c - h, c + h], axis=1)

    def _tables(self, q):
        x = [(q[c] - m) / s for c, m, s in zip(self.columns, self.centre, self.half_range,
                                                 strict=True)]
        return [_chebyshev(xj, self.degree) for xj in x]

    def length(self, q):
        """Length, m, at ``q`` ((n_coordinates,) or (n_coordinates, N) numpy, or CasADi)."""
        tables = self._tables(q)
        return _combine(self.coefficients, self.powers, [t[0] for t in tables])

    def derivatives(self, q) -> list:
        """dl/dq of each spanned coordinate (list in :attr:`columns` order), m/rad or m/m."""
        tables = self._tables(q)
        out = []
        for j, s in enumerate(self.half_range):
            factors = [t[1] if i == j else t[0] for i, t in enumerate(tables)]
            out.append(_combine(self.coefficients, self.powers, factors) / s)
        return out


def _chebyshev(x, degree: int):
    """([T_0..T_degree](x), [T_0'..T_degree'](x)) by the recurrences (numpy or CasADi)."""
    t, d = [1.0 + 0.0 * x, x], [0.0 * x, 1.0 + 0.0 * x]
    for n in range(1, degree):
        t.append(2.0 * x * t[n] - t[n - 1])
        d.append(2.0 * t[n] + 2.0 * x * d[n] - d[n - 1])
    return t[:degree + 1], d[:degree + 1]


def _combine(coefficients, powers, factors):
    """sum_k c_k prod_j factors[j][powers[k][j]]."""
    total = 0.0
    for c, e in zip(coefficients, powers, strict=True):
        term = c
        for j, k in enumerate(e):
            term = term * factors[j][k]
        total = total + term
    return total


def _design(x: np.ndarray, powers: np.ndarray, half_range: np.ndarray):
    """Basis values (N, T) and their derivatives by each coordinate (k, N, T)."""
    degree = int(powers.max())
    tables = [np.array(_chebyshev(x[:, j], degree)) for j in range(x.shape[1])]
    values = np.ones((len(x), len(powers)))
    for j, (t, _) in enumerate(tables):
        values *= t[powers[:, j]].T
    derivs = np.ones((x.shape[1],) + values.shape)
    for i in range(x.shape[1]):
        for j, (t, d) in enumerate(tables):
            derivs[i] *= (d if i == j else t)[powers[:, j]].T
        derivs[i] /= half_range[i]
    return values, derivs


def fit(muscle: str, columns: tuple[int, ...], ranges: np.ndarray, samples: np.ndarray,
        lengths: np.ndarray, arms: np.ndarray, *, length_goal: float = LENGTH_GOAL,
        arm_goal: float = ARM_GOAL, max_degree: int | None = None,
        agrees=None) -> PathPolynomial:
    """Fit one muscle's polynomial to exact lengths and moment arms.

    One least-squares system for all degrees: the normal equations of the highest degree,
    of which each lower degree solves the leading block (the basis is ordered by degree).
    The degree is chosen on held-out samples (every :data:`HOLD_OUT`-th), so that a high
    degree fitting the samples but waving between them is not taken; the polynomial of that
    degree is then fitted to all samples.

    Args:
        muscle: Name.
        columns: Columns of the spanned coordinates.
        ranges: (n_spanned, 2) fitting range of each.
        samples: (N, n_spanned) coordinate values inside the ranges.
        lengths: (N,) exact lengths, m.
        arms: (N, n_spanned) exact moment arms -dl/dq, m.
        length_goal: Goal of the max length error, m.
        arm_goal: Goal of the max moment-arm error, m.
        max_degree: Highest degree tried (default :data:`MAX_DEGREE`).
        agrees: Stored as :attr:`PathPolynomial.agrees` ((n_spanned, 2) or None).

    Returns:
        The polynomial of the lowest degree meeting both goals on the held-out samples,
        else of the degree whose larger error ratio to its goal is smallest there.
    """
    k = len(columns)
    max_degree = max_degree or MAX_DEGREE[min(k, len(MAX_DEGREE)) - 1]
    centre = ranges.mean(axis=1)
    half = (ranges[:, 1] - ranges[:, 0]) / 2.0
    powers = exponents(k, max_degree)
    values, derivs = _design((samples - centre) / half, powers, half)
    a = np.vstack([values, *(-d for d in derivs)])
    b = np.concatenate([lengths, *arms.T])
    held = np.arange(len(samples)) % HOLD_OUT == 0           # validation samples
    rows = np.tile(~held, k + 1)
    gram, rhs = a[rows].T @ a[rows], a[rows].T @ b[rows]
    chosen, best_score = max_degree, np.inf
    for degree in range(1, max_degree + 1):
        n = int(np.sum(powers.sum(axis=1) <= degree))
        coef = np.linalg.lstsq(gram[:n, :n], rhs[:n], rcond=None)[0]
        errors = _errors(values[held], derivs[:, held], lengths[held], arms[held], coef, n)
        score = max(errors[0] / length_goal, errors[1] / arm_goal)
        if score < best_score:
            chosen, best_score = degree, score
        if score <= 1.0:
            break
    n = int(np.sum(powers.sum(axis=1) <= chosen))
    coef = np.linalg.lstsq((a.T @ a)[:n, :n], (a.T @ b)[:n], rcond=None)[0]
    length_error, arm_error = _errors(values, derivs, lengths, arms, coef, n)
    return PathPolynomial(muscle, tuple(columns), tuple(centre), tuple(half),
                          tuple(tuple(int(v) for v in row) for row in powers[:n]),
                          tuple(float(v) for v in coef), length_error, arm_error,
                          None if agrees is None else tuple(map(tuple, agrees)))


def _errors(values, derivs, lengths, arms, coef, n) -> tuple[float, float]:
    """Max length and moment-arm errors, m, of the first ``n`` basis terms."""
    length_error = float(np.abs(values[:, :n] @ coef - lengths).max())
    arm_error = float(max(np.abs(-d[:, :n] @ coef - arms[:, j]).max()
                          for j, d in enumerate(derivs)))
    return length_error, arm_error


@dataclass(frozen=True)
class SmoothPaths:
    """Smooth lengths and moment arms of all muscles, numpy or CasADi.

    Attributes:
        coordinate_names: Order of the coordinate vector ``q`` the functions take.
        muscle_names: Order of the rows.
        polynomials: One :class:`PathPolynomial` per muscle.
    """

    coordinate_names: tuple[str, ...]
    muscle_names: tuple[str, ...]
    polynomials: tuple[PathPolynomial, ...]

    def lengths(self, q):
        """Muscle-tendon lengths, m: (n_muscles,) or (n_muscles, N) numpy, or a CasADi column.

        Args:
            q: Coordinates in :attr:`coordinate_names` order: (n,) or (n, N) numpy, or a
                CasADi column (n, 1).
        """
        values = [p.length(q) for p in self.polynomials]
        if lib(*values) is np:
            shape = np.broadcast_shapes(*[np.shape(v) for v in values])
            return np.stack([np.broadcast_to(v, shape) for v in values])
        return lib(*values).vertcat(*values)

    def moment_arms(self, q):
        """Moment arms -dl/dq, m: (n_muscles, n_coordinates[, N]) numpy or CasADi matrix."""
        n = len(self.coordinate_names)
        rows = []
        for p in self.polynomials:
            row = [0.0] * n
            for c, d in zip(p.columns, p.derivatives(q), strict=True):
                row[c] = -d
            rows.append(row)
        flat = [v for row in rows for v in row]
        m = lib(*flat)
        if m is np:
            shape = np.broadcast_shapes(*[np.shape(v) for v in flat])
            return np.array([[np.broadcast_to(v, shape) for v in row] for row in rows])
        return m.vertcat(*[m.horzcat(*row) for row in rows])

    def lengthening_speeds(self, q, v):
        """Lengthening speeds -R(q) v = dl/dt, m/s (v: coordinate rates, same order as q)."""
        arms = self.moment_arms(q)
        if lib(arms, v) is np:
            return -np.einsum("mc...,c...->m...", arms, np.asarray(v, float))
        return -(arms @ v)

    def casadi_functions(self):
        """CasADi ``lengths(q) -> (n_muscles,)`` and ``moment_arms(q) -> (n_muscles, n)``."""
        import casadi

        q = casadi.SX.sym("q", len(self.coordinate_names))
        return (casadi.Function("muscle_lengths", [q], [self.lengths(q)], ["q"], ["l"]),
                casadi.Function("moment_arms", [q], [self.moment_arms(q)], ["q"], ["d"]))

    def valid_ranges(self) -> dict[str, tuple[float, float]]:
        """Per spanned coordinate, where every muscle's fit approximates OpenSim's path.

        In this vector's values. Outside it (e.g. knee flexion beyond 81 deg in
        2D_gait.osim) the fits follow the branch of the path continued, not OpenSim's
        switched one (a few mm apart); beyond the model's coordinate ranges they extrapolate.
        """
        out: dict[str, tuple[float, float]] = {}
        for p in self.polynomials:
            for c, (a, b) in zip(p.columns, p.opensim_ranges, strict=True):
                lo, hi = min(a, b), max(a, b)
                name = self.coordinate_names[c]
                old = out.get(name, (-np.inf, np.inf))
                out[name] = (max(old[0], lo), min(old[1], hi))
        return out

    def reordered(self, names, signs=None) -> SmoothPaths:
        """The same functions of another coordinate vector.

        Args:
            names: Coordinate names of the new vector (every spanned one must be there).
            signs: New value = sign * OpenSim value, per entry of ``names`` (default +1;
                the planar base pitch of :mod:`predgait.models.osim_model` is -1).
        """
        names = tuple(names)
        signs = np.ones(len(names)) if signs is None else np.asarray(signs, float)
        polynomials = []
        for p in self.polynomials:
            spanned = [self.coordinate_names[c] for c in p.columns]
            missing = [n for n in spanned if n not in names]
            if missing:
                from predgait.errors import InputError

                raise InputError(f"muscle {p.muscle!r} spans {', '.join(missing)}, which the "
                                 f"coordinates {', '.join(names)} do not include.")
            columns = tuple(names.index(n) for n in spanned)
            sign = signs[list(columns)]
            # x = (s q' - c) / h = (q' - s c) / (s h) for q' = s q.
            agrees = None if p.agrees is None else tuple(
                tuple(sorted(s * np.array(r))) for s, r in zip(sign, p.agrees, strict=True))
            polynomials.append(PathPolynomial(
                p.muscle, columns, tuple(sign * np.array(p.centre)),
                tuple(sign * np.array(p.half_range)), p.powers, p.coefficients,
                p.length_error, p.arm_error, agrees))
        return SmoothPaths(names, self.muscle_names, tuple(polynomials))
