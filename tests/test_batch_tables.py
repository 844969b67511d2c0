"""The batch's dataset tables from what the workers return (issue 31, item 4).

A trial's cycle arrays travel back from its worker instead of being read from its
``cycles.npz``; the results tables are built from them: they must be those the files give.
The workers' forkserver warms the first trials' calibrations; a dataset's first trials
read alone are those of the whole file.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from predgait.report.dataset_tables import (
    TIDY,
    cycles_from_arrays,
    read_cycle_arrays,
    read_cycles,
)
from predgait.simulations.synthetic_trials import SyntheticWalk, write_synthetic_trial
from predgait.workflows.batch_spec import read_dataset

REPO = Path(__file__).resolve().parents[1]


def synthetic_dataset(folder: Path, count: int = 2) -> Path:
    rows = ['name = "syn"\nanalyses = ["leg"]\n']
    for k in range(count):
        name = f"s{k}"
        walk = SyntheticWalk(mass=60.0 + 10 * k, height=1.7, cadence=0.9, speed=0.8)
        write_synthetic_trial(folder / name, walk)
        rows.append(f'[[subjects]]\nname = "{name}"\nmass = {walk.mass}\nheight = 1.7\n'
                    f'leg = ["{name}/inverse.toml"]\n\n[[trials]]\nsubject = "{name}"\n'
                    f'condition = "c"\nmarkers = "{name}/markers.csv"\n'
                    f'grf = "{name}/grf.mot"\n')
    path = folder / "dataset.toml"
    path.write_text("\n".join(rows))
    return path


def reference_parquet_table(cycles):
    """The Parquet table as built row by row from the cycles (the earlier way)."""
    import pyarrow as pa

    n = 101
    rows = pa.array(np.repeat(np.arange(len(cycles)), n))

    def each(values):
        return pa.array(values).take(rows)

    columns = {name: each([c.key[i] for c in cycles]) for i, name in enumerate(TIDY[:5])}
    columns["cycle"] = each([c.cycle for c in cycles])
    columns["percent"] = np.tile(np.arange(n, dtype=np.int64), len(cycles))
    columns["variable"] = each([c.variable for c in cycles])
    columns["value"] = (np.concatenate([np.asarray(c.values, dtype=float) for c in cycles])
                        if cycles else np.empty(0))
    columns["unit"] = each([c.unit for c in cycles])
    columns["flagged"] = each([int(c.flagged) for c in cycles])
    return pa.table({k: columns[k] for k in TIDY})


@pytest.fixture(scope="module")
def trials(tmp_path_factory):
    """Two synthetic trials run by the batch task in this process: (out, dataset, results)."""
    from predgait.workflows.batch_trial import TrialPoint, run_trial

    folder = tmp_path_factory.mktemp("tables")
    dataset = read_dataset(synthetic_dataset(folder))
    out = folder / "out"
    (out / "trials").mkdir(parents=True)
    results = [run_trial(str(out), TrialPoint(i, {}, job))
               for i, job in enumerate(dataset.trials)]
    return out, dataset, results


def test_the_returned_cycles_equal_the_trials_files(trials):
    out, dataset, results = trials
    for job, result in zip(dataset.trials, results, strict=True):
        folder = out / "trials" / job.id
        files = read_cycle_arrays(folder)
        assert set(result.payload) == set(files)
        for name, array in files.items():
            assert result.payload[name].dtype == array.dtype, name
            np.testing.assert_array_equal(result.payload[name], array)
        ours, theirs = cycles_from_arrays(result.payload), read_cycles(folder)
        assert len(ours) == len(theirs) > 0
        for a, b in zip(ours, theirs, strict=True):
            assert (a.key, a.cycle, a.variable, a.unit, a.flagged) == \
                (b.key, b.cycle, b.variable, b.unit, b.flagged)
            np.testing.assert_array_equal(a.values, b.values)
        assert result.metrics["cycles"] == json.loads(
            (folder / "trial.json").read_text())["cycles"]


def test_the_parquet_table_from_the_arrays_is_the_table_of_the_cycles(trials, tmp_path):
    import pyarrow.parquet as pq

    from predgait.workflows.batch import _write_parquet

    out, dataset, results = trials
    parts = [r.payload for r in results]
    cycles = [c for job in dataset.trials for c in read_cycles(out / "trials" / job.id)]
    for name, (ours, theirs) in {"two trials": (parts, cycles), "none": ([], [])}.items():
        _write_parquet(tmp_path / "ours.parquet", ours)
        pq.write_table(reference_parquet_table(theirs), tmp_path / "theirs.parquet")
        table = pq.read_table(tmp_path / "ours.parquet")
        assert table.schema == pq.read_table(tmp_path / "theirs.parquet").schema, name
        assert table.equals(pq.read_table(tmp_path / "theirs.parquet")), name
        assert (tmp_path / "ours.parquet").read_bytes() == \
            (tmp_path / "theirs.parquet").read_bytes(), name


def test_the_results_table_joins_the_trials_tables(trials, tmp_path):
    from predgait.workflows.batch import _join_tables

    out, dataset, _ = trials
    tables = [out / "trials" / job.id / "cycles.csv" for job in dataset.trials]
    _join_tables(tmp_path / "results.csv", tables)
    expected = ",".join(TIDY) + "\n" + "".join(
        t.read_text().split("\n", 1)[1] for t in tables)
    assert (tmp_path / "results.csv").read_text() == expected
    _join_tables(tmp_path / "empty.csv", [])
    assert (tmp_path / "empty.csv").read_text() == ",".join(TIDY) + "\n"


def test_the_first_trials_alone_are_those_of_the_whole_file(tmp_path):
    path = synthetic_dataset(tmp_path, count=3)
    whole = read_dataset(path)
    assert read_dataset(path, first=2).trials == whole.trials[:2]
    assert read_dataset(path, first=9).trials == whole.trials


def test_the_forkserver_preload_warms_the_first_trials_calibrations(tmp_path, monkeypatch,
                                                                   count_leg_calibrations):
    """The preload computes subject01's leg calibration for the first trial; the trial's
    own call then finds it kept (no second calibration) and it is the same."""
    from predgait.dynamics.leg_measurements import read_trial
    from predgait.workflows import batch_preload, batch_warm

    text = (REPO / "problems" / "batch_subject01.toml").read_text().replace(
        '"inverse_subject01', f'"{REPO}/problems/inverse_subject01').replace(
        '"markers_fullbody', f'"{REPO}/problems/markers_fullbody')
    dataset = tmp_path / "d.toml"
    dataset.write_text(text)
    calls = count_leg_calibrations(monkeypatch)
    monkeypatch.setenv(batch_preload.ENV, json.dumps({"dataset": str(dataset), "first": 1,
                                                      "trials": None}))
    batch_preload._warm_from_environment()
    job = read_dataset(dataset).trials[0]
    assert len(calls) == len(job.legs) > 0 and len(batch_warm._kept) == len(job.legs)
    for options in job.legs:
        turn = read_trial(options)[1]
        assert batch_warm.leg_calibration(options, turn) is not None
    assert len(calls) == len(job.legs)   # kept: not computed again
    monkeypatch.setenv(batch_preload.ENV, "not json")
    batch_preload._warm_from_environment()   # a bad spec: nothing warmed, no error
