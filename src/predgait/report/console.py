"""Short aligned text summaries of result folders, for the terminal.

Numbers carry their unit and the precision it deserves (:mod:`predgait.report.tidy`):
angles 0.1 deg, times 1 ms, forces 1 N.
"""

from __future__ import annotations

import math

from predgait.report.tidy import aligned, format_number

RAD_TO_DEG = 57.29577951308232


#: What each parameter status means, as printed (problems.identifiability.Status values).
STATUS_WORDS = {"identified": "identified",
                "consistent_with_zero": "consistent with zero",
                "at_bound": "at its bound",
                "window_dependent": "window-dependent (not identified)",
                "not_identifiable": "not identifiable"}


def parameter_lines(parameters: dict[str, dict], *, indent: str = "  ") -> list[str]:
    """One line per fitted parameter of a ``solution.json`` (fixed ones left out).

    Value and unit (angles also in deg), the 95 % interval and the status in words, the
    reasons or note, then what the parameter is; first, how the intervals were made.
    """
    lines = []
    fitted = [r for r in parameters.values() if r["status"] != "fixed"]
    method = next((r.get("interval_method") for r in fitted if r.get("interval_method")), "")
    if method:
        lines.append(f"{indent}95 % intervals: {method}")
    for key, report in parameters.items():
        if report["status"] == "fixed":
            continue
        unit = report["unit"]
        head = f"{indent}{key} = {report['value']:.4g} {unit}"
        if unit == "rad":
            head += f" ({math.degrees(report['value']):.1f} deg)"
        words = STATUS_WORDS.get(report["status"], report["status"])
        if report["interval95"] is None:
            line = f"{head}: {words}"
        else:
            low, high = report["interval95"]
            interval = f"[{low:.4g}, {high:.4g}]"
            if unit == "rad":
                interval += f" ([{math.degrees(low):.1f}, {math.degrees(high):.1f}] deg)"
            line = f"{head}, 95 % interval {interval}: {words}"
        detail = "; ".join(report.get("reasons") or ()) or report.get("note") or ""
        line += f" ({detail})" if detail else ""
        lines.append(line)
        if report.get("meaning"):
            lines.append(f"{indent}    ({key.split('.')[-1]}: {report['meaning']})")
    return lines


def cutoff_lines(sensitivity: dict[str, dict]) -> list[str]:
    """The same fit at other marker cut-offs (Hz -> parameter values, or why it failed)."""
    return [f"  at {cutoff} Hz: fit failed ({values['failed']})" if "failed" in values
            else f"  at {cutoff} Hz: " + ", ".join(f"{k} = {v:.4g}" for k, v in values.items())
            for cutoff, values in sensitivity.items()]


def table(rows: list[dict[str, str]], *, indent: str = "  ") -> str:
    """Rows of cells as aligned columns under a header (the keys of the first row)."""
    if not rows:
        return ""
    header = list(dict.fromkeys(k for row in rows for k in row))
    cells = [header] + [[row.get(k, "") for k in header] for row in rows]
    widths = [max(len(line[i]) for line in cells) for i in range(len(header))]
    return "\n".join(indent + "  ".join(c.ljust(w) for c, w in zip(line, widths, strict=True))
                     .rstrip() for line in cells)


def _time(value) -> str:
    return "-" if value is None else f"{value:.3f} s"


def _run_cells(row: dict, summary: dict) -> dict[str, str]:
    cells = {"run": str(row.get("name") or row.get("frame")), "status": str(row["status"])}
    if "time_to_fall_s" in row or summary["kind"] != "rod":
        cells["fall"] = _time(row.get("time_to_fall_s"))
    if row.get("fall_criterion"):
        cells["what fell"] = row["fall_criterion"]
    for name, value in (row.get("rms_deg") or {}).items():
        cells[f"RMS {name}"] = f"{format_number(value, 1)} deg"
    if "time_to_threshold_s" in row:
        cells[f"> {summary.get('threshold_deg', 5):g} deg at"] = _time(row["time_to_threshold_s"])
    if isinstance(row.get("rms"), dict):  # rod: pitch and position error
        cells["RMS theta"] = f"{row['rms']['base_pitch'] * RAD_TO_DEG:.4f} deg"
        cells["RMS x"] = f"{row['rms']['base_x'] * 1000:.3f} mm"
    grf = row.get("grf") or {}  # gait7: vertical GRF vs the plates, per side
    if grf:
        sides = "/".join(side[0].upper() for side in grf)
        cells[f"GRF r {sides}"] = "/".join(f"{g['correlation']:.2f}" for g in grf.values())
        cells[f"GRF RMS {sides}"] = "/".join(f"{g['rms_n']:.0f}" for g in grf.values()) + " N"
    knee = row.get("knee_run")
    if knee:
        cells["knee-driven"] = f"{knee['status']} ({knee['moment']} moment)"
    return cells


def simulate_text(summary: dict, out) -> str:
    """What ``predgait simulate`` prints: the status line and one aligned row per run."""
    lines = [f"wrote {out} ({summary['kind']}): status {summary['status']}",
             f"  time to fall: {_time(summary.get('time_to_fall_s')).replace('-', 'none')}"]
    rows = [_run_cells(row, summary) for row in summary.get("runs", [])]
    if rows:
        lines.append(table(rows))
    return "\n".join(lines)


def foot_flat_text(feet: dict | None) -> str | None:
    """One line on the foot-flat calibration (``provenance.foot_flat_calibration``)."""
    if not feet:
        return None
    return "; ".join(
        f"{side} {f}" if isinstance(f, str) else
        f"{side} pitch {f['pitch_corrected_deg']:+.1f} roll {f['roll_corrected_deg']:+.1f} "
        f"deg, sole {1000 * f['sole_depth_m']:.0f} mm below the ankle"
        for side, f in feet.items())


def inverse3d_text(summary: dict, out) -> str:
    """What ``predgait inverse --model fullbody`` prints: IK fit and pelvis residuals."""
    ik = summary.get("ik_rms_m") or {}
    trusted = summary.get("ik_trusted_rms_m") or {}
    force = summary.get("pelvis_residual_force_N") or {}
    moment = summary.get("pelvis_residual_moment_Nm") or {}
    rows = [("frames", str(summary.get("frames"))),
            ("IK marker error (RMS)", f"mean {1000 * ik.get('mean', float('nan')):.1f} mm, "
                                      f"max {1000 * ik.get('max', float('nan')):.1f} mm"),
            *[(f"  {name.replace('_', ' ')}", f"RMS {1000 * rms:.1f} mm")
              for name, rms in (summary.get("ik_rms_by_region_m") or {}).items()
              if rms is not None],
            *([("IK marker error, trusted markers (weight > 0.5)",
                f"mean {1000 * trusted['mean']:.1f} mm, max {1000 * trusted['max']:.1f} mm")]
              if trusted.get("mean") is not None else []),
            ("frames flagged by IK", str(len(summary.get("ik_flagged_frames") or []))),
            ("pelvis residual force", f"RMS {force.get('rms', float('nan')):.1f} N, "
                                      f"max {force.get('max', float('nan')):.1f} N"),
            ("pelvis residual moment", f"RMS {moment.get('rms', float('nan')):.1f} N m, "
                                       f"max {moment.get('max', float('nan')):.1f} N m")]
    feet = foot_flat_text((summary.get("provenance") or {}).get("foot_flat_calibration"))
    if feet:
        rows.append(("feet levelled (foot flat)", feet))
    return f"3D inverse dynamics of the full body; wrote {out}/\n" + aligned(rows)
