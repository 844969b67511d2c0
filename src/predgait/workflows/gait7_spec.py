"""``kind = "gait7"`` problem files: the planar 7-link model on measured walking.

Tables (every key optional; see ``problems/gait7_contact.toml``): ``[trial]`` source,
start (s, trial clock), duration (s); ``[model]`` mass (kg), height (m), ground_z (m);
``[contact]`` model = impact | meglan, fit_depth (m) or stiffness (N/m), damping
(N s/m), damping_depth (m), meglan_a (N/m^4), meglan_b (N s/m^5); ``[knee]`` sides
(list of right/left; empty: no knee-driven run), moment = model | measured;
``[passive.knee]`` as :func:`predgait.dynamics.passive.parse_passive`; ``[fall]``
knee_deviation_deg, hat_drop (m); ``[output]`` stick_interval (s); ``[[variants]]``
with name and any of contact, knee, passive (tables as above).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field

from predgait.dynamics.contact import ImpactContact, MeglanContact
from predgait.dynamics.contact_fit import ImpactFit, fit_impact_to_meglan
from predgait.dynamics.falls import FallLimit
from predgait.dynamics.gait7_motion import SIDES
from predgait.dynamics.integrators import IntegratorOptions
from predgait.dynamics.inverse_options import BUNDLED, bundled_source
from predgait.dynamics.passive import PassiveJoint, parse_passive
from predgait.problemfile import Table
from predgait.simulations.gait7_sim import GAIT7_FALL, KneeMoment


class ContactKind(enum.Enum):
    """Foot-floor law of the four contact points."""

    IMPACT = "impact"
    MEGLAN = "meglan"


@dataclass(frozen=True)
class ContactSpec:
    """A contact law and how it was obtained (``fit`` for IMPACT fitted to Meglan)."""

    kind: ContactKind
    law: ImpactContact | MeglanContact
    fit: ImpactFit | None = None

    def describe(self) -> dict:
        """Parameters for the summary (SI units)."""
        out = {"model": self.kind.value, **{k: v for k, v in vars(self.law).items()
                                            if k not in ("friction", "slip_transition")}}
        if self.fit is not None:
            out |= {"fitted_to_meglan_over_m": self.fit.depth,
                    "fit_rms_stiffness_n": self.fit.stiffness_rms,
                    "fit_rms_damping_n_s_per_m": self.fit.damping_rms}
        return out


@dataclass(frozen=True)
class KneeSpec:
    """Knees driven by a moment (empty: none) and the moment's source."""

    sides: tuple[str, ...] = ("left",)
    moment: KneeMoment = KneeMoment.MODEL


@dataclass(frozen=True)
class Gait7Variant:
    """A compared run; None fields keep the main run's setting."""

    name: str
    contact: ContactSpec | None = None
    knee: KneeSpec | None = None
    passive: PassiveJoint | None = None


@dataclass(frozen=True)
class Gait7Spec:
    """gait7 contact simulation on a measured trial (thesis 2.3.1, 2.4)."""

    integrator: IntegratorOptions
    contact: ContactSpec
    trial: str = BUNDLED
    start: float = 0.62
    duration: float = 1.23
    mass: float = 72.6
    height: float = 1.8034
    ground_z: float = -0.0075
    knee: KneeSpec = KneeSpec()
    passive: PassiveJoint = field(default_factory=PassiveJoint)
    fall: FallLimit = GAIT7_FALL
    variants: tuple[Gait7Variant, ...] = ()
    stick_interval: float = 0.1
    source: str = ""


