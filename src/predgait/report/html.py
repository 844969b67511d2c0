"""A self-contained HTML page for any predgait result folder.

Each result (the folder, or each sub-folder holding a summary, e.g. the demo's stages)
becomes a section: a headline block first (what was run, on which trial, status, the
numbers that matter with units, one sentence written from those numbers; see
:mod:`predgait.report.headline`), then the plots, then the details folded away (every
setting and provenance entry, per-column statistics of the STO/CSV tables). Images are
embedded as data URIs, so the page can be mailed or archived as one file; file paths are
shown by their file name only, never a folder (folder names such as "Patient Jane Doe
(DOB ...)/visit 2" must not leak into a shareable page; :func:`scrub_paths`), and the
page says so. ``anonymise=True`` also drops the trial and input file names (headlines,
provenance, table headers) and the result folder's name.
"""

from __future__ import annotations

import base64
import dataclasses
import html
import json
import re
from datetime import UTC, datetime
from pathlib import Path, PurePath

import numpy as np

from predgait import __version__
from predgait.errors import InputError
from predgait.report.headline import GOOD, Headline, headline, summary_file
from predgait.report.plot_labels import SIGN_CONVENTION, gif_caption, read_labels
from predgait.report.tidy import format_quantity, label_of, unit_of
from predgait.report.viewer import viewer_markup, viewer_script

