"""Exact muscle-tendon lengths of OpenSim GeometryPaths, by Pinocchio forward kinematics.

:class:`PathGeometry` reproduces OpenSim 4.6's ``GeometryPath`` length for the path points
of :mod:`predgait.models.osim` (no wrapping surfaces): the sum of the straight segments
between consecutive *active* points, where

- a ``PathPoint`` is fixed in its body;
- a ``ConditionalPathPoint`` counts only while its coordinate lies in its range widened by
  1e-5 on each side (OpenSim ``ConditionalPathPoint::isActive``);
- a ``MovingPathPoint`` sits at (f_x(q_x), f_y(q_y), f_z(q_z)) in its body, each coordinate
  clamped to its range first (OpenSim ``MovingPathPoint::getLocation``;
  :mod:`predgait.dynamics.path_functions`); the file's ``location`` is ignored, as in OpenSim.

Body poses come from Pinocchio's forward kinematics on the model built by
:mod:`predgait.models.osim_model`, whose joint values equal OpenSim's. Moment arms are
-dl/dq (OpenSim ``Muscle::computeMomentArm``): central differences with the active points
of the nominal pose and the moving points' functions unclamped (OpenSim differentiates
them through ``getdPointdQ``, which does not clamp).

The geometry is the model's as it is, errors included. OpenSim's own example2DWalking
notes that "the path of the gastroc muscle contains an error -- the path does not cross the
knee joint"; whatever that path does in the file, it does here too (in 2D_gait.osim its
points lie on femur_r and calcn_r, so it spans knee and ankle; at OpenSim's 200 reference
poses its knee moment arm runs from -26 mm (a flexor) to +6 mm in deep flexion, in OpenSim
4.6 and here alike).

For the optimiser, :func:`smooth_paths` (:func:`fit_smooth_paths`) fits each muscle a
polynomial of its spanned coordinates (:mod:`predgait.dynamics.path_polynomials`) to this
exact geometry, in ~1 s; :func:`branch_ranges` says where such a fit can follow OpenSim.

Coordinates are given as OpenSim values in :attr:`PathGeometry.coordinate_names` order
(the model file's coordinate order, OpenSim's CoordinateSet).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from predgait.dynamics import path_functions
from predgait.models.osim import Muscle, OsimModel, PointKind

#: OpenSim's tolerance on a ConditionalPathPoint range, rad or m.
CONDITIONAL_TOLERANCE = 1e-5
#: Central-difference step of the exact moment arms, rad or m.
STEP = 1e-6
#: A conditional point switching with a length jump above this cuts the fitting range, m.
JUMP_LIMIT = 1e-3
#: Poses sampled for the fit.
SAMPLES = 1500


@dataclass(frozen=True)
class _Point:
    """A path point ready to evaluate: its Pinocchio frame and link-frame position."""

    frame: int                      # column in PathGeometry's frame list
    location: np.ndarray            # (3,) link frame, m (fixed and conditional points)
    to_link: np.ndarray             # (3, 3) OpenSim body axes -> link axes
    origin: np.ndarray              # (3,) link-frame position of the body origin
    condition: tuple[int, float, float] | None = None   # (coordinate column, low, high)
    functions: tuple | None = None                     # moving: three function records
    arguments: tuple[int | None, ...] | None = None     # their coordinate columns


def spanned_coordinates(osim: OsimModel, muscle: Muscle) -> tuple[str, ...]:
    """Coordinates whose value can change a muscle's length, in the model's order.

    Those of the joints on the kinematic tree between the bodies of consecutive path
    points, plus the coordinates of conditional and moving points.
    """
    parent = {j.child.body: j for j in osim.joints}

    def chain(body: str) -> list[str]:
        bodies = [body]
        while bodies[-1] in parent:
            bodies.append(parent[bodies[-1]].parent.body)
        return bodies

    names: set[str] = set()
    points = muscle.path
    for a, b in zip(points, points[1:], strict=False):
        up_a, up_b = chain(a.body), chain(b.body)
        common = next(x for x in up_a if x in up_b)
        for side in (up_a, up_b):
            for body in side[:side.index(common)]:
                names.update(c.name for c in parent[body].coordinates)
    for p in points:
        if p.coordinate:
            names.add(p.coordinate)
        names.update(n for n in (p.function_coordinates or ()) if n)
    return tuple(c.name for c in osim.coordinates if c.name in names)


class PathGeometry:
    """Exact muscle-tendon lengths and moment arms of an OpenSim model's muscles.

    Args:
        built: The :class:`~predgait.models.osim_model.OsimPlanarModel` of the model.
    """

    def __init__(self, built):
        osim = built.osim
        self.built = built
        self.coordinate_names = tuple(c.name for c in osim.coordinates)
        self.ranges = np.array([c.range for c in osim.coordinates], float)
        self.muscle_names = tuple(m.name for m in osim.muscles)
        self.spans = tuple(spanned_coordinates(osim, m) for m in osim.muscles)
        column = {n: i for i, n in enumerate(self.coordinate_names)}
        frames: list[int] = []
        self._paths: list[list[_Point]] = []
        for muscle in osim.muscles:
            path = []
            for p in muscle.path:
                link, origin = built.point_on_body(p.body, (0.0, 0.0, 0.0))
                frame = built.model.frame_id(link)
                if frame not in frames:
                    frames.append(frame)
                point = _Point(frame=frames.index(frame),
                               location=built.point_on_body(p.body, p.location)[1],
                               to_link=built.rotation_to_link(p.body), origin=origin)
                if p.kind is PointKind.CONDITIONAL:
                    point = _replace(point, condition=(column[p.coordinate], *p.range))
                elif p.kind is PointKind.MOVING:
                    point = _replace(point, functions=p.functions, arguments=tuple(
                        column[n] if n else None for n in p.function_coordinates))
                path.append(point)
            self._paths.append(path)
        self._frames = tuple(frames)

    def columns(self, muscle: int) -> tuple[int, ...]:
        """Columns of the coordinates a muscle spans."""
        return tuple(self.coordinate_names.index(n) for n in self.spans[muscle])

    def decisions(self, muscle: int, poses: np.ndarray) -> np.ndarray:
        """(N, n_conditional) whether each ConditionalPathPoint of a muscle is active."""
        columns = [_active(p, poses) for p in self._paths[muscle] if p.condition is not None]
        return np.stack(columns, axis=1) if columns else np.zeros((len(poses), 0), bool)

    def _placements(self, values: np.ndarray):
        """Rotations (N, F, 3, 3) and positions (N, F, 3) of the path frames in the lab."""
        model = self.built.model.pin_model
        data = model.createData()
        q_all = self.built.q_from_osim(
            {n: values[:, i] for i, n in enumerate(self.coordinate_names)})
        q_all = np.atleast_2d(q_all)
        rotations = np.empty((len(values), len(self._frames), 3, 3))
        positions = np.empty((len(values), len(self._frames), 3))
        for n, q in enumerate(q_all):
            pin.framesForwardKinematics(model, data, q)
            for k, frame in enumerate(self._frames):
                placement = data.oMf[frame]
                rotations[n, k] = placement.rotation
                positions[n, k] = placement.translation
        return rotations, positions

    def _lengths(self, values, active_at=None, clamp: bool = True) -> np.ndarray:
        """(N, n_muscles) lengths at poses ``values`` (N, n_coordinates)."""
        active_at = values if active_at is None else active_at
        rotations, positions = self._placements(values)
        lengths = np.zeros((len(values), len(self._paths)))
        for m, path in enumerate(self._paths):
            last = np.zeros((len(values), 3))
            started = np.zeros(len(values), bool)
            for p in path:
                local = self._local(p, values, clamp)
                world = np.einsum("nij,nj->ni", rotations[:, p.frame], local) \
                    + positions[:, p.frame]
                active = _active(p, active_at)
                segment = np.linalg.norm(world - last, axis=1)
                lengths[:, m] += np.where(active & started, segment, 0.0)
                last = np.where(active[:, None], world, last)
                started |= active
        return lengths

    def _local(self, p: _Point, values: np.ndarray, clamp: bool) -> np.ndarray:
        """(N, 3) link-frame position of a point at every pose."""
        if p.functions is None:
            return np.broadcast_to(p.location, (len(values), 3))
        xyz = []
        for function, c in zip(p.functions, p.arguments, strict=True):
            if c is None:
                argument = np.zeros(len(values))
            else:
                argument = values[:, c]
                if clamp:
                    argument = np.clip(argument, *self.ranges[c])
            xyz.append(path_functions.evaluate(function, argument))
        return np.stack(xyz, axis=1) @ p.to_link.T + p.origin

    def _values(self, q_osim) -> tuple[np.ndarray, bool]:
        if isinstance(q_osim, dict):
            q_osim = np.stack([np.asarray(q_osim.get(n, 0.0), float)
                               for n in self.coordinate_names], axis=-1)
        values = np.asarray(q_osim, float)
        return np.atleast_2d(values), values.ndim == 1

    def lengths(self, q_osim, *, active_at=None) -> np.ndarray:
        """Muscle-tendon lengths, m: (n_muscles,) for one pose, (N, n_muscles) for N.

        Args:
            q_osim: OpenSim coordinate values, (n_coordinates,) or (N, n_coordinates) in
                :attr:`coordinate_names` order, or a dict name -> value (missing ones 0).
            active_at: Poses (same shape) at which the ConditionalPathPoints are decided
                instead of ``q_osim`` (to follow one branch of a switching path).
        """
        values, single = self._values(q_osim)
        active = None if active_at is None else self._values(active_at)[0]
        lengths = self._lengths(values, active_at=active)
        return lengths[0] if single else lengths

    def moment_arms(self, q_osim, *, step: float = STEP, active_at=None) -> np.ndarray:
        """Moment arms -dl/dq, m (or m/m): (n_muscles, n_coordinates) or (N, ...) for N.

        Zero for coordinates a muscle does not span. The coordinates are perturbed in
        groups no muscle spans two of (a left and a right joint together), so a pose costs
        2 x (number of groups) length evaluations. ``active_at``: as :meth:`lengths`.
        """
        values, single = self._values(q_osim)
        active = values if active_at is None else self._values(active_at)[0]
        arms = np.zeros((len(values), len(self.muscle_names), len(self.coordinate_names)))
        for group in self._groups():
            delta = np.zeros(len(self.coordinate_names))
            delta[list(group)] = step
            plus = self._lengths(values + delta, active_at=active, clamp=False)
            minus = self._lengths(values - delta, active_at=active, clamp=False)
            for m in range(len(self.muscle_names)):
                for c in set(group) & set(self.columns(m)):
                    arms[:, m, c] = -(plus[:, m] - minus[:, m]) / (2.0 * step)
        return arms[0] if single else arms

    def _groups(self) -> list[tuple[int, ...]]:
        """Spanned coordinates coloured so that no muscle spans two of one colour."""
        groups: list[list[int]] = []
        spans = [set(self.columns(m)) for m in range(len(self.muscle_names))]
        for c in sorted(set().union(*spans)):
            for group in groups:
                if not any(c in s and s & set(group) for s in spans):
                    group.append(c)
                    break
            else:
                groups.append([c])
        return [tuple(g) for g in groups]


def branch_ranges(geometry: PathGeometry, muscle: int) -> np.ndarray:
    """(n_spanned, 2) ranges within which a muscle's smooth length follows OpenSim's.

    The spanned coordinates' ranges, each cut at a ConditionalPathPoint boundary inside it
    where the exact length jumps by more than :data:`JUMP_LIMIT` (no smooth function follows
    such a jump): the side kept holds the coordinate's default value. Beyond the cut the fit
    follows the kept branch continued (the point's switch not made), smooth and bounded. In
    2D_gait.osim this cuts the knee at 81 deg of flexion for vasti (3.4 mm jump) and 84 deg
    for rect_fem (2.5 mm); the iliopsoas (0.02 mm at 45 deg hip flexion) and gastroc
    (0.4 mm at 45 deg knee flexion) switches are fitted through.
    """
    osim = geometry.built.osim
    columns = geometry.columns(muscle)
    ranges = geometry.ranges[list(columns)].copy()
    defaults = np.array([c.default_value for c in osim.coordinates])
    for point in geometry._paths[muscle]:
        if point.condition is None or point.condition[0] not in columns:
            continue
        c, low, high = point.condition
        row = columns.index(c)
        for bound in (low, high):
            lo, hi = ranges[row]
            if not lo < bound < hi:
                continue
            poses = np.tile(defaults, (2, 1))
            poses[:, c] = bound - 2 * CONDITIONAL_TOLERANCE, bound + 2 * CONDITIONAL_TOLERANCE
            jump = abs(np.diff(geometry.lengths(poses)[:, muscle])[0])
            if jump > JUMP_LIMIT:
                margin = 2 * CONDITIONAL_TOLERANCE
                ranges[row] = (bound + margin, hi) if defaults[c] > bound else (lo, bound - margin)
    return ranges


def fit_smooth_paths(geometry: PathGeometry, *, n_samples: int = SAMPLES, seed: int = 0):
    """Fit every muscle's polynomial (:mod:`predgait.dynamics.path_polynomials`).

    The exact lengths and moment arms are sampled at ``n_samples`` poses within the spanned
    coordinates' ranges, half drawn uniformly, half with the arcsine density of Chebyshev
    nodes (seeded: the same fit every time); each muscle is
    fitted over the whole ranges, its conditional points decided within its
    :func:`branch_ranges` (the poses clipped into them), which it then follows.

    Returns:
        :class:`~predgait.dynamics.path_polynomials.SmoothPaths` on OpenSim coordinate values
        in ``geometry.coordinate_names`` order.
    """
    from predgait.dynamics import path_polynomials

    rng = np.random.default_rng(seed)
    spanned = sorted({c for m in range(len(geometry.muscle_names)) for c in geometry.columns(m)})
    values = np.tile([c.default_value for c in geometry.built.osim.coordinates], (n_samples, 1))
    for c in spanned:
        # Arcsine (Chebyshev) density: as many samples near the range ends, where a
        # polynomial's derivative errs most, as in the middle.
        low, high = geometry.ranges[c]
        unit = np.where(np.arange(n_samples) % 2 == 0, rng.uniform(-1.0, 1.0, n_samples),
                        np.cos(np.pi * rng.uniform(0.0, 1.0, n_samples)))
        values[:, c] = 0.5 * (low + high) + 0.5 * (high - low) * unit
    branches = [branch_ranges(geometry, m) for m in range(len(geometry.muscle_names))]
    decide = values.copy()
    for m, ranges in enumerate(branches):
        for row, c in enumerate(geometry.columns(m)):
            # Coordinates are shared: a cut must be the same for every muscle it concerns,
            # else those muscles are evaluated on their own clipped poses below.
            decide[:, c] = np.clip(decide[:, c], *ranges[row])
    lengths = geometry.lengths(values, active_at=decide)
    arms = geometry.moment_arms(values, active_at=decide)
    polynomials = []
    for m, name in enumerate(geometry.muscle_names):
        columns = list(geometry.columns(m))
        own = values.copy()
        own[:, columns] = np.clip(values[:, columns], branches[m][:, 0], branches[m][:, 1])
        if not np.array_equal(geometry.decisions(m, own), geometry.decisions(m, decide)):
            lengths[:, m] = geometry.lengths(values, active_at=own)[:, m]
            arms[:, m] = geometry.moment_arms(values, active_at=own)[:, m]
        full = geometry.ranges[columns]
        polynomials.append(path_polynomials.fit(
            name, tuple(columns), full, values[:, columns], lengths[:, m], arms[:, m][:, columns],
            agrees=branches[m]))
    return path_polynomials.SmoothPaths(geometry.coordinate_names, geometry.muscle_names,
                                        tuple(polynomials))


def smooth_paths(built, *, on_model_q: bool = False):
    """The fitted smooth paths of a built model (:func:`fit_smooth_paths`), ~1 s once.

    Args:
        built: :class:`~predgait.models.osim_model.OsimPlanarModel`.
        on_model_q: Take the model's q (``built.osim_coordinates`` order and signs) instead
            of OpenSim values in the file's coordinate order.
    """
    paths = _fitted(built)
    return paths.reordered(built.osim_coordinates, built.signs) if on_model_q else paths


@functools.lru_cache(maxsize=8)
def _fitted(built):
    """One fit per built model object (kept while the process runs)."""
    return fit_smooth_paths(PathGeometry(built))


def _active(point: _Point, poses: np.ndarray) -> np.ndarray:
    """(N,) whether a point counts at each pose (OpenSim ConditionalPathPoint::isActive)."""
    if point.condition is None:
        return np.ones(len(poses), bool)
    c, low, high = point.condition
    return (poses[:, c] >= low - CONDITIONAL_TOLERANCE) & \
        (poses[:, c] <= high + CONDITIONAL_TOLERANCE)


def _replace(point: _Point, **changes) -> _Point:
    from dataclasses import replace

    return replace(point, **changes)
