"""Surgery and orthosis edits of a muscle-driven OpenSim model: a :class:`MuscleScenario`.

A scenario file holds ``[[muscle_edit]]`` tables (beside the joint/segment ``[[edit]]``
tables of :mod:`predgait.scenarios.edits`, which act on the torque-driven gait7 model).
:func:`parse_muscle_edits` reads them (every error names the file, key and line);
:func:`muscle_scenario` applies them to a model read by
:func:`predgait.models.osim.read_osim` and built by
:func:`predgait.models.osim_model.build_model`. Muscles are named as in the model
(``soleus_r``) or without the side (``soleus``: both sides); coordinates likewise
(``knee_angle_r``, or ``knee_angle`` for both).

Kinds (``kind = ...``):

- ``tendon_slack_length``: ``scale`` or ``change_m`` (m; > 0 a lengthening, e.g. an
  Achilles or hamstring lengthening; < 0 a contracture): ``tendon_slack_length``.
- ``max_isometric_force``: ``scale`` (weakness < 1): ``max_isometric_force``.
- ``optimal_fiber_length``: ``scale`` (contracture < 1): ``optimal_fiber_length``.
- ``passive_fiber_strain``: ``scale`` or ``strain`` (contracture: a smaller strain, a
  stiffer muscle): ``passive_fiber_strain_at_one_norm_force``.
- ``transfer``: ``muscle`` moved onto ``donor``'s distal attachment (see below).
- ``fuse``: ``coordinate`` held at ``angle_deg`` (arthrodesis, locked knee brace): its
  bounds become [angle, angle] and its speed bounds [0, 0].
- ``range_of_motion``: ``coordinate`` bounded to ``lower_deg``..``upper_deg``.
- ``spring``: a rotational spring-damper on ``coordinate`` (an ankle-foot orthosis):
  tau = -k (q - q0) - c dq/dt with ``stiffness`` k (N m/rad), ``neutral_deg`` q0 and
  ``damping`` c (N m s/rad, default 0). Its torque acts on the skeleton in the dynamics
  (it is not a control and costs nothing in the effort), so a stiff orthosis changes the
  gait and the muscles' metabolic cost, not the objective's bookkeeping.

Muscle transfer: :mod:`predgait.scenarios.muscle_transfer`.

:class:`MuscleScenario` is what the muscle-driven problem builder consumes (see its
attributes).
"""

from __future__ import annotations

import enum
import math
from collections.abc import Mapping
from dataclasses import dataclass

from predgait.dynamics.joint_springs import JointSpring, spring_forces
from predgait.problemfile import Table
from predgait.scenarios.muscle_transfer import transferred_model, transferred_osim

DEG = math.pi / 180.0


class MuscleEditKind(enum.Enum):
    """The kinds of ``[[muscle_edit]]`` a scenario file may hold."""

    TENDON_SLACK_LENGTH = "tendon_slack_length"
    MAX_ISOMETRIC_FORCE = "max_isometric_force"
    OPTIMAL_FIBER_LENGTH = "optimal_fiber_length"
    PASSIVE_FIBER_STRAIN = "passive_fiber_strain"
    TRANSFER = "transfer"
    FUSE = "fuse"
    RANGE_OF_MOTION = "range_of_motion"
    SPRING = "spring"


#: Muscle parameter each parameter edit changes.
PARAMETER = {
    MuscleEditKind.TENDON_SLACK_LENGTH: "tendon_slack_length",
    MuscleEditKind.MAX_ISOMETRIC_FORCE: "max_isometric_force",
    MuscleEditKind.OPTIMAL_FIBER_LENGTH: "optimal_fiber_length",
    MuscleEditKind.PASSIVE_FIBER_STRAIN: "passive_fiber_strain_at_one_norm_force",
}
#: Key of an absolute value per parameter edit (besides ``scale``).
_ABSOLUTE = {MuscleEditKind.TENDON_SLACK_LENGTH: "change_m",
             MuscleEditKind.PASSIVE_FIBER_STRAIN: "strain"}
#: Allowed scale factors (a zero or negative one is impossible).
SCALE_RANGE = (1e-3, 10.0)


@dataclass(frozen=True)
class ParameterEdit:
    """Scale a parameter (``scale``) or add to / set it (``change``, ``value``)."""

    kind: MuscleEditKind
    muscles: tuple[str, ...]
    scale: float | None = None
    change: float | None = None     # m, tendon slack length
    value: float | None = None      # passive fibre strain


@dataclass(frozen=True)
class Transfer:
    """Move ``muscle``'s distal attachment onto ``donor``'s (see the module docstring)."""

    muscle: str
    donor: str


