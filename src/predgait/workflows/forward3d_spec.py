"""``kind = "fullbody"`` problem files (thesis 2.3.2, 2.4).

The 35-DOF body re-synthesized from its own 3D inverse dynamics
(:mod:`predgait.simulations.forward3d`).

Tables: ``[trial]`` (the bundled subject01 walk or TRC/MOT files, the static trial, the
marker map, subject), ``[integrator]``, ``[simulation]`` (start, duration, deviation
bands), ``[fall]``, ``[contact]`` and one ``[[variants]]`` per simulation (pelvis,
joints, ground, kinematic joints). See problems/fullbody_resynthesis.toml.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from predgait.data.body_weight import parse_mass
from predgait.dynamics.contact import ImpactContact
from predgait.dynamics.falls import FallLimit
from predgait.dynamics.integrators import IntegratorOptions
from predgait.dynamics.inverse_options import BUNDLED
from predgait.models.fullbody import CONTACTS
from predgait.problemfile import Table
from predgait.simulations.forward3d import (
    DEFAULT_CONTACT,
    FULLBODY_FALL,
    ContactSettings,
    GroundMode,
    JointMode,
    Mode,
    PelvisMode,
)


@dataclass(frozen=True)
class TrialSpec:
    """Where the measured trial comes from (files None = the bundled subject01 walk)."""

    files: tuple[Path, ...] | None
    static: Path | None
    marker_map: Path
    mass: float | str | None   # kg, "plates" (weighed on them) or None (the bundled walk's)
    height: float | None
    sex: str
    cutoff: float


@dataclass(frozen=True)
class FullbodySpec:
    """A whole-body re-synthesis problem."""

    integrator: IntegratorOptions
    trial: TrialSpec
    variants: tuple[Mode, ...]
    start: float | None = None
    duration: float = 1.0
    band_deg: float = 5.0
    band_m: float = 0.05
    fall: FallLimit = FULLBODY_FALL
    contact: ContactSettings = ContactSettings()
    source: str = ""


def parse_trial(table: Table) -> TrialSpec:
    """The ``[trial]`` table of a full-body problem (bundled source or files, subject)."""
    t = table.table("trial")
    t.check_keys(("source", "files", "static", "marker_map", "mass", "height", "sex",
                  "cutoff"))
    source = t.get("source", str, BUNDLED if not t.has("files") else "files")
    if t.has("files") == (source == BUNDLED):
        raise t.error("source", f"give either source = \"{BUNDLED}\" or files = [TRC, MOT] "
                                "(relative to this file), not both or neither.")
    files = None
    if t.has("files"):
        names = t.get("files", list)
        if not names or not all(isinstance(n, str) for n in names):
            raise t.error("files", "expected a list of file names, e.g. [\"walk.trc\", "
                                   "\"walk_grf.mot\"].")
        files = tuple(p if p.is_absolute() else t.path.parent / p for p in map(Path, names))
        for key in ("mass", "height"):
            if not t.has(key):
                raise t.error(key, "required with trial files (kg, m).")
    sex = t.get("sex", str, "male")
    if sex not in ("male", "female"):
        raise t.error("sex", f"{sex!r} is not male or female.")
    for key, paths in (("files", files or ()), ("static", [t.path_value("static", None)]),
                       ("marker_map", [t.path_value("marker_map")])):
        for path in paths:
            if path is not None and not path.is_file():
                raise t.error(key, f"{path} not found (paths are relative to the problem "
                                   "file).")
    return TrialSpec(files=files, static=t.path_value("static", None),
                     marker_map=t.path_value("marker_map"),
                     mass=parse_mass(t) if t.has("mass") else None,
                     height=t.number("height", None, low=0.5, high=2.5, unit="m"), sex=sex,
                     cutoff=t.number("cutoff", 6.0, low=0.5, high=50, unit="Hz"))


def parse_contact(table: Table) -> ContactSettings:
    """The ``[contact]`` table: sole points, spring-damper and friction of the floor."""
    c = table.table("contact")
    c.check_keys(("frames", "stiffness", "exponent", "damping", "damping_depth", "friction",
                  "slip_transition", "ground_z", "belt_velocity"))
    frames = c.get("frames", list, list(CONTACTS))
    if not frames or not all(isinstance(f, str) for f in frames):
        raise c.error("frames", f"expected a list of model frames, e.g. {list(CONTACTS)}.")
    d = DEFAULT_CONTACT
    law = ImpactContact(
        stiffness=c.number("stiffness", d.stiffness, low=1e2, high=1e9, unit="N/m"),
        exponent=c.number("exponent", d.exponent, low=1, high=4),
        damping=c.number("damping", d.damping, low=0, high=1e6, unit="N s/m"),
        damping_depth=c.number("damping_depth", d.damping_depth, low=1e-6, high=0.1, unit="m"),
        friction=c.number("friction", d.friction, low=0, high=5),
        slip_transition=c.number("slip_transition", d.slip_transition, low=1e-4, high=1,
                                 unit="m/s"))
    return ContactSettings(law, tuple(frames),
                           c.number("ground_z", None, low=-1, high=1, unit="m"),
                           c.number("belt_velocity", None, low=-10, high=10, unit="m/s"))


def _variants(table: Table) -> tuple[Mode, ...]:
    items = table.data.get("variants", [])
    if not isinstance(items, list) or not items:
        raise table.error("variants", "give at least one [[variants]] table (name, pelvis, "
                                      "joints, ground).")
    out = []
    for i, item in enumerate(items):
        v = Table(item, table.path, table.text, f"variants.{i}.")
        v.check_keys(("name", "pelvis", "joints", "ground", "kinematic_joints", "feedback_kp",
                      "feedback_damping_ratio", "step"))
        kinematic = v.get("kinematic_joints", list, [])
        if not all(isinstance(k, str) for k in kinematic):
            raise v.error("kinematic_joints", "expected a list of joint names or prefixes, "
                                              "e.g. [\"ankle\", \"knee_r_z\"].")
        out.append(Mode(name=v.get("name", str, f"variant {i}"),
                        pelvis=v.choice("pelvis", PelvisMode, "prescribed"),
                        joints=v.choice("joints", JointMode, "moments"),
                        ground=v.choice("ground", GroundMode, "measured"),
                        kinematic_joints=tuple(kinematic),
                        feedback_kp=v.number("feedback_kp", low=0.0, high=1e5, default=0.0),
                        feedback_damping_ratio=v.number("feedback_damping_ratio", low=0.0,
                                                        high=10.0, default=1.0),
                        step=v.number("step", low=1e-6, high=0.1, default=None, unit="s")))
    names = [m.name for m in out]
    if len(set(names)) != len(names):
        raise table.error("variants", "variant names must differ (they name the output files).")
    return tuple(out)


def parse_fullbody(table: Table, integrator: IntegratorOptions, source: str) -> FullbodySpec:
    """Read a ``kind = "fullbody"`` problem (the integrator already parsed).

    Raises:
        InputError: Naming file, key and line for unknown keys or bad values.
    """
    table.check_keys(("kind", "integrator", "trial", "simulation", "fall", "contact",
                      "variants"))
    sim = table.table("simulation")
    sim.check_keys(("start", "duration", "band_deg", "band_m"))
    fall = table.table("fall")
    fall.check_keys(("pelvis_drop", "pelvis_angle_deg", "joint_deg"))
    return FullbodySpec(
        integrator=integrator, trial=parse_trial(table), variants=_variants(table),
        start=sim.number("start", None, low=0, unit="s"),
        duration=sim.number("duration", 1.0, low=0.001, high=30, unit="s"),
        band_deg=sim.number("band_deg", 5.0, low=0.01, high=90, unit="deg"),
        band_m=sim.number("band_m", 0.05, low=1e-4, high=2, unit="m"),
        fall=FallLimit(
            base_drop=fall.number("pelvis_drop", 0.1, low=1e-3, high=2, unit="m"),
            base_angle_deg=fall.number("pelvis_angle_deg", 30.0, low=0.1, high=180,
                                       unit="deg"),
            joint_deviation_deg=fall.number("joint_deg", 45.0, low=0.1, high=360,
                                            unit="deg")),
        contact=parse_contact(table), source=source)
