"""``predgait batch`` on a small dataset: the bundled real walk, two synthetic walks with
known answers (different mass, height, cadence, speed) and one broken trial (issue 31).

Checked trial by trial: every finished trial's tables equal those of the single-trial
command ``predgait inverse``; the synthetic walks' angles and moments equal the exact RNEA
answer; their gait cycles (the motion is periodic) give curves with the exact mean and
~zero SD; the broken trial is recorded with its reason and the rest go on; ``--resume``
reruns only what changed or failed; a worker killed mid-run loses no trial.
"""

from __future__ import annotations

import csv
import json
import os
import re
import shutil
import signal
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from predgait.cli import main
from predgait.errors import InputError
from predgait.simulations.synthetic_trials import SyntheticWalk, write_synthetic_trial
from predgait.workflows.batch import run_batch
from predgait.workflows.batch_spec import read_dataset

REPO = Path(__file__).resolve().parents[1]
WALKS = {"synA": SyntheticWalk(mass=60.0, height=1.70, cadence=0.9, speed=0.8),
         "synB": SyntheticWalk(mass=85.0, height=1.90, cadence=0.75, speed=0.5)}


def write_dataset(folder: Path) -> Path:
    """The dataset file and its synthetic trials in ``folder``; one trial is broken."""
    rows = []
    for name, walk in WALKS.items():
        write_synthetic_trial(folder / name, walk)
        rows.append(f'[[subjects]]\nname = "{name}"\nmass = {walk.mass}\nheight = {walk.height}\n'
                    f'leg = ["{name}/inverse.toml"]\n\n[[trials]]\nsubject = "{name}"\n'
                    f'condition = "normal"\nmarkers = "{name}/markers.csv"\n'
                    f'grf = "{name}/grf.mot"\n')
    short = folder / "synB_short"   # 5 frames: too short to analyse
    short.mkdir()
    lines = (folder / "synB" / "markers.csv").read_text().splitlines()
    (short / "markers.csv").write_text("\n".join(lines[:8]) + "\n")
    shutil.copy(folder / "synB" / "grf.mot", short / "grf.mot")
    rows.append('[[trials]]\nsubject = "synB"\ncondition = "short"\n'
                'markers = ["synB_short/*.csv"]\ngrf = "synB_short/grf.mot"\n')
    rows.append(f'[[subjects]]\nname = "subject01"\nmass = 72.6\nheight = 1.8034\n'
                f'static = "bundled:subject01_walk1/subject01_static.trc"\n'
                f'leg = ["{REPO}/problems/inverse_subject01.toml"]\n\n[[trials]]\n'
                'subject = "subject01"\ncondition = "self-selected"\n'
                'markers = "bundled:subject01_walk1/subject01_walk1.trc"\ngrf = "{stem}_grf.mot"\n')
    path = folder / "dataset.toml"
    path.write_text('name = "lab"\nanalyses = ["leg"]\n\n' + "\n".join(rows))
    return path


def read_csv(path: Path) -> tuple[list[str], np.ndarray]:
    lines = [ln for ln in path.read_text().splitlines() if not ln.startswith("#")]
    return lines[0].split(","), np.array([[float(v or "nan") for v in ln.split(",")]
                                           for ln in lines[1:]])


def kill_a_busy_worker(out: Path, killed: list, stop: threading.Event) -> None:
    """SIGKILL the first worker process seen writing a trial (its staging folder is named
    ``.<trial>.predgait-<pid>-*``)."""
    pattern = re.compile(r"^\.(.+)\.predgait-(\d+)-")
    while not stop.is_set() and not killed:
        for path in (out / "trials").glob(".*.predgait-*") if (out / "trials").is_dir() else ():
            match = pattern.match(path.name)
            if match and int(match.group(2)) != os.getpid():
                os.kill(int(match.group(2)), signal.SIGKILL)
                killed.append(match.group(1))
                break
        time.sleep(0.005)