@dataclass(frozen=True)
class CoordinateLimit:
    """Bounds on an OpenSim coordinate (rad): a fusion has lower = upper."""

    coordinate: str
    lower: float
    upper: float

    @property
    def fused(self) -> bool:
        """Held at one angle."""
        return self.lower == self.upper


MuscleEdit = ParameterEdit | Transfer | CoordinateLimit | JointSpring


@dataclass(frozen=True, eq=False)
class MuscleScenario:
    """An edited muscle-driven model, as the problem builder consumes it.

    Attributes:
        muscles: The edited :class:`~predgait.dynamics.muscles.MuscleSet` (same order).
        coordinate_bounds: OpenSim coordinate -> (low, high), rad, overriding the baseline
            problem's bounds (``{**baseline_bounds, **coordinate_bounds}``).
        speed_bounds: OpenSim coordinate -> (low, high), rad/s and rad/s^2, for the
            speeds and the accelerations: (0, 0) for a fused one.
        passive_torques: :class:`JointSpring` elements whose torques add to the applied
            generalised forces (:meth:`passive_forces`).
        paths: Smooth paths (:func:`predgait.dynamics.muscle_paths.smooth_paths`, model q)
            replacing the baseline's, or None (no transfer: keep the baseline's fit).
        built: The :class:`~predgait.models.osim_model.OsimPlanarModel` whose ``osim``
            holds the transferred paths (the baseline's if no transfer).
        edits: The edits applied, in file order.
        symmetric: Every edit acts on both sides alike (a half-stride problem with
            left/right symmetry stays valid); False: solve a full stride.

    A fused coordinate is a weld: its joint reaction torque holds it, so the problem must
    drop that coordinate's row of the inverse-dynamics residual (or give it a free,
    cost-free torque); keeping the row would make the muscles hold the joint, a
    muscle-braced knee rather than an arthrodesis. :attr:`fused` lists them.
    """

    muscles: object
    coordinate_bounds: Mapping[str, tuple[float, float]]
    speed_bounds: Mapping[str, tuple[float, float]]
    passive_torques: tuple[JointSpring, ...]
    paths: object | None
    built: object
    edits: tuple[MuscleEdit, ...]
    symmetric: bool

    @property
    def fused(self) -> tuple[str, ...]:
        """OpenSim coordinates held at one value (their residual rows are reactions)."""
        return tuple(n for n, (low, high) in self.coordinate_bounds.items() if low == high)

    def passive_forces(self, planar, q, v):
        """(nq,) generalised forces of the springs on model q/v (numpy or CasADi column).

        See :func:`predgait.dynamics.joint_springs.spring_forces`.
        """
        return spring_forces(self.passive_torques, planar.osim_coordinates, planar.signs,
                             q, v)

    def edited_plant(self, plant):
        """The baseline MusclePlant with this scenario's muscles, paths and model record.

        A new :class:`~predgait.problems.muscle_gait_dynamics.MusclePlant` (its node
        function is built anew). The springs are not in it: add :meth:`passive_forces` to
        the node's applied generalised forces.
        """
        from dataclasses import replace as copy

        return copy(plant, osim=self.built.osim, muscle_set=self.muscles,
                    paths=plant.paths if self.paths is None else self.paths)


def _sides(name: str, known: tuple[str, ...]) -> tuple[str, ...]:
    """``name`` if known, else its ``_r`` and ``_l`` versions that are (empty: none)."""
    if name in known:
        return (name,)
    return tuple(n for n in (f"{name}_r", f"{name}_l") if n in known)


def _muscle_names(table: Table, key: str, known: tuple[str, ...]) -> tuple[str, ...]:
    value = table.get(key, (str, list))
    given = (value,) if isinstance(value, str) else table.strings(key)
    names: list[str] = []
    for name in given:
        found = _sides(name, known)
        if not found:
            raise table.error(key, f"no muscle named {name!r}; the model's muscles: "
                                   f"{', '.join(known)} (or one without _r/_l for both).")
        names.extend(n for n in found if n not in names)
    return tuple(names)


def _coordinates(table: Table, known: tuple[str, ...]) -> tuple[str, ...]:
    name = table.get("coordinate", str)
    found = _sides(name, known)
    if not found:
        raise table.error("coordinate", f"no coordinate named {name!r}; the model's: "
                                        f"{', '.join(known)} (or one without _r/_l).")
    return found


