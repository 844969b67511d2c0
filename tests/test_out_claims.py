"""One run per ``--out`` folder, and ``--force`` that loses nothing (issue 29, items 5, 6
and the ``--out`` checks of item 9)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from cli_checks import one_error as _one_error
from predgait.cli import main
from predgait.workflows import output
from predgait.workflows.output import staged_output

REPO = Path(__file__).resolve().parents[1]
ROD = str(REPO / "problems" / "rod.toml")
HOLD = """\
import sys, time
from predgait.workflows.output import check_out
check_out(sys.argv[1], force=True)
print("claimed", flush=True)
time.sleep(float(sys.argv[2]))
"""




def _holder(out: Path, seconds: float) -> subprocess.Popen:
    """Another process that claims ``out`` and holds it for ``seconds``."""
    child = subprocess.Popen([sys.executable, "-c", HOLD, str(out), str(seconds)],
                             stdout=subprocess.PIPE, text=True)
    assert child.stdout.readline().strip() == "claimed"
    return child


def test_second_run_to_the_same_folder_fails_with_one_message(tmp_path, capsys):
    out = tmp_path / "res"
    child = _holder(out, 60.0)
    try:
        started = time.perf_counter()
        status = main(["simulate", ROD, "--out", str(out), "--no-plots"])
        _one_error(capsys, status, "another predgait run", f"process {child.pid}", "--force")
        assert time.perf_counter() - started < 5.0  # refused before the simulation
        assert not out.exists()
    finally:
        child.kill()
        child.wait()
    assert main(["simulate", ROD, "--out", str(out), "--no-plots"]) == 0  # claim freed
    assert (out / "summary.json").is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["res"]  # no lock left


def test_with_force_the_second_run_publishes_after_the_first(tmp_path, caplog):
    out = tmp_path / "res"
    child = _holder(out, 2.0)
    try:
        assert main(["simulate", ROD, "--out", str(out), "--no-plots", "--force"]) == 0
    finally:
        child.wait()
    assert "another predgait run" in caplog.text
    assert json.loads((out / "summary.json").read_text())
    assert sorted(p.name for p in tmp_path.iterdir()) == ["res"]


def test_the_last_writer_never_silently_replaces_a_folder_made_meanwhile(tmp_path):
    out = tmp_path / "res"
    with pytest.raises(output.InputError, match="created by something else"), \
            staged_output(out) as stage:
        (stage / "a.txt").write_text("mine")
        out.mkdir()
        (out / "theirs.txt").write_text("theirs")
    assert (out / "theirs.txt").read_text() == "theirs"
    kept = list(tmp_path.glob("res.new-*"))
    assert len(kept) == 1 and (kept[0] / "a.txt").read_text() == "mine"


def _result(out: Path, text: str, *, force=False) -> None:
    with staged_output(out, force=force) as stage:
        (stage / "states.sto").write_text(text)


def test_force_removes_only_what_predgait_wrote(tmp_path, caplog):
    out = tmp_path / "res"
    _result(out, "first")
    _result(out, "second", force=True)
    assert (out / "states.sto").read_text() == "second"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["res"]
    (out / "notes.txt").write_text("the user's notes")
    _result(out, "third", force=True)
    assert (out / "states.sto").read_text() == "third"
    kept = list(tmp_path.glob("res.previous-*"))
    assert len(kept) == 1
    assert (kept[0] / "notes.txt").read_text() == "the user's notes"
    assert (kept[0] / "states.sto").read_text() == "second"
    assert "notes.txt" in caplog.text and kept[0].name in caplog.text


def test_force_over_a_folder_of_unknown_files_keeps_it_whole(tmp_path, caplog):
    out = tmp_path / "res"
    out.mkdir()
    (out / "mine.csv").write_text("1,2\n")
    _result(out, "new", force=True)
    kept = list(tmp_path.glob("res.previous-*"))
    assert len(kept) == 1 and (kept[0] / "mine.csv").read_text() == "1,2\n"


KILL_BETWEEN_RENAMES = """\
import os, signal, sys
from pathlib import Path
from predgait.workflows.output import staged_output
renames = []
real = Path.rename
def rename(self, target):
    result = real(self, target)
    renames.append(target)
    if len(renames) == 1:
        os.kill(os.getpid(), signal.SIGKILL)
    return result
Path.rename = rename
with staged_output(sys.argv[1], force=True) as stage:
    (stage / "states.sto").write_text("new")
"""


def test_sigkill_between_the_two_renames_loses_nothing(tmp_path):
    out = tmp_path / "res"
    _result(out, "previous")
    (out / "notes.txt").write_text("the user's notes")
    done = subprocess.run([sys.executable, "-c", KILL_BETWEEN_RENAMES, str(out)])
    assert done.returncode == -signal.SIGKILL
    assert not out.exists()  # killed with the previous result moved aside
    _result(tmp_path / "other", "x")  # the next run in the folder puts it back
    assert (out / "states.sto").read_text() == "previous"
    assert (out / "notes.txt").read_text() == "the user's notes"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["other", "res"]


def test_dangling_link_as_out_is_refused_before_any_work(tmp_path, capsys):
    out = tmp_path / "res"
    out.symlink_to(tmp_path / "gone")
    started = time.perf_counter()
    _one_error(capsys, main(["simulate", ROD, "--out", str(out), "--force"]),
               "res", "does not exist")
    assert time.perf_counter() - started < 5.0


def test_read_only_parent_of_out_is_refused_before_any_work(tmp_path, capsys, read_only):
    parent = tmp_path / "ro"
    parent.mkdir()
    read_only(parent)
    _one_error(capsys, main(["simulate", ROD, "--out", str(parent / "res")]), "read-only")


def test_a_failed_run_leaves_no_claim(tmp_path, capsys):
    out = tmp_path / "res"
    status = main(["simulate", ROD, "--out", str(out), "--set", "rod.nope=1"])
    assert status == 2
    assert list(tmp_path.iterdir()) == []
    assert not output._CLAIMS and os.listdir(tmp_path) == []