@pytest.fixture(scope="module")
def batch(tmp_path_factory):
    """The dataset run once with 2 local Dask workers, one of them killed mid-trial;
    (folder, dataset file, out, exit status, the trial that was running when killed)."""
    pytest.importorskip("distributed")
    folder = tmp_path_factory.mktemp("lab")
    dataset = write_dataset(folder)
    out = folder / "results"
    killed, stop = [], threading.Event()
    killer = threading.Thread(target=kill_a_busy_worker, args=(out, killed, stop))
    killer.start()
    try:
        status = main(["batch", str(dataset), "--out", str(out), "--workers", "2",
                       "--no-plots"])
    finally:
        stop.set()
        killer.join()
    return folder, dataset, out, status, killed


def status_rows(out: Path) -> dict[str, dict]:
    with (out / "status.csv").open() as handle:
        return {row["trial"]: row for row in csv.DictReader(handle)}


def test_broken_trial_is_recorded_and_the_rest_go_on(batch):
    _, _, out, status, _ = batch
    rows = status_rows(out)
    assert status == 1   # a failed trial: exit 1 without --allow-failures
    assert {t: r["status"] for t, r in rows.items()} == {
        "synA__normal__markers": "ok", "synB__normal__markers": "ok",
        "synB__short__markers": "failed", "subject01__self-selected__subject01_walk1": "ok"}
    assert "frames" in rows["synB__short__markers"]["reason"]
    assert not (out / "trials" / "synB__short__markers").exists()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["ok"] == 3 and summary["failed"] == 1


def test_each_trial_equals_the_single_trial_command(batch, tmp_path):
    folder, _, out, _, _ = batch
    problems = {"synA__normal__markers": folder / "synA" / "inverse.toml",
                "subject01__self-selected__subject01_walk1": REPO / "problems" /
                "inverse_subject01.toml"}
    for trial, problem in problems.items():
        single = tmp_path / trial
        assert main(["inverse", str(problem), "--out", str(single), "--no-plots"]) == 0
        for table in ("kinematics.csv", "inverse_dynamics.csv"):
            ours = (out / "trials" / trial / "leg_right" / table).read_text()
            assert ours == (single / table).read_text(), (trial, table)