_KEYS = {
    MuscleEditKind.TENDON_SLACK_LENGTH: ("muscles", "scale", "change_m"),
    MuscleEditKind.MAX_ISOMETRIC_FORCE: ("muscles", "scale"),
    MuscleEditKind.OPTIMAL_FIBER_LENGTH: ("muscles", "scale"),
    MuscleEditKind.PASSIVE_FIBER_STRAIN: ("muscles", "scale", "strain"),
    MuscleEditKind.TRANSFER: ("muscle", "donor"),
    MuscleEditKind.FUSE: ("coordinate", "angle_deg"),
    MuscleEditKind.RANGE_OF_MOTION: ("coordinate", "lower_deg", "upper_deg"),
    MuscleEditKind.SPRING: ("coordinate", "stiffness", "neutral_deg", "damping"),
}


def _parameter_edit(table: Table, kind: MuscleEditKind, muscles) -> ParameterEdit:
    names = _muscle_names(table, "muscles", muscles.names)
    absolute = _ABSOLUTE.get(kind)
    given = [k for k in ("scale", absolute) if k and table.has(k)]
    if len(given) != 1:
        choices = " or ".join(k for k in ("scale", absolute) if k)
        raise table.error("kind", f"give exactly one of {choices} for a {kind.value} edit.")
    key = given[0]
    value = table.number(key)
    parameter = PARAMETER[kind]
    if key == "scale" and not SCALE_RANGE[0] <= value <= SCALE_RANGE[1]:
        raise table.error(key, f"{value!r} is impossible; a scale factor must be within "
                               f"{SCALE_RANGE[0]:g}..{SCALE_RANGE[1]:g}.")
    for name in names:
        old = getattr(muscles.muscles[muscles.index(name)], parameter)
        new = old * value if key == "scale" else (old + value if key == "change_m" else value)
        if not new > 0:
            raise table.error(key, f"gives muscle {name!r} {parameter} = {new:.6g} (was "
                                   f"{old:.6g}); it must stay > 0.")
    if key == "scale":
        return ParameterEdit(kind, names, scale=value)
    if key == "change_m":
        return ParameterEdit(kind, names, change=value)
    return ParameterEdit(kind, names, value=value)


def parse_muscle_edit(table: Table, muscles, coordinates: tuple[str, ...]) -> list[MuscleEdit]:
    """One ``[[muscle_edit]]`` table -> edits (one per side for a side-less coordinate).

    Args:
        table: The table (errors name its file, key and line).
        muscles: The baseline :class:`~predgait.dynamics.muscles.MuscleSet` (names, values).
        coordinates: The model's OpenSim coordinate names.

    Raises:
        InputError: Unknown kind, key, muscle or coordinate; an impossible value (a zero or
            negative scale, a tendon slack length that would not stay > 0, ...).
    """
    kind = table.choice("kind", MuscleEditKind)
    table.check_keys(("kind", *_KEYS[kind]))
    if kind in PARAMETER:
        return [_parameter_edit(table, kind, muscles)]
    if kind is MuscleEditKind.TRANSFER:
        muscle, donor = (_muscle_names(table, k, muscles.names) for k in ("muscle", "donor"))
        if len(muscle) != len(donor) or any(a == b for a, b in zip(muscle, donor, strict=True)):
            raise table.error("donor", f"transfer {muscle} onto {donor}: give one donor per "
                                       "muscle (same sides), other than the muscle itself.")
        return [Transfer(a, b) for a, b in zip(muscle, donor, strict=True)]
    names = _coordinates(table, coordinates)
    if kind is MuscleEditKind.FUSE:
        angle = table.number("angle_deg", low=-180, high=180, unit="deg") * DEG
        return [CoordinateLimit(n, angle, angle) for n in names]
    if kind is MuscleEditKind.RANGE_OF_MOTION:
        low = table.number("lower_deg", low=-180, high=180, unit="deg")
        high = table.number("upper_deg", low=-180, high=180, unit="deg")
        if high <= low:
            raise table.error("upper_deg", "must be larger than lower_deg.")
        return [CoordinateLimit(n, low * DEG, high * DEG) for n in names]
    stiffness = table.number("stiffness", low=0.0, high=1e5, unit="N m/rad")
    neutral = table.number("neutral_deg", 0.0, low=-180, high=180, unit="deg") * DEG
    damping = table.number("damping", 0.0, low=0.0, high=1e4, unit="N m s/rad")
    return [JointSpring(n, stiffness, neutral, damping) for n in names]