_STYLE = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;margin:2rem auto;
max-width:1100px;color:#222;line-height:1.45;padding:0 1rem}
h1{border-bottom:2px solid #2a6f97;padding-bottom:.3rem}h2{color:#2a6f97;margin-top:2.4rem}
section{border-top:1px solid #ddd;margin-top:1.5rem}
table{border-collapse:collapse;margin:.4rem 0 1rem;font-size:.9rem}
td,th{border:1px solid #ccc;padding:.25rem .6rem;text-align:left;vertical-align:top}
th{background:#eef4f8;font-weight:600}td.num{text-align:right;font-variant-numeric:tabular-nums}
.headline{background:#f6f9fb;border-left:4px solid #2a6f97;padding:.6rem 1rem;margin:.8rem 0}
.headline table{margin:.4rem 0}.headline td{border:none;padding:.1rem .8rem .1rem 0}
.headline td.num{font-weight:600}.interpretation{font-size:1.02rem;margin:.5rem 0 0}
.figures{display:flex;flex-wrap:wrap;gap:1rem}figure{margin:.5rem 0;max-width:100%}
figure img{max-width:100%;border:1px solid #ddd}figcaption{font-size:.85rem;color:#555}
.meta{color:#666;font-size:.85rem}.badge{padding:.1rem .5rem;border-radius:.6rem;
font-size:.85rem;font-weight:600}.ok{background:#d8f0df;color:#1b5e20}
.finding{background:#fff1cc;color:#6d4c00}.bad{background:#fbd9dc;color:#8e0015}
.warnings{color:#6d4c00;margin:.4rem 0 0 1rem;padding:0}
details{margin:1rem 0;border:1px solid #ddd;border-radius:.3rem;padding:.3rem .8rem}
summary{cursor:pointer;color:#2a6f97;font-weight:600}
ol.walk li{margin:.4rem 0}.convention{background:#eef4f8;padding:.4rem .8rem;font-size:.92rem}
"""

#: Caption of a plot by its file stem (prefix match for heat maps and outcome plots).
CAPTIONS = {
    "angles": "Joint angles", "moments": "Joint moments", "powers": "Joint powers",
    "grf": "Ground reaction force", "stick": "Stick figures (darker = later)",
    "contributions": "Contributions to the joint accelerations (thesis Fig. 4.2.12)",
    "before_after": "Measured vs synthesized motion, before and after the optimisation",
    "convergence": "Ipopt convergence", "fullbody": "Whole-body runs against the measured motion",
    "knee": "Knee angles of the knee-driven runs (x = fall)",
    "rod_trajectories": "Rod coordinates, simulated and synthetic trial",
    "step_study": "Error against integrator step",
    "clinical_angles": "Clinical joint angles, left and right",
    "deviation": "Deviation from the measured motion: threshold band and fall",
    "active_passive": "Inverse-dynamics moment split into passive and active parts",
    "passive_literature": "Identified passive knee and ankle beside Riener & Edrich (1999) "
                          "at this trial's angles",
    "clinical_moments": "Clinical joint moments, left and right",
    "heatmap_": "Sweep outcome", "outcome_vs_": "Sweep outcomes against",
}
_ORDER = ("angles", "clinical_angles", "deviation", "moments", "clinical_moments", "powers",
          "grf", "fullbody", "knee", "before_after", "contributions", "stick")
_PATH = re.compile(r"(?<![\w.])(?:[A-Za-z]:)?(?:~|\.{1,2})?(?:[/\\][^\s;,'\"()<>|]+)+"
                   r"|(?<![\w./])[\w.-]+(?:/[\w.-]+)+\.[A-Za-z]\w{0,4}\b")


def _esc(value) -> str:
    return html.escape(str(value))


_SEGMENT = re.compile(r"[^;=\n\t]+")
_FILE_NAME = re.compile(r"[^\s/\\]+\.[A-Za-z]\w{0,5}\b")
_NAMED_FILE = re.compile(r"[^/\\\n]*?\.[A-Za-z]\w{0,5}\b")  # spaces allowed
_ROOTED = re.compile(r"\s*(?:[A-Za-z]:[/\\]|[/\\~]|\.{1,2}[/\\])")
#: What anonymised values are shown as.
ANONYMISED = "(anonymised)"


def scrub_paths(text: str) -> str:
    """Every file path in ``text`` replaced by its last part (no folder is shown).

    ``text`` is cut at ``;``, ``=``, tabs and new lines (provenance lists such as
    ``trial=<path>; grf=<path>``); in each piece, everything up to the last folder
    separator goes when a file name follows it or the piece starts as a path (``/``,
    ``~``, ``./``, a drive letter), so folder names with spaces or brackets go too; other
    pieces lose the folders of the paths they contain.
    """
    def piece(match: re.Match) -> str:
        part = match.group(0)
        cut = max(part.rfind("/"), part.rfind("\\"))
        if cut < 0:
            return part
        lead = part[:len(part) - len(part.lstrip())]
        if not part[cut + 1:].strip():  # a folder path: ".../visit 2/"
            return f"{lead}(folder){part[len(part.rstrip()):]}"
        if _NAMED_FILE.match(part, cut + 1) or _ROOTED.match(part):
            return lead + part[cut + 1:]
        return _PATH.sub(lambda m: PurePath(m.group(0).replace("\\", "/")).name or "/", part)

    return _SEGMENT.sub(piece, text)


def _anonymised(value, key: str = ""):
    """``value`` (a summary's JSON) with provenance and file names replaced."""
    if isinstance(value, dict):
        return {k: _anonymised(v, "provenance" if key == "provenance" else k)
                for k, v in value.items()}
    if isinstance(value, list):
        return [_anonymised(v, key) for v in value]
    if isinstance(value, str) and (key == "provenance" or key in ("trial", "subject", "source")
                                   or _FILE_NAME.search(value)):
        return ANONYMISED
    return value


def _value(key: str, value) -> str:
    """A JSON value of the field ``key`` as HTML text, with unit and precision."""
    if value is None:
        return "–"
    if isinstance(value, str):
        return _esc(scrub_paths(value))
    if isinstance(value, list):
        if value and all(isinstance(v, int | float) and not isinstance(v, bool)
                         for v in value):
            if len(value) > 12:
                return _esc(f"{len(value)} values, {format_quantity(key, min(value))} .. "
                            f"{format_quantity(key, max(value))}")
            return _esc(format_quantity(key, value))
        if all(isinstance(v, dict) for v in value) and value:
            return _records(value)
        return _esc(", ".join(scrub_paths(str(v)) for v in value) or "–")
    if isinstance(value, dict):
        return _fields(value)
    return _esc(format_quantity(key, value))


def _fields(data: dict) -> str:
    rows = "".join(f"<tr><th>{_esc(k.replace('_', ' '))}</th><td>{_value(k, v)}</td></tr>"
                   for k, v in data.items())
    return f"<table>{rows}</table>"


def _records(rows: list[dict]) -> str:
    keys = list(dict.fromkeys(k for row in rows for k in row))
    head = "".join(f"<th>{_esc(k.replace('_', ' '))}</th>" for k in keys)
    body = "".join("<tr>" + "".join(f"<td>{_value(k, row.get(k))}</td>" for k in keys)
                   + "</tr>" for row in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def _read_table(path: Path) -> tuple[list[str], np.ndarray, list[str]]:
    """Column names, numeric data and header comment lines of an STO/MOT/CSV file."""
    lines = path.read_text().splitlines()
    header: list[str] = []
    start = 0
    if path.suffix.lower() in (".sto", ".mot"):
        for number, line in enumerate(lines):
            if line.strip().lower() == "endheader":
                start = number + 1
                break
            header.append(line)
        sep = "\t"
    else:
        while start < len(lines) and lines[start].startswith("#"):
            header.append(lines[start].lstrip("# "))
            start += 1
        sep = ","
    names = [n.strip() for n in lines[start].split(sep)]
    rows = [line.split(sep) for line in lines[start + 1:] if line.strip()]
    data = np.array([[float(x) for x in row] for row in rows]) if rows else np.zeros((0, 1))
    return names, data, header


def _table_summary(path: Path, anonymise: bool = False) -> str:
    try:
        names, data, header = _read_table(path)
    except (ValueError, IndexError, UnicodeDecodeError):
        return f"<p class='meta'>{_esc(path.name)}: not a numeric table.</p>"
    if data.size == 0:
        return f"<p class='meta'>{_esc(path.name)}: no rows.</p>"
    meta = "; ".join(h for h in header if ("=" in h or "unit" in h.lower())
                     and not (anonymise and "provenance" in h.lower()))[:600]
    rows = "".join(
        f"<tr><td>{_esc(name)}</td><td class='num'>{np.nanmin(col):.4g}</td>"
        f"<td class='num'>{np.nanmax(col):.4g}</td><td class='num'>{np.nanmean(col):.4g}</td>"
        "</tr>" for name, col in zip(names, data.T, strict=False))
    return (f"<h4>{_esc(path.name)}</h4><p class='meta'>{data.shape[0]} rows. "
            f"{_esc(scrub_paths(meta))}</p><table><tr><th>column</th><th>min</th>"
            f"<th>max</th><th>mean</th></tr>{rows}</table>")


def _caption(path: Path) -> str:
    stem = path.stem
    if path.suffix == ".gif":
        return gif_caption(path) or "Stick figure, sagittal plane (animation)"
    for key, text in CAPTIONS.items():
        if stem == key or (key.endswith("_") and stem.startswith(key)):
            extra = stem[len(key):] if key.endswith("_") else ""
            if extra and key == "heatmap_":
                unit = unit_of(extra)
                extra = label_of(extra) + (f" ({unit[0]})" if unit else "")
            extra = extra.replace("_", " ")
            return f"{text}{': ' + extra if extra else ''}"
    return stem.replace("_", " ")


def _figures(folder: Path) -> str:
    def rank(path: Path) -> tuple:
        stem = path.stem
        first = next((i for i, key in enumerate(_ORDER) if stem.startswith(key)), len(_ORDER))
        return (path.suffix == ".gif", first, stem)

    parts = []
    for path in sorted([*folder.glob("*.png"), *folder.glob("*.gif")], key=rank):
        mime = "image/gif" if path.suffix == ".gif" else "image/png"
        data = base64.b64encode(path.read_bytes()).decode("ascii")
        caption = _caption(path)
        x_axis = read_labels(path)[0] if path.suffix == ".png" else []
        stated = f" (x: {'; '.join(x_axis)})" if x_axis else ""
        parts.append(f"<figure><img alt='{_esc(caption)}' src='data:{mime};base64,{data}'>"
                     f"<figcaption>{_esc(caption)}{_esc(stated)} — {_esc(path.name)}"
                     "</figcaption></figure>")
    return f"<div class='figures'>{''.join(parts)}</div>" if parts else ""


def _badge(head: Headline) -> str:
    css = "ok" if head.status in GOOD else "finding" if head.ok else "bad"
    text = {"event": "stopped by an event (fall)", "fell": "fell"}.get(head.status,
                                                                       head.status)
    return f"<span class='badge {css}'>{_esc(text)}</span>"


def _headline_block(head: Headline) -> str:
    numbers = "".join(f"<tr><td>{_esc(label)}</td><td class='num'>{_esc(value)}</td></tr>"
                      for label, value in head.numbers)
    return (f"<div class='headline'><p>Trial: <b>{_esc(head.trial)}</b> · status "
            f"{_badge(head)}</p>" + (f"<table>{numbers}</table>" if numbers else "")
            + (f"<p class='interpretation'>{_esc(head.sentence)}</p>" if head.sentence else "")
            + (f"<p class='meta'>{_esc(head.note)}</p>" if head.note else "")
            + ("<ul class='warnings'>" + "".join(f"<li>warning: {_esc(w)}</li>"
                                                 for w in head.warnings) + "</ul>"
               if head.warnings else "")
            + "</div>")


def _details(folder: Path, anonymise: bool = False) -> str:
    parts = []
    path = summary_file(folder)
    if path is not None:
        try:
            data = json.loads(path.read_text())
            data = _anonymised(data) if anonymise else data
            parts.append(f"<h4>{_esc(path.name)}</h4>" + (_fields(data) if isinstance(
                data, dict) else _value("", data)))
        except (json.JSONDecodeError, UnicodeDecodeError):
            parts.append(f"<p class='bad'>{_esc(path.name)}: invalid JSON.</p>")
    tables = sorted([*folder.glob("*.sto"), *folder.glob("*.mot")])
    parts.extend(_table_summary(p, anonymise) for p in tables)
    if not parts:
        return ""
    return ("<details><summary>Details: all settings, provenance and the data files"
            f"</summary>{''.join(parts)}</details>")


def _result_folders(folder: Path) -> list[Path]:
    """The folder and its sub-folders (name order) that hold a summary or plots."""
    found = []
    for path in [folder, *sorted(p for p in folder.rglob("*") if p.is_dir())]:
        if any(part.startswith(".") for part in path.relative_to(folder).parts):
            continue
        if summary_file(path) or any(path.glob("*.png")):
            found.append(path)
    return found


def _section(folder: Path, root: Path, number: int | None, anonymise: bool = False
             ) -> tuple[str, Headline]:
    head = headline(folder) or Headline(folder.name.replace("_", " "), "-", "-")
    if anonymise:
        head = dataclasses.replace(head, trial=ANONYMISED)
    title = f"{number}. {head.title}" if number is not None else head.title
    anchor = f"r{number or 0}"
    where = folder.relative_to(root).as_posix() if folder != root else "."
    viewer = ""
    if (folder / "viewer.json").is_file():
        viewer = viewer_markup((folder / "viewer.json").read_text(), _esc(head.title))
    return (f"<section id='{anchor}'><h2>{_esc(title)}</h2>"
            f"<p class='meta'>folder {_esc(where)}</p>{_headline_block(head)}"
            f"{_figures(folder)}{viewer}{_details(folder, anonymise)}</section>"), head


def build_report(result_dir: str | Path, *, title: str | None = None,
                 source: str | None = None, intro: str | None = None,
                 anonymise: bool = False) -> str:
    """The HTML text of the report of a result folder.

    Args:
        result_dir: A predgait ``--out`` folder (its sub-folders with results become
            numbered sections, e.g. the demo's stages).
        title: Page title (default: "predgait report: <folder name>").
        source: Name to show for the folder (default: its name; never a full path).
        intro: A paragraph shown under the title.
        anonymise: Drop the trial and input file names and the result folder's name.

    Raises:
        InputError: The folder does not exist or holds no result file.
    """
    folder = Path(result_dir)
    if not folder.is_dir():
        raise InputError(f"{folder}: result folder not found; give the --out folder of a "
                         "predgait command.")
    results = _result_folders(folder)
    if not results:
        raise InputError(f"{folder}: no results (summary.json, solution.json or .png) in "
                         "this folder.")
    stamp = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    name = PurePath(source).name if source else folder.resolve().name
    name = ANONYMISED if anonymise else name
    title = title or f"predgait report: {name}"
    numbered = len(results) > 1
    sections, heads = [], []
    for number, result in enumerate(results, start=1):
        text, head = _section(result, folder, number if numbered else None, anonymise)
        sections.append(text)
        heads.append(head)
    overview = ""
    if numbered:  # the walk-through: each step's sentence, linked to its section
        items = "".join(f"<li><a href='#r{i}'>{_esc(h.title)}</a>: {_esc(h.sentence)}</li>"
                        for i, h in enumerate(heads, start=1))
        overview = f"<h2>At a glance</h2><ol class='walk'>{items}</ol>"
    return ("<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
            f"<title>{_esc(title)}</title><style>{_STYLE}</style></head><body>"
            f"<h1>{_esc(title)}</h1><p class='meta'>predgait {__version__}, {stamp}, "
            f"result folder {_esc(name)}. "
            + ("Anonymised: trial, input file and folder names are left out."
               if anonymise else "Files are named by their file name only, without folders.")
            + "</p>"
            + f"<p class='convention'>{_esc(SIGN_CONVENTION)}</p>"
            + (f"<p>{_esc(intro)}</p>" if intro else "")
            + overview + "".join(sections)
            + (f"<script>{viewer_script()}</script>" if "pg-viewer" in "".join(sections)
               else "") + "</body></html>\n")
