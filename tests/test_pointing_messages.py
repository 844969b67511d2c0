"""Messages that point the right way (issue 30 item 8): binary/C3D where text is expected,
a problem file given to the wrong command, ``report -o`` extensions, required options in
usage lines. Each runs the command in process and checks exit 2, the message and that
nothing was written."""

from __future__ import annotations

from pathlib import Path

import pytest

from predgait.cli import main
from predgait.problemfile import COMMAND_KINDS, problem_command

REPO = Path(__file__).resolve().parents[1]
PROBLEMS = REPO / "problems"
DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
C3D = DATA / "opensim_walking5_c3d" / "walking5.c3d"
TRC = DATA / "opensim_subject01_walk1" / "subject01_walk1.trc"
LEG = ["--mass", "72", "--markers", "hip=RHJC,knee=RKJC,ankle=RAJC,toe=RMT2"]


def _error(capsys, argv) -> str:
    assert main(argv) == 2
    return capsys.readouterr().err


def _c3d_header(path: Path) -> Path:
    """A file with a C3D header block (parameter block 2, key 0x50) and a text name."""
    path.write_bytes(bytes([2, 0x50]) + bytes(510) + b"rest")
    return path


def test_c3d_given_to_grf_is_named_with_the_option_that_takes_it(tmp_path, capsys):
    grf = C3D if C3D.is_file() else _c3d_header(tmp_path / "walk.c3d")
    err = _error(capsys, ["inverse", str(TRC), "--grf", str(grf), *LEG,
                          "--out", str(tmp_path / "out")])
    assert "C3D file" in err and "--grf" in err and "MARKERS.c3d" in err
    assert "UTF-8" not in err  # not "save it as UTF-8"
    assert not (tmp_path / "out").exists()


def test_c3d_header_under_a_text_name_is_recognised(tmp_path, capsys):
    grf = _c3d_header(tmp_path / "walk_grf.mot")   # a C3D renamed .mot
    err = _error(capsys, ["inverse", str(TRC), "--grf", str(grf), *LEG,
                          "--out", str(tmp_path / "out")])
    assert "C3D file" in err and "OpenSim .sto/.mot" in err


def test_other_binary_is_named_binary_not_asked_to_be_saved_as_utf8(tmp_path, capsys):
    grf = tmp_path / "grf.mot"
    grf.write_bytes(bytes(range(256)) * 4)
    err = _error(capsys, ["inverse", str(TRC), "--grf", str(grf), *LEG,
                          "--out", str(tmp_path / "out")])
    assert "binary file" in err and "C3D" not in err and "UTF-8" not in err


def test_latin1_text_still_asked_to_be_saved_as_utf8(tmp_path, capsys):
    grf = tmp_path / "grf.mot"
    grf.write_bytes("name\tForce \xe9\n".encode("latin-1") * 20)
    err = _error(capsys, ["inverse", str(TRC), "--grf", str(grf), *LEG,
                          "--out", str(tmp_path / "out")])
    assert "Save it as UTF-8" in err and "binary" not in err


@pytest.mark.parametrize(("command", "problem", "owner"), [
    ("solve", "resynthesis.toml", "simulate"),
    ("simulate", "predict_gait7.toml", "solve"),
    ("sweep", "scenario_stiff_knee.toml", "scenario"),
    ("scenario", "sweep_knee_stiffness.toml", "sweep"),
    ("scenario", "knee_fit.toml", "solve"),
    ("sweep", "scenario_muscle_afo_2d.toml", "scenario"),
    ("solve", "inverse_subject01.toml", "inverse"),
])
def test_problem_file_given_to_the_wrong_command_names_its_command(tmp_path, capsys, command,
                                                                    problem, owner):
    err = _error(capsys, [command, str(PROBLEMS / problem), "--out", str(tmp_path / "out")])
    assert f"is a problem for 'predgait {owner}', not 'predgait {command}'" in err
    assert "unknown key" not in err
    assert not (tmp_path / "out").exists()


def test_every_bundled_problem_belongs_to_one_command():
    """Every kind of every command is in the table the message uses, and each bundled
    problem file is recognised (a new kind left out of COMMAND_KINDS fails here)."""
    import tomllib

    from predgait.workflows.simulate import KINDS
    from predgait.workflows.solve import Kind

    assert set(KINDS) <= set(COMMAND_KINDS["simulate"])
    from predgait.cli.solve import _WORKFLOWS
    assert {k.value for k in Kind} | set(_WORKFLOWS) <= set(COMMAND_KINDS["solve"])
    for path in PROBLEMS.glob("*.toml"):
        assert problem_command(tomllib.loads(path.read_text())) is not None, path.name


def test_right_command_is_not_refused(tmp_path, capsys):
    """A sweep file given to sweep gets past the check (then fails on --workers 0)."""
    err = _error(capsys, ["sweep", str(PROBLEMS / "sweep_knee_stiffness.toml"),
                          "--workers", "-1", "--out", str(tmp_path / "out")])
    assert "is a problem for" not in err


@pytest.mark.parametrize("name", ["report.pdf", "report.txt", "report"])
def test_report_refuses_extensions_it_does_not_write(tmp_path, capsys, name):
    folder = tmp_path / "result"
    folder.mkdir()
    (folder / "summary.json").write_text('{"status": "completed"}')
    err = _error(capsys, ["report", str(folder), "-o", str(tmp_path / name)])
    assert "HTML" in err and ".html" in err
    assert not (tmp_path / name).exists()
    assert main(["report", str(folder), "-o", str(tmp_path / "report.html")]) == 0


def test_inverse_usage_shows_mass_as_required(capsys):
    with pytest.raises(SystemExit):
        main(["inverse", "--help"])
    usage = capsys.readouterr().out.split("\n\n")[0]
    assert "--mass KG" in usage and "[--mass KG]" not in usage
    assert "--markers hip=NAME" in usage and "--marker-map FILE.toml --mass KG --height M" in usage


def test_inverse_without_mass_says_so(tmp_path, capsys):
    err = _error(capsys, ["inverse", str(TRC), "--markers", "hip=RHJC,knee=RKJC,ankle=RAJC,"
                          "toe=RMT2", "--out", str(tmp_path / "out")])
    assert "--mass (kg) is required" in err