def parse_contact(sub: Table) -> ContactSpec:
    """[contact]: IMPACT given or fitted to Meglan, or Meglan itself."""
    sub.check_keys(("model", "fit_depth", "stiffness", "damping", "damping_depth",
                    "meglan_a", "meglan_b"))
    kind = sub.choice("model", ContactKind, "impact")
    meglan = MeglanContact(a=sub.number("meglan_a", 4.658e10, low=1.0, unit="N/m^4"),
                           b=sub.number("meglan_b", 9.719e10, low=0.0, unit="N s/m^5"))
    if kind is ContactKind.MEGLAN:
        return ContactSpec(kind, meglan)
    given = [k for k in ("stiffness", "damping", "damping_depth") if sub.has(k)]
    if given and len(given) < 3:
        raise sub.error(given[0], "give all of stiffness, damping, damping_depth, or none "
                                  "(then they are fitted to Meglan over fit_depth).")
    if given:
        law = ImpactContact(stiffness=sub.number("stiffness", low=1.0, unit="N/m"),
                            damping=sub.number("damping", low=0.0, unit="N s/m"),
                            damping_depth=sub.number("damping_depth", low=1e-5, high=0.1,
                                                     unit="m"))
        return ContactSpec(kind, law)
    fit = fit_impact_to_meglan(meglan, depth=sub.number("fit_depth", 0.01, low=1e-4,
                                                          high=0.1, unit="m"))
    return ContactSpec(kind, fit.contact, fit)


def parse_knee(sub: Table) -> KneeSpec:
    """[knee]: sides (list of right/left) and moment (model | measured)."""
    sub.check_keys(("sides", "moment"))
    sides = sub.get("sides", list, ["left"])
    if any(s not in SIDES for s in sides) or len(set(sides)) != len(sides):
        raise sub.error("sides", f"{sides!r}: give a list of distinct \"right\"/\"left\" "
                                 "([] for no knee-driven run).")
    return KneeSpec(tuple(sides), sub.choice("moment", KneeMoment, "model"))


def _passive_knee(table: Table) -> PassiveJoint:
    sub = table.table("passive")
    sub.check_keys(("knee",))
    if not sub.has("knee"):
        return PassiveJoint()
    return parse_passive(sub.data["knee"], where=f"{table.path}: {sub.prefix}knee")


def _variants(table: Table) -> tuple[Gait7Variant, ...]:
    items = table.data.get("variants", [])
    if not isinstance(items, list):
        raise table.error("variants", "expected an array of tables [[variants]].")
    out = []
    for i, item in enumerate(items):
        sub = Table(item, table.path, table.text, f"variants.{i}.")
        sub.check_keys(("name", "contact", "knee", "passive"))
        out.append(Gait7Variant(
            name=sub.get("name", str),
            contact=parse_contact(sub.table("contact")) if sub.has("contact") else None,
            knee=parse_knee(sub.table("knee")) if sub.has("knee") else None,
            passive=_passive_knee(sub) if sub.has("passive") else None))
    return tuple(out)


def parse_gait7(table: Table, integrator: IntegratorOptions, source: str) -> Gait7Spec:
    """The spec of a ``kind = "gait7"`` problem table (InputError names file/key/line)."""
    table.check_keys(("kind", "integrator", "trial", "model", "contact", "knee", "passive",
                      "fall", "output", "variants"))
    trial = table.table("trial")
    trial.check_keys(("source", "start", "duration"))
    name = bundled_source(trial)
    model = table.table("model")
    model.check_keys(("mass", "height", "ground_z"))
    fall = table.table("fall")
    fall.check_keys(("knee_deviation_deg", "hat_drop"))
    out = table.table("output")
    out.check_keys(("stick_interval",))
    return Gait7Spec(
        integrator=integrator, contact=parse_contact(table.table("contact")), trial=name,
        start=trial.number("start", 0.62, low=0.0, unit="s"),
        duration=trial.number("duration", 1.23, low=0.01, high=30.0, unit="s"),
        mass=model.number("mass", 72.6, low=1.0, high=500.0, unit="kg"),
        height=model.number("height", 1.8034, low=0.3, high=3.0, unit="m"),
        ground_z=model.number("ground_z", -0.0075, low=-1.0, high=1.0, unit="m"),
        knee=parse_knee(table.table("knee")), passive=_passive_knee(table),
        fall=FallLimit(
            joint_deviation_deg=fall.number("knee_deviation_deg", 30.0, low=0.1, high=180.0,
                                           unit="deg"),
            base_drop=fall.number("hat_drop", 0.1, low=1e-3, high=2.0, unit="m")),
        variants=_variants(table),
        stick_interval=out.number("stick_interval", 0.1, low=0.001, high=1.0, unit="s"),
        source=source)
