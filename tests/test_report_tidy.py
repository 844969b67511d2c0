"""Summaries hold JSON values only; numbers are printed with the precision of their unit."""

import enum
import json
import math
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from conftest import PYTHON_REPR, REPO
from predgait.problemfile import Table
from predgait.report.tidy import (
    aligned,
    format_quantity,
    json_ready,
    label_of,
    unit_of,
    write_summary,
)
from predgait.scenarios.edits import (
    AddMass,
    LockJoint,
    MoveCom,
    PassiveEdit,
    RangeOfMotion,
    ScaleLength,
    ScaleMass,
    edit_record,
    parse_edit,
)


class Colour(enum.Enum):
    RED = "red"


@dataclass(frozen=True)
class Pair:
    a: float
    b: Colour


def test_json_ready_converts_numpy_enums_dataclasses_and_non_finite():
    data = {"x": np.float64(0.1234567891), "n": np.int64(3), "v": np.array([1.0, np.nan]),
            "c": Colour.RED, "p": Pair(1.0, Colour.RED), "t": (1, 2), 4: math.inf}
    clean = json_ready(data)
    assert clean == {"x": 0.123457, "n": 3, "v": [1.0, None], "c": "red",
                     "p": {"a": 1.0, "b": "red"}, "t": [1, 2], "4": None}
    assert json.loads(json.dumps(clean)) == clean
    with pytest.raises(TypeError, match="object is not a JSON value"):
        json_ready({"bad": object()})


def test_write_summary_round_trips(tmp_path):
    path = tmp_path / "summary.json"
    written = write_summary(path, {"time_to_fall_s": np.float32(0.25), "edits": [
        PassiveEdit("knee", 100.0, 2.0, math.radians(10.0))]})
    assert json.loads(path.read_text()) == written
    assert written["edits"][0]["theta0"] == pytest.approx(0.174533)


@pytest.mark.parametrize("edit", [
    ScaleMass("thigh", 1.2), ScaleLength("foot", 0.9), MoveCom("shank", 0.01),
    AddMass("shank", 1.5, 0.4), LockJoint("knee", math.radians(20.0)),
    RangeOfMotion("ankle", math.radians(-10.0), math.radians(15.0)),
    PassiveEdit("knee", 100.0, 2.0, math.radians(10.0))])
def test_edit_record_is_the_scenario_table(edit):
    record = edit_record(edit)
    assert all(not isinstance(v, float) or math.isfinite(v) for v in record.values())
    back = parse_edit(Table(record, Path("scenario.toml"), ""))
    for name in edit.__dataclass_fields__:
        value = getattr(edit, name)
        assert getattr(back, name) == (pytest.approx(value) if isinstance(value, float)
                                       else value)


def test_repr_pattern_catches_reprs_and_spares_text():
    for text in ("PassiveEdit(joint='knee', k=1.0)", "None", "{'a': 1}", "[1, 2]",
                 "array([1., 2.])", "<Foo object at 0x7f>"):
        assert PYTHON_REPR.search(text), text
    for text in ("leg for 72.6 kg, 1.803 m (regressions)", "fell at 0.3 s (knee)",
                 "completed", "knee k=10 c=20"):
        assert not PYTHON_REPR.search(text), text


def test_units_and_precision():
    assert format_quantity("time_to_fall_s", 0.351723) == "0.352 s"
    assert format_quantity("rms_deg", 10.5348) == "10.5 deg"
    assert format_quantity("peak_n_m_per_kg", -1.70958) == "-1.71 N m/kg"
    assert format_quantity("knee_extra_feedback_rms_n_m", 12.345) == "12.3 N m"
    assert format_quantity("time_to_fall_s", None) == "none"
    assert format_quantity("time_span_s", [0.62, 1.85]) == "0.620, 1.850 s"
    assert format_quantity("residual_mm", -0.01) == "0.0 mm"  # no "-0.0"
    assert format_quantity("objective", 1.234567e-5) == "1.235e-05"
    assert unit_of("kd_n_m_s_per_rad") == ("N m s/rad", 2)
    assert label_of("time_to_fall_s") == "time to fall"
    assert aligned([("a", "1"), ("long", "2")]) == "  a     1\n  long  2"


def test_no_plots_writes_no_image_and_imports_no_matplotlib(tmp_path):
    out = tmp_path / "collapse"
    code = ("import sys; from predgait.cli import main; "
            f"code = main(['simulate', {str(REPO / 'problems' / 'collapse.toml')!r}, '--out', "
            f"{str(out)!r}, '--set', 'collapse.duration=0.2', '--no-plots']); "
            "assert 'matplotlib' not in sys.modules, 'matplotlib imported'; sys.exit(code)")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            timeout=300)
    assert result.returncode == 0, result.stderr
    names = {p.name for p in out.iterdir()}
    assert {"summary.json", "states.sto"} <= names
    assert not [n for n in names if n.endswith((".png", ".gif"))]


def test_sweep_plots_heat_map_for_a_full_grid_else_outcome_curves(tmp_path):
    from types import SimpleNamespace

    from predgait.report.sweep_plots import save_sweep_plots

    def outcome(k, c, ok=True):
        return SimpleNamespace(ok=ok, point=SimpleNamespace(values={"edit.0.k": k,
                                                                    "edit.0.c": c}),
                               metrics={"knee_rms_change_deg": k / 10 + c})
    grid = [outcome(k, c) for k in (0.0, 50.0, 100.0) for c in (0.0, 2.0)]
    names = save_sweep_plots(grid, tmp_path, ["knee_rms_change_deg"],
                             baseline={"edit.0.k": 100.0, "edit.0.c": 2.0})
    assert names == ["heatmap_knee_rms_change_deg.png"]
    partial = [*grid[:-1], outcome(100.0, 2.0, ok=False)]
    names = save_sweep_plots(partial, tmp_path, ["knee_rms_change_deg"],
                             baseline={"edit.0.k": 100.0})
    assert names == ["outcome_vs_edit_0_k.png", "outcome_vs_edit_0_c.png"]
    assert all((tmp_path / n).stat().st_size > 5000 for n in names)


def test_report_of_an_unknown_summary_says_so(tmp_path):
    from predgait.report.html import build_report

    (tmp_path / "summary.json").write_text('{"status": "completed", "kind": "future"}')
    page = build_report(tmp_path)
    assert "No headline: summary.json is not in a layout" in page
