"""TOML problem files: typed fields, unknown keys with their line, --set overrides."""

import enum

import pytest

from predgait.errors import InputError
from predgait.problemfile import load_problem


class Colour(enum.Enum):
    RED = "red"
    BLUE = "blue"


@pytest.fixture
def problem(tmp_path):
    path = tmp_path / "p.toml"
    path.write_text('kind = "collapse"\n\n[integrator]\nmethod = "red"\nstep = 0.001\n'
                    'iteratons = 10\n\n[passive.knee]\nk = 10\n')
    return path


def test_typed_fields_and_overrides(problem):
    table = load_problem(problem, overrides=["integrator.step=0.05", "passive.knee.c=20"])
    integrator = table.table("integrator")
    assert integrator.number("step", low=1e-6, high=0.1) == 0.05
    assert integrator.choice("method", Colour) is Colour.RED
    knee = table.table("passive").table("knee")
    assert knee.number("k") == 10.0 and knee.number("c") == 20.0


def test_unknown_key_names_file_key_and_line(problem):
    integrator = load_problem(problem).table("integrator")
    with pytest.raises(InputError, match=r"key 'integrator.iteratons' \(line 6\): unknown key"):
        integrator.check_keys(["method", "step", "iterations"])


def test_wrong_type_and_range(problem):
    table = load_problem(problem, overrides=["integrator.step=1.5"])
    with pytest.raises(InputError, match=r"integrator.step' \(line 5\).*outside"):
        table.table("integrator").number("step", low=1e-6, high=0.1)
    with pytest.raises(InputError, match="expected float"):
        table.number("kind")
    with pytest.raises(InputError, match="not one of: red, blue"):
        load_problem(problem, overrides=["integrator.method='green'"]).table(
            "integrator").choice("method", Colour)


def test_syntax_error_and_missing_file(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("a = [1,\n")
    with pytest.raises(InputError, match="not valid TOML"):
        load_problem(bad)
    with pytest.raises(InputError, match="problem file not found"):
        load_problem(tmp_path / "none.toml")


def test_override_inside_an_array_of_tables(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text('[[edit]]\nkind = "passive"\nk = 1\n\n[[edit]]\nkind = "lock_joint"\n')
    table = load_problem(path, overrides=["edit.0.k=250", "edit.1.angle_deg=12"])
    assert table.data["edit"][0]["k"] == 250
    assert table.data["edit"][1]["angle_deg"] == 12
    with pytest.raises(InputError, match="is not an index 0..1"):
        load_problem(path, overrides=["edit.5.k=1"])
