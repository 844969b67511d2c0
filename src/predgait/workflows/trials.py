"""Where a problem's measured trial comes from: THE trial-source resolver.

A problem file's ``[trial]`` names ``source = "bundled:subject01"`` (the OpenSim subject01
walk shipped with predgait, :mod:`predgait.data.bundled`), optionally the analysed
``side`` and, for the leg, ``inverse_problem = FILE.toml`` (an ``inverse`` problem file
whose trial and options are used instead) or the inverse inputs themselves (``markers``,
``grf``, ``static``, ``mass``, ``height``, ``side``, ``model``, ``[trial.points]``,
``[trial.options]``: the keys of an inverse problem file, read by the same parser).
Every kind of problem resolves its trial here: the leg (re-synthesis, solve, passive
decomposition), gait7 and the whole body.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from predgait.data.events import Side
from predgait.dynamics.inverse_options import InverseOptions, bundled_source
from predgait.dynamics.inverse_trial import InverseResult
from predgait.problemfile import Table

SIDES = ("right", "left")


@dataclass(frozen=True)
class LegTrial:
    """The leg's measured trial: the bundled one or an inverse problem file's.

    Attributes:
        side: the analysed leg.
        inverse_problem: Path of an ``inverse`` problem file, or None (bundled subject01).
    """

    side: Side = Side.RIGHT
    inverse_problem: Path | None = None
    direct: InverseOptions | None = None

    def options(self) -> InverseOptions:
        """Inverse-dynamics options of this trial."""
        if self.direct is not None:
            return self.direct
        if self.inverse_problem is None:
            from predgait.dynamics.inverse_options import bundled_options

            return bundled_options(self.side)
        from predgait.problemfile import load_problem
        from predgait.workflows.inverse_io import options_from_problem

        return options_from_problem(load_problem(self.inverse_problem))

    def inverse(self) -> InverseResult:
        """Inverse dynamics of this trial (the bundled one cached)."""
        from predgait.dynamics.inverse_trial import bundled_inverse, run_inverse

        if self.inverse_problem is None and self.direct is None:
            return bundled_inverse(self.side)
        return run_inverse(self.options())


#: The keys of an inverse problem's ``[trial]`` that make a leg trial direct.
DIRECT_KEYS = ("markers", "grf", "static", "mass", "height", "model", "points", "options")


def leg_trial(table: Table) -> LegTrial:
    """The :class:`LegTrial` of a ``[trial]`` table.

    Keys: source, side, inverse_problem; or the inverse inputs directly (DIRECT_KEYS and
    side, see :func:`predgait.workflows.inverse_io.options_from_trial`).
    """
    direct = [key for key in DIRECT_KEYS if key in table.data]
    if direct:
        from predgait.workflows.inverse_io import options_from_trial

        for key in ("source", "inverse_problem"):
            if key in table.data:
                raise table.error(key, f"the trial is given directly ({', '.join(direct)}); "
                                       f"drop {key} or the direct inputs.")
        options = options_from_trial(table)
        return LegTrial(side=options.side, direct=options)
    table.check_keys(("source", "side", "inverse_problem"))
    bundled_source(table)
    side = table.get("side", str, "right")
    if side not in SIDES:
        raise table.error("side", f"'{side}' is not one of: {', '.join(SIDES)}.")
    return LegTrial(side=Side(side), inverse_problem=table.path_value("inverse_problem", None))


def bundled_fullbody_files(static: Path | None = None) -> tuple[tuple[Path, Path], Path, float,
                                                               float]:
    """The bundled walk for the whole body: (TRC, MOT), static TRC, mass kg, height m."""
    from predgait.data.bundled import bundled_path, subject_info

    folder = bundled_path("subject01_walk1")
    info = subject_info("subject01_walk1")
    return ((folder / "subject01_walk1.trc", folder / "subject01_walk1_grf.mot"),
            static or folder / "subject01_static.trc", info["mass"], info["height"])
