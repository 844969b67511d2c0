"""``predgait simulate`` problem files: one frozen spec per kind, parsed once.

Kinds (``kind = "..."`` at the top of the file):

* ``rod``: the thesis rod experiment on a synthetic trial (3.2.4, Figs. 4.1.9-4.1.10),
  inertial- vs body-based end forces, and a step-size study.
* ``collapse``: the leg collapsing under its own weight (4.2, Figs. 4.2.2-4.2.5), with
  ``[[compare]]`` runs at other steps / iterations.
* ``resynthesis``: the measured trial re-synthesized from its inverse-dynamics moments
  and hip load with the foot prescribed (4.2, Figs. 4.2.8-4.2.10), with ``[[variants]]``
  of passive elements (Fig. 4.2.9).
* ``gait7``: the planar 7-link model on the measured trial, feet on heel/toe contacts,
  HAT height free (2.3.1, 2.4, Fig. 2.4.1); knee-driven runs to a fall
  (:mod:`predgait.workflows.gait7_spec`).
* ``fullbody``: the 35-DOF body driven by its 3D inverse-dynamics moments or motions,
  pelvis prescribed or free, measured or contact ground (2.3.2, 2.4, Figs. 2.4.2-2.4.3;
  :mod:`predgait.workflows.forward3d_spec`).

Strings become enums here; unknown keys are refused with their line.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from predgait.data.events import Side
from predgait.dynamics.forward import LEG_FALL, FallLimit, ForceFrame
from predgait.dynamics.integrators import IntegratorOptions
from predgait.dynamics.passive import PassiveJoint, parse_passive
from predgait.problemfile import Table, load_problem
from predgait.workflows.trials import LegTrial, leg_trial

KINDS = ("rod", "collapse", "resynthesis", "gait7", "fullbody")


@dataclass(frozen=True)
class RodSpec:
    """Rod experiment: synthetic trial, both force frames, step study."""

    integrator: IntegratorOptions
    duration: float = 1.0
    rate: float = 60.0
    noise: float = 0.0
    frames: tuple[ForceFrame, ...] = (ForceFrame.INERTIAL, ForceFrame.BODY)
    step_study: tuple[float, ...] = ()
    source: str = ""


@dataclass(frozen=True)
class Variant:
    """A compared run: a name and what it changes."""

    name: str
    step: float | None = None
    iterations: int | None = None
    passive: dict[str, PassiveJoint] | None = None
    hip_in_thigh_frame: bool | None = None


@dataclass(frozen=True)
class CollapseSpec:
    """Collapse test: foot fixed, initial absolute segment angles, no loads."""

    integrator: IntegratorOptions
    duration: float = 0.3
    foot_deg: float = 0.0
    shank_deg: float = 5.0
    thigh_deg: float = -5.0
    fall: FallLimit = LEG_FALL
    passive: dict[str, PassiveJoint] = field(default_factory=dict)
    compare: tuple[Variant, ...] = ()
    stick_interval: float = 0.05
    source: str = ""


@dataclass(frozen=True)
class ResynthesisSpec:
    """Re-synthesis of a measured trial (bundled subject01 or an inverse problem file)."""

    integrator: IntegratorOptions
    side: Side = Side.RIGHT
    inverse_problem: Path | None = None
    start: float = 0.0
    duration: float | None = None
    threshold_deg: float = 5.0
    fall: FallLimit = LEG_FALL
    passive: dict[str, PassiveJoint] = field(default_factory=dict)
    hip_in_thigh_frame: bool = False
    variants: tuple[Variant, ...] = ()
    stability_times: tuple[float, ...] = (0.05, 0.2, 0.4)
    stick_interval: float = 0.05
    source: str = ""
    trial: LegTrial | None = None


Spec = RodSpec | CollapseSpec | ResynthesisSpec


def _integrator(table: Table) -> IntegratorOptions:
    return IntegratorOptions.from_table(table.table("integrator"))


def _passive(table: Table, key: str = "passive") -> dict[str, PassiveJoint]:
    sub = table.table(key)
    sub.check_keys(("ankle", "knee", "hip"))
    joints = {}
    for name in sub.data:
        joint = sub.table(name)
        joint.check_keys(("k", "c", "theta0", "theta0_deg", "limits"))
        joints[name] = parse_passive(joint.data, where=f"{table.path}: {sub.prefix}{name}")
    return joints


def _fall(table: Table) -> FallLimit:
    sub = table.table("fall")
    sub.check_keys(("segment_angle_deg", "hip_height"))
    return FallLimit(segment_angle_deg=sub.number("segment_angle_deg", 60.0, low=1, high=180,
                                                  unit="deg"),
                     hip_height=sub.number("hip_height", None, low=0, high=2, unit="m"))


def _variants(table: Table, key: str) -> tuple[Variant, ...]:
    out = []
    for sub in table.tables(key):
        sub.check_keys(("name", "step", "iterations", "passive", "hip_force_frame"))
        out.append(Variant(name=sub.get("name", str),
                           step=sub.number("step", None, low=1e-6, high=0.1, unit="s"),
                           iterations=_iterations(sub),
                           passive=_passive(sub) if sub.has("passive") else None,
                           hip_in_thigh_frame=_hip_in_thigh(sub) if sub.has("hip_force_frame")
                           else None))
    return tuple(out)


#: ``hip_force_frame`` values: the hip load fixed in the lab (inertial-based) or in the
#: thigh frame (body-based, thesis 3.3.3 and Appendix A).
HIP_FORCE_FRAMES = ("lab", "thigh")


def _hip_in_thigh(table: Table) -> bool:
    frame = table.get("hip_force_frame", str, "lab")
    if frame not in HIP_FORCE_FRAMES:
        raise table.error("hip_force_frame", f"'{frame}' is not one of: "
                                             f"{', '.join(HIP_FORCE_FRAMES)}.")
    return frame == "thigh"


def _iterations(table: Table) -> int | None:
    value = table.get("iterations", int, None)
    if value is not None and not 1 <= value <= 100:
        raise table.error("iterations", f"{value} is outside 1..100.")
    return value


def _stability_times(stab: Table, sim: Table) -> tuple[float, ...]:
    duration = sim.number("duration", None, low=0.01, high=30, unit="s")
    return stab.numbers("times", [0.05, 0.2, 0.4], low=0.0,
                        high=30.0 if duration is None else duration, unit="s")


def parse_spec(path: str | Path, overrides=()) -> Spec:
    """Read a ``simulate`` problem file into its spec.

    Raises:
        InputError: Naming file, key and line for unknown keys or bad values.
    """
    table = load_problem(path, overrides)
    table.expect_command("simulate")
    kind = table.get("kind", str)
    if kind not in KINDS:
        raise table.error("kind", f"{kind!r} is not one of: {', '.join(KINDS)}.")
    integrator = _integrator(table)
    source = str(path)
    if kind == "gait7":
        from predgait.workflows.gait7_spec import parse_gait7

        return parse_gait7(table, integrator, source)
    if kind == "fullbody":
        from predgait.workflows.forward3d_spec import parse_fullbody

        return parse_fullbody(table, integrator, source)
    if kind == "rod":
        table.check_keys(("kind", "integrator", "rod"))
        rod = table.table("rod")
        rod.check_keys(("duration", "rate", "noise", "frames", "step_study"))
        frames = rod.strings("frames", ["inertial", "body"])
        try:
            frames = tuple(ForceFrame(f) for f in frames)
        except ValueError:
            raise rod.error("frames", "use a list of \"inertial\" and/or \"body\".") from None
        steps = rod.numbers("step_study", [], low=1e-6, high=0.1, unit="s")
        return RodSpec(integrator=integrator,
                       duration=rod.number("duration", 1.0, low=0.05, high=20, unit="s"),
                       rate=rod.number("rate", 60.0, low=10, high=10000, unit="Hz"),
                       noise=rod.number("noise", 0.0, low=0, high=1e3, unit="N"),
                       frames=frames, step_study=steps, source=source)
    if kind == "collapse":
        table.check_keys(("kind", "integrator", "collapse", "fall", "passive", "compare"))
        c = table.table("collapse")
        c.check_keys(("duration", "foot_deg", "shank_deg", "thigh_deg", "stick_interval"))
        return CollapseSpec(
            integrator=integrator,
            duration=c.number("duration", 0.3, low=0.01, high=10, unit="s"),
            foot_deg=c.number("foot_deg", 0.0, low=-90, high=90, unit="deg"),
            shank_deg=c.number("shank_deg", 5.0, low=-90, high=90, unit="deg"),
            thigh_deg=c.number("thigh_deg", -5.0, low=-90, high=90, unit="deg"),
            stick_interval=c.number("stick_interval", 0.05, low=0.001, high=1, unit="s"),
            fall=_fall(table), passive=_passive(table), compare=_variants(table, "compare"),
            source=source)
    table.check_keys(("kind", "integrator", "trial", "simulation", "fall", "passive",
                      "variants", "stability"))
    trial = leg_trial(table.table("trial"))
    sim = table.table("simulation")
    sim.check_keys(("start", "duration", "threshold_deg", "stick_interval", "hip_force_frame"))
    stab = table.table("stability")
    stab.check_keys(("times",))
    return ResynthesisSpec(
        integrator=integrator, side=trial.side, inverse_problem=trial.inverse_problem,
        start=sim.number("start", 0.0, unit="s"),
        duration=sim.number("duration", None, low=0.01, high=30, unit="s"),
        threshold_deg=sim.number("threshold_deg", 5.0, low=0.01, high=90, unit="deg"),
        stick_interval=sim.number("stick_interval", 0.05, low=0.001, high=1, unit="s"),
        fall=_fall(table), passive=_passive(table), hip_in_thigh_frame=_hip_in_thigh(sim),
        variants=_variants(table, "variants"), stability_times=_stability_times(stab, sim),
        source=source, trial=trial)
