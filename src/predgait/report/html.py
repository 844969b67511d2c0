"""A self-contained HTML page for any predgait result folder.

Images (PNG) are embedded as base64 data URIs, JSON summaries become tables, and STO/CSV
tables are summarised per column (unit, minimum, maximum, mean) with a link-free preview,
so the page can be mailed or archived as one file. Sub-folders (e.g. the demo's stages)
become sections, in name order.
"""

from __future__ import annotations

import base64
import html
import json
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from predgait import __version__
from predgait.errors import InputError

_STYLE = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;margin:2rem auto;
max-width:1100px;color:#222;line-height:1.45;padding:0 1rem}
h1{border-bottom:2px solid #2a6f97;padding-bottom:.3rem}h2{color:#2a6f97;margin-top:2.2rem}
h3{margin-bottom:.3rem}table{border-collapse:collapse;margin:.5rem 0 1rem;font-size:.9rem}
td,th{border:1px solid #ccc;padding:.25rem .6rem;text-align:left;vertical-align:top}
th{background:#eef4f8}td.num{text-align:right;font-variant-numeric:tabular-nums}
figure{margin:1rem 0}figure img{max-width:100%;border:1px solid #ddd}
figcaption{font-size:.85rem;color:#555}.meta{color:#666;font-size:.85rem}
.status-bad{color:#b00020;font-weight:bold}.status-ok{color:#1b7f3b;font-weight:bold}
"""


def _esc(value) -> str:
    return html.escape(str(value))


def _format_value(value) -> str:
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, list) and len(value) > 12:
        return _esc(f"[{len(value)} values]")
    if isinstance(value, dict | list):
        return _esc(json.dumps(value, default=str)[:400])
    return _esc(value)


def _json_table(data: dict) -> str:
    rows = []
    for key, value in data.items():
        if isinstance(value, dict) and all(not isinstance(v, dict | list) for v in value.values()):
            inner = "".join(f"<tr><th>{_esc(k)}</th><td class='num'>{_format_value(v)}</td></tr>"
                            for k, v in value.items())
            rows.append(f"<tr><th>{_esc(key)}</th><td><table>{inner}</table></td></tr>")
            continue
        css = ""
        if key == "status":
            good = str(value).lower() in ("completed", "solved", "ok", "success", "converged")
            css = " class='status-ok'" if good else " class='status-bad'"
        rows.append(f"<tr><th>{_esc(key)}</th><td{css}>{_format_value(value)}</td></tr>")
    return "<table>" + "".join(rows) + "</table>"


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


def _table_summary(path: Path) -> str:
    try:
        names, data, header = _read_table(path)
    except (ValueError, IndexError, UnicodeDecodeError):
        return f"<p class='meta'>{_esc(path.name)}: not a numeric table.</p>"
    if data.size == 0:
        return f"<p class='meta'>{_esc(path.name)}: no rows.</p>"
    meta = "; ".join(h for h in header if "=" in h or "unit" in h.lower())[:600]
    rows = "".join(
        f"<tr><td>{_esc(name)}</td><td class='num'>{np.nanmin(col):.5g}</td>"
        f"<td class='num'>{np.nanmax(col):.5g}</td><td class='num'>{np.nanmean(col):.5g}</td></tr>"
        for name, col in zip(names, data.T, strict=False))
    return (f"<h3>{_esc(path.name)}</h3><p class='meta'>{data.shape[0]} rows. {_esc(meta)}</p>"
            "<table><tr><th>column</th><th>min</th><th>max</th><th>mean</th></tr>"
            f"{rows}</table>")


def _figure(path: Path) -> str:
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    caption = path.stem.replace("_", " ")
    return (f"<figure><img alt='{_esc(caption)}' src='data:image/png;base64,{data}'>"
            f"<figcaption>{_esc(path.name)}</figcaption></figure>")


def _section(folder: Path, title: str, level: int) -> str:
    parts = [f"<h{level}>{_esc(title)}</h{level}>"]
    for path in sorted(folder.glob("*.json")):
        try:
            data = json.loads(path.read_text())
        except (json.JSONDecodeError, UnicodeDecodeError):
            parts.append(f"<p class='status-bad'>{_esc(path.name)}: invalid JSON.</p>")
            continue
        parts.append(f"<h3>{_esc(path.name)}</h3>")
        parts.append(_json_table(data) if isinstance(data, dict) else _format_value(data))
    for path in sorted(folder.glob("*.png")):
        parts.append(_figure(path))
    for path in sorted([*folder.glob("*.sto"), *folder.glob("*.mot")]):
        parts.append(_table_summary(path))
    gifs = sorted(folder.glob("*.gif"))
    for path in gifs:
        data = base64.b64encode(path.read_bytes()).decode("ascii")
        parts.append(f"<figure><img alt='animation' src='data:image/gif;base64,{data}'>"
                     f"<figcaption>{_esc(path.name)}</figcaption></figure>")
    for sub in sorted(p for p in folder.iterdir() if p.is_dir()):
        if not any(sub.rglob("*.json")) and not any(sub.rglob("*.png")):
            continue  # e.g. the problem files used
        parts.append(_section(sub, sub.name.replace("_", " "), min(level + 1, 3)))
    return "\n".join(parts)


def build_report(result_dir: str | Path, *, title: str | None = None,
                 source: str | None = None) -> str:
    """The HTML text of the report of a result folder (``source``: name to show for it).

    Raises:
        InputError: The folder does not exist or holds no result file.
    """
    folder = Path(result_dir)
    if not folder.is_dir():
        raise InputError(f"{folder}: result folder not found; give the --out folder of a "
                         "predgait command.")
    if not any(folder.rglob("*.json")) and not any(folder.rglob("*.png")):
        raise InputError(f"{folder}: no results (.json or .png) in this folder.")
    stamp = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    title = title or f"predgait report: {folder.resolve().name}"
    body = _section(folder, title, 1)
    return ("<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
            f"<title>{_esc(title)}</title><style>{_STYLE}</style></head><body>"
            f"<p class='meta'>predgait {__version__}, {stamp}, from "
            f"{_esc(source or folder.resolve())}</p>"
            f"{body}</body></html>\n")