def test_the_parquet_table_reads_back_equal_to_the_csv_table(batch):
    """results.parquet (pyarrow, in the test extra) holds results.csv's rows, in order:
    the same text cells, the same integers, values equal to the CSV's 10 digits (NaN where
    the CSV cell is empty)."""
    import pyarrow.parquet as pq

    from predgait.report.dataset_tables import TIDY

    _, _, out, _, _ = batch
    table = pq.read_table(out / "results.parquet")
    assert tuple(table.column_names) == TIDY
    parquet = table.to_pydict()
    with (out / "results.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == table.num_rows > 0
    for name in TIDY:
        ours = parquet[name]
        if name == "value":
            text = np.array([float(r[name] or "nan") for r in rows])
            np.testing.assert_allclose(np.array(ours, dtype=float), text, rtol=1e-9,
                                       atol=1e-300, equal_nan=True)
        elif name in ("cycle", "percent", "flagged"):
            assert ours == [int(r[name]) for r in rows], name
        else:
            assert ours == [r[name] for r in rows], name


@pytest.mark.parametrize("name", list(WALKS))
def test_synthetic_trials_give_their_known_answers(batch, name):
    """Exact RNEA answer (test_inverse_synthetic's tolerances), cycles and curves."""
    folder, _, out, _, _ = batch
    trial = out / "trials" / f"{name}__normal__markers" / "leg_right"
    t0 = json.loads((trial / "summary.json").read_text())["provenance"]["time_zero_s"]
    names, exact = read_csv(folder / name / "answers.csv")
    columns = {}
    for table in ("kinematics.csv", "inverse_dynamics.csv"):
        header, values = read_csv(trial / table)
        columns |= {h: values[:, i] for i, h in enumerate(header)}
    np.testing.assert_allclose(columns["time"] + t0, exact[:, 0], atol=1e-6)   # CSV digits
    keep = slice(15, -15)
    for i, variable in enumerate(names[1:], start=1):
        truth = exact[keep, i]
        ours = columns[variable][keep]
        if variable.endswith("_moment"):
            scale = np.abs(truth).max()
            assert np.nanmax(np.abs(ours - truth)) < 0.01 * scale + 0.5, variable
        else:
            assert np.nanmax(np.abs(np.degrees(ours) - truth)) < 0.05, variable
    # The tidy table: 3 cycles of the periodic walk, each one cadence period long.
    with (out / "results.csv").open() as handle:
        rows = [r for r in csv.DictReader(handle) if r["subject"] == name]
    assert {int(r["cycle"]) for r in rows} == {1, 2, 3}
    walk = WALKS[name]
    curves = {}
    with (out / "curves.csv").open() as handle:
        for r in csv.DictReader(handle):
            if r["subject"] == name:
                curves[(r["variable"], int(r["percent"]))] = r
    strikes = json.loads((trial / "summary.json").read_text())["heel_strikes_s"]
    assert np.diff(strikes) == pytest.approx(1 / walk.cadence, abs=0.011)   # 1 frame
    at = t0 + strikes[0] + (strikes[1] - strikes[0]) * np.arange(101) / 100.0   # cycle 1
    knee = np.interp(at, exact[:, 0], exact[:, names.index("knee_flexion")])
    mean = np.array([float(curves[("knee_flexion", p)]["mean"]) for p in range(101)])
    sd = np.array([float(curves[("knee_flexion", p)]["sd"]) for p in range(101)])
    assert {curves[("knee_flexion", p)]["n"] for p in range(101)} == {"3"}
    np.testing.assert_allclose(mean[5:-5], knee[5:-5], atol=0.1)
    assert sd[5:-5].max() < 0.1   # cycles 1 frame (0.01 s) apart in length
    moment = np.array([float(curves[("ankle_dorsiflexion_moment", p)]["mean"])
                       for p in range(101)])
    exact_moment = np.interp(at, exact[:, 0], exact[:, names.index("ankle_dorsiflexion_moment")])
    np.testing.assert_allclose(moment[5:-5], exact_moment[5:-5] / walk.mass, atol=0.02)


def test_resume_reruns_only_the_changed_and_failed_trials(batch, tmp_path):
    folder, dataset, out, _, _ = batch
    copy = tmp_path / "results"
    shutil.copytree(out, copy)
    kept = (copy / "trials" / "synA__normal__markers" / "trial.json").stat().st_mtime_ns
    # Fix the broken trial; change the real walk's settings (its mass).
    shutil.copy(folder / "synB" / "markers.csv", folder / "synB_short" / "markers.csv")
    text = dataset.read_text()
    edited = folder / "dataset_edited.toml"   # the same dataset (its name), edited
    edited.write_text(text.replace("mass = 72.6", "mass = 70.0"))
    try:
        status = main(["batch", str(edited), "--out", str(copy), "--resume", "--workers", "1",
                       "--no-plots"])
    finally:   # the module's other tests read the broken file
        lines = (folder / "synB" / "markers.csv").read_text().splitlines()
        (folder / "synB_short" / "markers.csv").write_text("\n".join(lines[:8]) + "\n")
    assert status == 0
    rows = status_rows(copy)
    assert {t: r["status"] for t, r in rows.items()} == {
        "synA__normal__markers": "unchanged", "synB__normal__markers": "unchanged",
        "synB__short__markers": "ok", "subject01__self-selected__subject01_walk1": "ok"}
    assert (copy / "trials" / "synA__normal__markers" / "trial.json").stat().st_mtime_ns == kept
    real = Path("trials", "subject01__self-selected__subject01_walk1", "leg_right",
                "inverse_dynamics.csv")
    assert (copy / real).read_text() != (out / real).read_text()   # the lighter segments


def dataset_text(**changes) -> str:
    base = {"subjects": '[[subjects]]\nname = "s"\nmass = 70\nleg = ["leg.toml"]\n',
            "trials": '[[trials]]\nsubject = "s"\nmarkers = "walk*.csv"\n'}
    return 'name = "d"\n' + "".join(changes.get(k, v) for k, v in base.items())


@pytest.mark.parametrize("case, text, message", [
    ("no trial", dataset_text(trials=""), "names no trial"),
    ("glob", dataset_text(trials='[[trials]]\nsubject = "s"\nmarkers = "none*.c3d"\n'),
     "matches no file"),
    ("subject row", dataset_text(trials='[[trials]]\nsubject = "x"\nmarkers = "walk*.csv"\n'),
     "'x' has no \\[\\[subjects\\]\\] row"),
    ("same name", dataset_text(subjects='[[subjects]]\nname = "s"\nmass = 70\nleg = ["leg.toml"]'
                                        '\n[[subjects]]\nname = "s"\nmass = 60\n'
                                        'leg = ["leg.toml"]\n'), "two subjects are named 's'"),
])
def test_bad_dataset_files(tmp_path, capsys, case, text, message):
    shutil.copy(REPO / "problems" / "inverse_subject01.toml", tmp_path / "leg.toml")
    (tmp_path / "walk1.csv").write_text("time\n0\n")
    (tmp_path / "d.toml").write_text(text)
    status = main(["batch", str(tmp_path / "d.toml"), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert status == 2 and err.startswith("predgait: error:"), err
    assert len(err.strip().splitlines()) == 1
    assert re.search(message, err), err
    assert not (tmp_path / "out").exists()


def test_another_datasets_folder_and_an_unreachable_scheduler(batch, tmp_path, capsys):
    folder, dataset, out, _, _ = batch
    other = folder / "dataset_other.toml"
    other.write_text(dataset.read_text().replace('name = "lab"', 'name = "other"'))
    before = {p: p.stat().st_mtime_ns for p in out.rglob("*")}
    assert main(["batch", str(other), "--out", str(out)]) == 2
    assert "holds the results of dataset 'lab'" in capsys.readouterr().err
    assert main(["batch", str(dataset), "--out", str(out)]) == 2   # no --resume / --force
    assert "add --resume" in capsys.readouterr().err
    with pytest.raises(InputError, match="cannot reach the Dask scheduler"):
        run_batch(read_dataset(dataset), tmp_path / "new", scheduler="tcp://127.0.0.1:9",
                  connect_timeout=1.0)
    assert not (tmp_path / "new").exists()
    assert {p: p.stat().st_mtime_ns for p in out.rglob("*")} == before


def test_the_workers_forkserver_is_ended_with_the_batch(batch):
    """The 2-worker run started its workers' forkserver and ended it on its way out."""
    from predgait.workflows import batch_server

    assert not batch_server.running()


def test_a_killed_worker_loses_no_trial(batch):
    """The worker SIGKILLed while it wrote a trial: Dask reran that trial, it is whole."""
    _, _, out, _, killed = batch
    assert killed, "no worker was seen running a trial"
    rows = status_rows(out)
    assert rows[killed[0]]["status"] in ("ok", "failed")
    if rows[killed[0]]["status"] == "ok":
        assert json.loads((out / "trials" / killed[0] / "trial.json").read_text())["cycles"] > 0
    assert [r["status"] for r in rows.values()].count("ok") == 3
    assert not list((out / "trials").glob(".*"))   # the killed stage was cleaned up


def test_fullbody_trial_equals_the_single_trial_command_and_the_report(tmp_path):
    """analyses = ["fullbody"] on the bundled walk, with a normative band drawn."""
    from predgait.data.bundled import bundled_path

    text = (REPO / "problems" / "batch_subject01.toml").read_text()
    text = text.replace('analyses = ["leg"]', 'analyses = ["fullbody"]').replace(
        '"inverse_subject01', f'"{REPO}/problems/inverse_subject01').replace(
        '"markers_fullbody', f'"{REPO}/problems/markers_fullbody')
    dataset = tmp_path / "fullbody.toml"
    dataset.write_text(text)
    band = tmp_path / "band.csv"
    band.write_text("# normative\nvariable,percent,mean,sd\n"
                    + "".join(f"knee_flexion,{p},{30 * np.sin(np.pi * p / 100)},5\n"
                              for p in range(0, 101, 10)))
    out = tmp_path / "out"
    assert main(["batch", str(dataset), "--out", str(out), "--workers", "1",
                 "--normative", str(band)]) == 0
    walk = bundled_path("subject01_walk1")
    single = tmp_path / "single"
    assert main(["inverse", str(walk / "subject01_walk1.trc"), "--grf",
                 str(walk / "subject01_walk1_grf.mot"), "--static",
                 str(walk / "subject01_static.trc"), "--mass", "72.6", "--height", "1.8034",
                 "--model", "fullbody", "--marker-map",
                 str(REPO / "problems" / "markers_fullbody_subject01.toml"), "--out",
                 str(single), "--no-plots"]) == 0
    trial = out / "trials" / "subject01__self-selected__subject01_walk1" / "fullbody"
    for table in ("clinical.csv", "inverse_dynamics3d.csv"):
        assert (trial / table).read_text() == (single / table).read_text(), table
    with (out / "results.csv").open() as handle:
        rows = [r for r in csv.DictReader(handle) if r["variable"] == "knee_flexion"]
    assert {(r["side"], r["cycle"]) for r in rows} == {("right", "1"), ("right", "2"),
                                                      ("left", "1"), ("left", "2")}
    page = (out / "report.html").read_text()
    assert "curves_fullbody_knee_flexion" in page and "normative band" in page
    assert "subject01__self-selected__subject01_walk1</td>" in page


def test_fullbody_calibration_once_per_subject_per_worker(tmp_path, monkeypatch):
    """Three walks of one subject and one of another mass, in one worker: two static
    calibrations; a trial on the kept calibration equals the single-trial command (every
    file), and the kept calibration is refused for another subject."""
    from predgait.data.bundled import bundled_path
    from predgait.dynamics import fullbody_calibration
    from predgait.dynamics.inverse3d_trial import inverse_fullbody, read_trial
    from predgait.workflows import batch_warm

    walk, folder = bundled_path("subject01_walk1"), tmp_path / "walks"
    folder.mkdir()
    for stem in ("a", "b", "c", "d"):
        shutil.copy(walk / "subject01_walk1.trc", folder / f"{stem}.trc")
        shutil.copy(walk / "subject01_walk1_grf.mot", folder / f"{stem}_grf.mot")
        shutil.copy(walk / "subject01_walk1_grf.xml", folder / f"{stem}_grf.xml")
    subject = ('[[subjects]]\nname = "{name}"\nmass = {mass}\nheight = 1.8034\n'
               'static = "bundled:subject01_walk1/subject01_static.trc"\n'
               f'marker_map = "{REPO}/problems/markers_fullbody_subject01.toml"\n\n'
               '[[trials]]\nsubject = "{name}"\ncondition = "walk"\nmarkers = {files}\n'
               'grf = "{{stem}}_grf.mot"\n\n')
    dataset = tmp_path / "two.toml"
    dataset.write_text('name = "two"\nanalyses = ["fullbody"]\n\n'
                       + subject.format(name="s1", mass=72.6,
                                        files='["walks/a.trc", "walks/b.trc", "walks/c.trc"]')
                       + subject.format(name="s2", mass=80.0, files='"walks/d.trc"'))
    calls = []
    real = fullbody_calibration.calibrate_fullbody

    def counted(*args, **kwargs):
        calls.append(kwargs["mass"])
        return real(*args, **kwargs)

    monkeypatch.setattr(fullbody_calibration, "calibrate_fullbody", counted)
    monkeypatch.setattr(batch_warm, "_kept", type(batch_warm._kept)())
    out = tmp_path / "out"
    assert main(["batch", str(dataset), "--out", str(out), "--workers", "1",
                 "--no-plots"]) == 0
    assert calls == [72.6, 80.0]
    single = tmp_path / "single"
    assert main(["inverse", str(folder / "c.trc"), "--grf", str(folder / "c_grf.mot"),
                 "--static", str(walk / "subject01_static.trc"), "--mass", "72.6",
                 "--height", "1.8034", "--model", "fullbody", "--marker-map",
                 str(REPO / "problems" / "markers_fullbody_subject01.toml"), "--out",
                 str(single), "--no-plots"]) == 0
    trial = out / "trials" / "s1__walk__c" / "fullbody"
    names = sorted(p.name for p in single.glob("[!.]*"))   # not the folder's marker
    assert sorted(p.name for p in trial.iterdir()) == names
    for name in names:
        assert (trial / name).read_text() == (single / name).read_text(), name
    kept = next(iter(batch_warm._kept.values()))
    markers, plates = read_trial([folder / "d.trc", folder / "d_grf.mot"])
    with pytest.raises(ValueError, match="another subject"):
        inverse_fullbody(markers, plates, kept[0], mass=80.0, height=1.8034,
                         static=kept[1], calibration=kept[2])


def test_leg_static_calibration_once_per_subject_side_per_worker(tmp_path, monkeypatch,
                                                                count_leg_calibrations):
    """Two walks of subject01, both legs, in one worker: one static calibration per side;
    the second walk's files equal 'predgait inverse' of it (each side), and the kept
    calibration is refused for other options."""
    from dataclasses import replace

    from predgait.data.bundled import bundled_path
    from predgait.dynamics import leg_static
    from predgait.dynamics.inverse_trial import run_inverse
    from predgait.dynamics.leg_measurements import read_trial
    from predgait.workflows import batch_warm

    walk, folder = bundled_path("subject01_walk1"), tmp_path / "walks"
    folder.mkdir()
    for stem in ("a", "b"):
        shutil.copy(walk / "subject01_walk1.trc", folder / f"{stem}.trc")
        shutil.copy(walk / "subject01_walk1_grf.mot", folder / f"{stem}_grf.mot")
        shutil.copy(walk / "subject01_walk1_grf.xml", folder / f"{stem}_grf.xml")
    text = (REPO / "problems" / "batch_subject01.toml").read_text().replace(
        '"inverse_subject01', f'"{REPO}/problems/inverse_subject01').replace(
        '"markers_fullbody', f'"{REPO}/problems/markers_fullbody').replace(
        '"bundled:subject01_walk1/subject01_walk1.trc"', '["walks/a.trc", "walks/b.trc"]')
    dataset = tmp_path / "legs.toml"
    dataset.write_text(text)
    calls = count_leg_calibrations(monkeypatch)
    out = tmp_path / "out"
    assert main(["batch", str(dataset), "--out", str(out), "--workers", "1",
                 "--no-plots"]) == 0
    assert sorted(calls) == ["left", "right"]
    for side, problem in (("right", "inverse_subject01.toml"),
                          ("left", "inverse_subject01_left.toml")):
        single = tmp_path / f"single_{side}"
        assert main(["inverse", str(REPO / "problems" / problem), "--set",
                     f"trial.markers={folder / 'b.trc'}", "--set",
                     f"trial.grf={folder / 'b_grf.mot'}", "--set",
                     "trial.static=bundled:subject01_walk1/subject01_static.trc", "--out",
                     str(single), "--no-plots"]) == 0
        trial = out / "trials" / "subject01__self-selected__b" / f"leg_{side}"
        names = sorted(p.name for p in single.glob("[!.]*"))   # not the folders' markers
        assert sorted(p.name for p in trial.glob("[!.]*")) == names
        for name in names:
            assert (trial / name).read_text() == (single / name).read_text(), (side, name)
    kept = [v for v in batch_warm._kept.values() if isinstance(v, leg_static.LegStatic)]
    options = replace(kept[0].options, mass=kept[0].options.mass + 1.0)
    trial, turn = read_trial(options)
    with pytest.raises(ValueError, match="another subject"):
        run_inverse(options, loaded=(trial, turn), static=kept[0])


def test_a_bad_normative_band_is_refused_before_any_work(batch, tmp_path, capsys):
    _, dataset, _, _, _ = batch
    band = tmp_path / "band.csv"
    band.write_text("variable,percent,mean\nknee_flexion,0,1\n")
    assert main(["batch", str(dataset), "--out", str(tmp_path / "out"), "--normative",
                 str(band)]) == 2
    assert "needs the columns mean, percent, sd, variable" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()
