"""Single-file outputs (``report -o``, ``model build -o``) never write through a link and
never share a temporary file (issue 29, item 4; the read-only case of item 9)."""

from __future__ import annotations

import os
import threading

import pytest

from cli_checks import one_error as _one_error
from predgait.cli import main
from predgait.models import urdf
from predgait.models.urdf import write_text_atomic

SUMMARY = '{"status": "ok"}\n'




@pytest.fixture
def result(tmp_path, monkeypatch):
    res = tmp_path / "res"
    res.mkdir()
    (res / "summary.json").write_text(SUMMARY)
    monkeypatch.chdir(tmp_path)
    return res


def test_report_does_not_follow_a_link_planted_at_the_old_temporary_name(result, tmp_path):
    planted = tmp_path / ".report.html.tmp"
    planted.symlink_to(result / "summary.json")
    assert main(["report", "res", "-o", "report.html"]) == 0
    assert (result / "summary.json").read_text() == SUMMARY
    assert (tmp_path / "report.html").read_text().startswith("<!DOCTYPE html>")
    assert planted.is_symlink()
    assert sorted(p.name for p in tmp_path.iterdir()) == [".report.html.tmp", "report.html",
                                                          "res"]


def test_model_build_does_not_follow_a_planted_link(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    problem = tmp_path / "problem.toml"
    problem.write_text("[trial]\n")
    (tmp_path / ".leg.urdf.tmp").symlink_to(problem)
    assert main(["model", "build", "leg", "-o", "leg.urdf"]) == 0
    assert problem.read_text() == "[trial]\n"
    assert "<robot" in (tmp_path / "leg.urdf").read_text()


def test_report_onto_a_link_to_its_input_is_refused(result, tmp_path, capsys):
    (tmp_path / "page.html").symlink_to(result / "summary.json")
    status = main(["report", "res", "-o", "page.html", "--force"])
    _one_error(capsys, status, "page.html")
    assert (result / "summary.json").read_text() == SUMMARY


def test_dangling_link_as_output_is_refused_without_force(result, tmp_path, capsys):
    (tmp_path / "page.html").symlink_to(tmp_path / "nowhere.html")
    _one_error(capsys, main(["report", "res", "-o", "page.html"]), "exists", "--force")
    assert not (tmp_path / "nowhere.html").exists()


def test_concurrent_writers_use_their_own_temporary_files(tmp_path, monkeypatch):
    """Each writer renames its own whole file: the result is one writer's whole text."""
    sources = []
    replace = os.replace

    def recording(src, dst):
        sources.append(os.fspath(src))
        replace(src, dst)

    monkeypatch.setattr(urdf.os, "replace", recording)
    texts = [f"writer {i}\n" * 20000 for i in range(12)]
    target = tmp_path / "out.html"
    errors = []

    def write(text):
        try:
            write_text_atomic(text, target, force=True)
        except Exception as exc:  # noqa: BLE001 - collected for the assert
            errors.append(exc)

    threads = [threading.Thread(target=write, args=(t,)) for t in texts]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert not errors
    assert len(set(sources)) == len(texts)
    assert not any(name.endswith(".out.html.tmp") for name in sources)
    assert target.read_text() in texts
    assert [p.name for p in tmp_path.iterdir()] == ["out.html"]


def test_report_into_a_read_only_folder_is_one_message_before_any_work(
        result, tmp_path, capsys, monkeypatch, read_only):
    out = tmp_path / "ro"
    out.mkdir()
    read_only(out)

    def no_report(*args, **kwargs):
        raise AssertionError("the report was built before the output was checked")

    monkeypatch.setattr("predgait.report.html.build_report", no_report)
    _one_error(capsys, main(["report", "res", "-o", "ro/page.html"]), "ro/page.html",
               "read-only")
    assert list(out.iterdir()) == []


def test_write_failing_midway_leaves_nothing(tmp_path, monkeypatch):
    target = tmp_path / "out.urdf"
    target.write_text("previous\n")

    def failing(src, dst):
        raise OSError(30, "Read-only file system")

    monkeypatch.setattr(urdf.os, "replace", failing)
    with pytest.raises(urdf.InputError, match="Read-only file system"):
        write_text_atomic("new\n", target, force=True)
    assert target.read_text() == "previous\n"
    assert [p.name for p in tmp_path.iterdir()] == ["out.urdf"]