def parse_muscle_edits(table: Table, muscles, coordinates: tuple[str, ...],
                       key: str = "muscle_edit") -> tuple[MuscleEdit, ...]:
    """All ``[[muscle_edit]]`` tables of a scenario file, in order."""
    edits: list[MuscleEdit] = []
    for item in table.tables(key):
        edits.extend(parse_muscle_edit(item, muscles, coordinates))
    return tuple(edits)


@dataclass(frozen=True)
class MuscleScenarioSpec:
    """A parsed ``kind = "muscle_scenario"`` file.

    Attributes:
        name: Scenario name.
        baseline: The baseline problem file (``predict_2d_muscles.toml``), from the
            scenario file's folder; not read here.
        edits: The ``[[muscle_edit]]`` edits, in order.
        source: The scenario file.
    """

    name: str
    baseline: object
    edits: tuple[MuscleEdit, ...]
    source: object = None


def parse_muscle_scenario(table: Table, muscles,
                          coordinates: tuple[str, ...]) -> MuscleScenarioSpec:
    """A muscle scenario file: ``name``, ``kind``, ``baseline`` and ``[[muscle_edit]]``."""
    table.check_keys(("name", "kind", "baseline", "muscle_edit"))
    if table.get("kind", str) != "muscle_scenario":
        raise table.error("kind", "expected 'muscle_scenario'.")
    edits = parse_muscle_edits(table, muscles, coordinates)
    if not edits:
        raise table.error("muscle_edit", "no [[muscle_edit]] table; add one (see "
                                         "problems/scenario_muscle_*.toml).")
    return MuscleScenarioSpec(table.get("name", str), table.path_value("baseline"), edits,
                              table.path)


def muscle_scenario(edits, built, muscles=None) -> MuscleScenario:
    """Apply parsed edits to a built model (:func:`parse_muscle_edits`).

    Args:
        edits: The edits, in order (later ones act on earlier results).
        built: Baseline :class:`~predgait.models.osim_model.OsimPlanarModel`.
        muscles: Baseline MuscleSet (default ``MuscleSet.from_osim(built.osim)``).
    """
    from predgait.dynamics.muscles import MuscleSet

    muscles = MuscleSet.from_osim(built.osim) if muscles is None else muscles
    osim = built.osim
    bounds: dict[str, tuple[float, float]] = {}
    speeds: dict[str, tuple[float, float]] = {}
    springs: list[JointSpring] = []
    transfers: list[Transfer] = []
    for edit in edits:
        if isinstance(edit, ParameterEdit):
            key = PARAMETER[edit.kind]
            if edit.scale is not None:
                muscles = muscles.edited(edit.muscles, **{f"{key}_scale": edit.scale})
            else:
                for name in edit.muscles:
                    old = getattr(muscles.muscles[muscles.index(name)], key)
                    new = old + edit.change if edit.change is not None else edit.value
                    muscles = muscles.edited(name, **{key: new})
        elif isinstance(edit, Transfer):
            osim = transferred_osim(osim, edit.muscle, edit.donor)
            transfers.append(edit)
        elif isinstance(edit, CoordinateLimit):
            bounds[edit.coordinate] = (edit.lower, edit.upper)
            if edit.fused:
                speeds[edit.coordinate] = (0.0, 0.0)
        else:
            springs.append(edit)
    paths, edited_built = None, built
    if transfers:
        edited_built, muscles, paths = transferred_model(
            built, osim, muscles, tuple(e.muscle for e in transfers))
    return MuscleScenario(muscles=muscles, coordinate_bounds=bounds, speed_bounds=speeds,
                          passive_torques=tuple(springs), paths=paths, built=edited_built,
                          edits=tuple(edits), symmetric=_symmetric(edits))


def _symmetric(edits) -> bool:
    """Whether every right-side edit has its left mirror (and vice versa)."""
    def mirrored(name: str) -> str:
        return name[:-2] + {"_r": "_l", "_l": "_r"}.get(name[-2:], name[-2:])

    def signature(edit) -> tuple:
        if isinstance(edit, ParameterEdit):
            return tuple((edit.kind, n, edit.scale, edit.change, edit.value)
                         for n in edit.muscles)
        if isinstance(edit, Transfer):
            return ((edit.muscle, edit.donor),)
        return ((type(edit).__name__, edit.coordinate, *[getattr(edit, f) for f in
                 edit.__dataclass_fields__ if f != "coordinate"]),)

    items = {item for edit in edits for item in signature(edit)}

    def mirror(item: tuple) -> tuple:
        return tuple(mirrored(x) if isinstance(x, str) and x[-2:] in ("_r", "_l") else x
                     for x in item)

    return all(mirror(item) in items for item in items)

