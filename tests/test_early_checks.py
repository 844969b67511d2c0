"""Bad inputs refused before the work, with readable messages (issue 29, item 9, and
the nested-key line number left from issue 28): a marker label with a space is refused
when read; a TRC longer than its plates is refused from its header, before the full
read; numbers in range messages read as written; nested unknown keys name their line."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

from cli_checks import one_error as _one_error
from predgait.cli import main
from predgait.data import read_trc
from predgait.errors import InputError
from predgait.problemfile import load_problem

REPO = Path(__file__).resolve().parents[1]
BUNDLED = REPO / "src" / "predgait" / "datasets" / "subject01_walk1"
TRC = BUNDLED / "subject01_walk1.trc"




@pytest.fixture
def lab(tmp_path, monkeypatch):
    """The bundled subject01 files and an inverse problem reading walk.trc."""
    for path in BUNDLED.glob("subject01_*"):
        shutil.copy(path, tmp_path / path.name)
    shutil.copy(TRC, tmp_path / "walk.trc")
    problem = (REPO / "problems" / "inverse_subject01.toml").read_text().replace(
        "bundled:subject01_walk1/subject01_walk1.trc", "walk.trc").replace(
        "bundled:subject01_walk1/", "")
    (tmp_path / "inverse.toml").write_text(problem)
    monkeypatch.chdir(tmp_path)
    return tmp_path


def test_marker_label_with_a_space_is_refused_when_read(lab, capsys):
    lines = TRC.read_text().split("\n")
    lines[3] = lines[3].replace("L.ASIS", "L ASIS", 1)
    (lab / "walk.trc").write_text("\n".join(lines))
    with pytest.raises(InputError, match=r"walk.trc: line 4: marker label 'L ASIS' contains "
                                         r"white space; rename it \(e.g. 'L_ASIS'\)"):
        read_trc(lab / "walk.trc")
    message = _one_error(capsys, main(["inverse", "inverse.toml", "--out", "res"]),
                         "walk.trc", "'L ASIS'")
    assert ".predgait-" not in message and not (lab / "res").exists()


def _long_trc(path: Path, copies: int) -> float:
    """subject01's TRC repeated ``copies`` times end to end; returns its last time, s."""
    lines = TRC.read_text().splitlines()
    header, rows = lines[:6], [r for r in lines[6:] if r.strip()]
    step, out = 1 / 60, []
    for _ in range(copies):
        for row in rows:
            fields = row.split("\t")
            frame = len(out) + 1
            fields[0], fields[1] = str(frame), f"{(frame - 1) * step:.6f}"
            out.append("\t".join(fields))
    header[2] = re.sub(r"\s+151\t", f"\t{len(out)}\t", header[2], count=1)
    header[2] = re.sub(r"\t\s*151$", f"\t{len(out)}", header[2])
    path.write_text("\n".join(header + out) + "\n")
    return (len(out) - 1) * step


def test_trial_longer_than_its_plates_is_refused_before_the_full_read(lab, capsys,
                                                                      monkeypatch):
    from predgait.data.trc import trc_span

    last = _long_trc(lab / "walk.trc", 12)
    start, end, frames = trc_span(lab / "walk.trc")
    assert start == 0.0 and end == pytest.approx(last) and frames == 12 * 151

    def no_full_read(*args, **kwargs):
        raise AssertionError("the whole TRC was read before the plates were checked")

    for reader in ("leg_measurements", "leg_static"):   # the walk's and the static's
        monkeypatch.setattr(f"predgait.dynamics.{reader}.read_trc", no_full_read)
    message = _one_error(capsys, main(["inverse", "inverse.toml", "--out", "res"]),
                         "covers t = 0.0000..2.5000 s", f"walk.trc run 0.0000..{last:.4f} s")
    assert message.startswith("predgait: error: subject01_walk1_grf.mot: force plate")


def test_trial_within_its_plates_passes_the_header_check(lab):
    assert main(["inverse", "inverse.toml", "--out", "res", "--no-plots"]) == 0
    assert (lab / "res" / "summary.json").is_file()


def test_range_message_reads_the_numbers_as_written(tmp_path, capsys, monkeypatch):
    problem = (REPO / "problems" / "knee_fit.toml").read_text().replace(
        "nodes = 100 ", "nodes = 1000000.0 ")
    (tmp_path / "fit.toml").write_text(problem)
    monkeypatch.chdir(tmp_path)
    message = _one_error(capsys, main(["solve", "fit.toml", "--out", "res"]))
    assert message.endswith("key 'nodes' (line 5): 1000000 is outside 10..2000."), message


@pytest.mark.parametrize(("text", "line"), [
    ("[passive]\nx = 1\nknee = {k = 1.0, kk = 2.0}\n", 3),       # inline table
    ("[passive]\nx = 1\nknee.kk = 2.0\n", 3),                     # dotted key
    ("x = 1\npassive.knee.kk = 2.0\n", 2),                        # dotted from the top
    ("[passive]\nx = 1\n[passive.knee]\nk = 1\nkk = 2.0\n", 5),   # sub-table (as before)
])
def test_nested_unknown_key_names_its_line(tmp_path, text, line):
    path = tmp_path / "p.toml"
    path.write_text(text)
    knee = load_problem(path).table("passive").table("knee")
    with pytest.raises(InputError, match=rf"key 'passive.knee.kk' \(line {line}\): unknown"):
        knee.check_keys(["k"])
