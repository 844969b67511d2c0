"""Window sensitivity of the passive fits: the same fit over other quiet windows.

Which part of swing is free of muscle activity is an assumption: the hamstrings brake knee
extension in terminal swing and tibialis anterior holds the foot up throughout swing
(Perry & Burnfield 2010, Gait Analysis, ch. 4-5). A passive parameter is a tissue property
only if it does not depend on that choice, so every passive fit is repeated over the quiet
windows a user could defend (:data:`DEFENSIBLE_WINDOWS`, or the problem file's
``window_sensitivity``) beside the user's own, and a parameter whose value over another
window lies outside the main fit's 95 % interval is reported ``window_dependent``
(:func:`~predgait.problems.identifiability.mark_window_dependent`).
"""

from __future__ import annotations

from collections.abc import Callable

from predgait.errors import InputError, SolveFailed
from predgait.problemfile import Table

#: Quiet windows, % gait cycle: mid swing (73-87 %), to the end of knee extension before
#: the hamstrings brake it (73-95 %), and the whole of mid and terminal swing (73-100 %)
#: (Perry & Burnfield 2010, ch. 4).
DEFENSIBLE_WINDOWS = ((73.0, 87.0), (73.0, 95.0), (73.0, 100.0))
KEY = "window_sensitivity"


def parse_windows(table: Table) -> tuple[tuple[float, float], ...]:
    """The ``window_sensitivity`` key: [start, end] pairs in % gait cycle ([] for none)."""
    windows = table.get(KEY, list, [list(w) for w in DEFENSIBLE_WINDOWS])
    checked = []
    for window in windows:
        if not (isinstance(window, list) and len(window) == 2
                and all(isinstance(v, int | float) and not isinstance(v, bool) for v in window)
                and 0 <= window[0] < window[1] <= 100):
            raise table.error(KEY, f"{window!r}: give [start, end] pairs in % gait cycle with "
                                   "0 <= start < end <= 100, or [] for none.")
        checked.append((float(window[0]), float(window[1])))
    return tuple(checked)


def label(phases) -> str:
    """"73-87 %" (phases joined by ", ")."""
    return ", ".join(f"{a:g}-{b:g}" for a, b in phases) + " %"


def window_sensitivity(fit_over: Callable[[tuple], tuple], phases, windows, main: tuple
                       ) -> dict[str, dict]:
    """Window label -> fitted values (``joint.name`` -> SI) and ``statuses``, or ``failed``.

    Args:
        fit_over: phases (((start, end),)) -> (model, fit) over those quiet phases.
        phases: The user's quiet phases (the main fit).
        windows: The other windows, each one (start, end) pair.
        main: The main fit's (model, fit) (listed first, under the user's label).

    The ``statuses`` and ``intervals`` are each window's own verdicts and 95 % intervals
    from its Fisher information alone (no bootstrap): a parameter the main fit identifies
    but a defensible window does not rests on the samples that window leaves out.
    """
    table = {label(phases): _entry(*main)}
    for window in windows:
        if (window,) == tuple(phases):
            continue
        try:
            table[label((window,))] = _entry(*fit_over((window,)))
        except (InputError, SolveFailed) as exc:
            table[label((window,))] = {"failed": str(exc)}
    return table


def _entry(model, fit) -> dict:
    from predgait.problems.identifiability import assess

    reports = assess(model, fit, None)[0]
    keys = {p.key for p in model.fitted}
    return {**{p.key: fit.values[p.key] for p in model.fitted},
            "statuses": {r.key: r.status.value for r in reports if r.key in keys},
            "intervals": {r.key: list(r.interval95) if r.interval95 else None
                          for r in reports if r.key in keys}}


def window_lines(table: dict[str, dict], indent: str = "  ") -> list[str]:
    """What the CLI prints: one line per window (the first is the main fit)."""
    lines = [f"{indent}window sensitivity (the same fit over other quiet windows; a value "
             "outside the main 95 % interval makes that parameter window_dependent):"]
    for i, (name, values) in enumerate(table.items()):
        statuses = values.get("statuses", {})
        what = f"fit failed ({values['failed']})" if "failed" in values else ", ".join(
            f"{k} = {v:.4g}" + (f" ({statuses[k]})" if statuses.get(k, "identified")
                                != "identified" else "")
            for k, v in values.items() if k not in ("statuses", "intervals"))
        lines.append(f"{indent}  over {name}{' (this fit)' if i == 0 else ''}: {what}")
    return lines
