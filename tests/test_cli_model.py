"""``predgait model build|show`` and ``demo`` as a user runs them, bad input included."""

import subprocess
import sys

import pytest

from predgait.cli import main


def run_cli(*args, cwd=None):
    """Run the real console entry point in a subprocess (what a user sees)."""
    return subprocess.run([sys.executable, "-m", "predgait", *args], capture_output=True,
                          text=True, cwd=cwd, timeout=120)


def test_build_and_show_leg(tmp_path):
    out = tmp_path / "leg.urdf"
    assert main(["model", "build", "leg", "--mass", "80", "--height", "1.75", "-o", str(out)]) == 0
    text = out.read_text()
    assert "body mass 80 kg, height 1.75 m" in text
    result = run_cli("model", "show", str(out))
    assert result.returncode == 0, result.stderr
    lines = {line.split()[0]: line.split() for line in result.stdout.splitlines() if line}
    assert float(lines["thigh"][1]) == pytest.approx(8.0, abs=1e-4)
    assert float(lines["shank"][2]) == pytest.approx(0.246 * 1.75, abs=1e-4)
    assert "knee" in lines and "hip_center" in lines


@pytest.mark.parametrize("args,message", [
    (["leg", "--mass", "500"], "--mass = 500.0 kg is outside"),
    (["leg", "--mass", "0"], "--mass = 0.0 kg is outside"),
    (["leg", "--mass", "nan"], "--mass = nan kg"),
    (["leg", "--height", "3.1"], "--height = 3.1 m is outside"),
    (["leg", "--height", "-1.7"], "--height = -1.7 m"),
    (["rod", "--height", "1.7"], "the rod takes --mass and --length"),
    (["leg", "--segments", "missing.csv"], "segment table not found"),
])
def test_bad_input_is_one_clear_message(tmp_path, args, message):
    out = tmp_path / "model.urdf"
    result = run_cli("model", "build", *args, "-o", str(out))
    assert result.returncode == 2
    assert message in result.stderr
    assert "Traceback" not in result.stderr
    assert not out.exists()


def test_unknown_kind_and_existing_output(tmp_path):
    result = run_cli("model", "build", "arm", "-o", str(tmp_path / "a.urdf"))
    assert result.returncode == 2 and "invalid choice: 'arm'" in result.stderr
    out = tmp_path / "leg.urdf"
    out.write_text("keep me")
    result = run_cli("model", "build", "leg", "-o", str(out))
    assert result.returncode == 2 and "add --force" in result.stderr
    assert out.read_text() == "keep me"
    assert run_cli("model", "build", "leg", "-o", str(out), "--force").returncode == 0
    assert "predgait: kind=leg" in out.read_text()


def test_unwritable_output(tmp_path):
    result = run_cli("model", "build", "leg", "-o", str(tmp_path / "no" / "such" / "leg.urdf"))
    assert result.returncode == 2 and "does not exist" in result.stderr


def test_show_rejects_a_foreign_urdf(tmp_path):
    foreign = tmp_path / "robot.urdf"
    foreign.write_text('<robot name="r"><link name="a"/></robot>')
    result = run_cli("model", "show", str(foreign))
    assert result.returncode == 2 and "not a predgait-generated URDF" in result.stderr


def test_help_explains_units():
    result = run_cli("model", "build", "--help")
    assert result.returncode == 0
    assert "kg" in result.stdout and "(m)" in result.stdout
    assert "SI" in run_cli("--help").stdout
