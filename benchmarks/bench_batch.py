"""Batch throughput: ``predgait batch`` on 20 (and 80) trials with 2 workers, against
OpenSim 4.6's IK + ID tools called per trial (issue 31, item 4).

Run: python benchmarks/bench_batch.py [--trials 20 80] [--analyses leg fullbody]
     [--workers 2] [--peer-repeat 3]

Datasets (built in a temporary folder): leg: half copies of the bundled subject01 walk
(TRC + GRF MOT + XML, static trial, both legs' problem files: right leg analysed), half
synthetic leg walks with known answers (mass 55-95 kg, cadence 0.75-1.0 Hz, speed
0.5-1.2 m/s; :mod:`predgait.simulations.synthetic_trials`); fullbody: copies of the
subject01 walk (35-DOF IK and ID of the whole trial, 151 frames). Each batch is timed as
one whole process (``predgait batch ... --no-plots``: Python start-up, the Dask cluster,
every trial, the dataset tables and report): trials per minute = trials x 60 / wall.
The peer: ``benchmarks/opensim_subject01.py GAIT2354_DIR --tools ik,id`` as one process
per trial (OpenSim's InverseKinematicsTool and InverseDynamicsTool on Gait2354, the
0.4-1.6 s window of 76 frames, model loading included), one trial after another; its
trials per minute = 60 / wall of one process, timed (--peer-repeat times) right before
each batch, so both see the same load. Needs OPENSIM_PYTHON and GAIT2354_DIR, else
"peer not available". The machine's load average is printed before and after. Note the
work per trial differs: predgait analyses the whole walk (151 frames), the peer's setup
files the 0.4-1.6 s window (76 frames).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np
from timing import (
    NOT_AVAILABLE,
    REPO,
    Row,
    Timing,
    gait2354_folder,
    opensim_python,
    print_rows,
    time_process,
)

from predgait.data.bundled import bundled_path
from predgait.simulations.synthetic_trials import SyntheticWalk, write_synthetic_trial

HERE = Path(__file__).resolve().parent
PREDGAIT = [sys.executable, "-m", "predgait"]


def write_dataset(folder: Path, trials: int, analysis: str) -> Path:
    """A dataset of ``trials`` trials for ``analysis`` (leg | fullbody) in ``folder``."""
    walk = bundled_path("subject01_walk1")
    real = trials if analysis == "fullbody" else trials - trials // 2
    copies = folder / "subject01"
    copies.mkdir(parents=True)
    for k in range(real):
        stem = f"walk_{k:03d}"
        shutil.copy(walk / "subject01_walk1.trc", copies / f"{stem}.trc")
        shutil.copy(walk / "subject01_walk1_grf.mot", copies / f"{stem}_grf.mot")
        shutil.copy(walk / "subject01_walk1_grf.xml", copies / f"{stem}_grf.xml")
    text = (f'name = "bench {analysis} {trials}"\nanalyses = ["{analysis}"]\n\n'
            '[[subjects]]\nname = "subject01"\nmass = 72.6\nheight = 1.8034\n'
            'static = "bundled:subject01_walk1/subject01_static.trc"\n'
            f'leg = ["{REPO}/problems/inverse_subject01.toml"]\n'
            f'marker_map = "{REPO}/problems/markers_fullbody_subject01.toml"\n\n'
            '[[trials]]\nsubject = "subject01"\ncondition = "real"\n'
            'markers = "subject01/walk_*.trc"\ngrf = "{stem}_grf.mot"\n')
    rng = np.random.default_rng(31)
    for k in range(trials - real):
        name = f"syn{k:03d}"
        synthetic = SyntheticWalk(mass=float(rng.uniform(55, 95)),
                                  height=float(rng.uniform(1.6, 1.95)),
                                  cadence=float(rng.uniform(0.75, 1.0)),
                                  speed=float(rng.uniform(0.5, 1.2)))
        write_synthetic_trial(folder / name, synthetic)
        text += (f'\n[[subjects]]\nname = "{name}"\nmass = {synthetic.mass!r}\n'
                 f'height = {synthetic.height!r}\nleg = ["{name}/inverse.toml"]\n'
                 f'\n[[trials]]\nsubject = "{name}"\ncondition = "synthetic"\n'
                 f'markers = "{name}/markers.csv"\ngrf = "{name}/grf.mot"\n')
    path = folder / "dataset.toml"
    path.write_text(text)
    return path


def batch_timing(trials: int, analysis: str, workers: int) -> tuple[Timing, dict]:
    """One whole ``predgait batch`` process: its timing per trial and its summary."""
    with tempfile.TemporaryDirectory() as tmp:
        dataset = write_dataset(Path(tmp), trials, analysis)
        out = Path(tmp) / "out"
        whole = time_process([*PREDGAIT, "batch", str(dataset), "--out", str(out),
                              "--workers", str(workers), "--no-plots"], repeat=1)
        summary = json.loads((out / "summary.json").read_text())
    if summary["ok"] != trials:
        raise RuntimeError(f"{analysis} batch: {summary}")
    per_trial = Timing(tuple(w / trials for w in whole.wall),
                       tuple(c / trials for c in whole.cpu))
    return per_trial, summary


def peer_timing(repeat: int) -> Timing | None:
    """OpenSim's IK + ID tools on subject01 as one process per trial."""
    folder, python = gait2354_folder(), opensim_python()
    if folder is None or python is None:
        return None
    return time_process([python, str(HERE / "opensim_subject01.py"), folder,
                         "--tools", "ik,id", "--repeat", "1"], repeat=repeat)


def rows(repeat: int = 3, *, trials=(20, 80), analyses=("leg", "fullbody"),
         workers: int = 2) -> list[Row]:
    """Per-trial wall of each batch against the peer's per-trial process, the peer timed
    again right before each batch (the machine's load drifts between rows)."""
    out = []
    for analysis in analyses:
        for count in trials:
            peer = peer_timing(repeat)
            timing, summary = batch_timing(count, analysis, workers)
            does = (f"{count} trials, {workers} workers, whole process / trials "
                    f"({60 / timing.best:.1f} trials/min; in-run "
                    f"{summary['trials_per_minute']:.1f}/min)")
            out.append(Row(f"batch {analysis} inverse, {count} trials (per trial)", timing,
                           does, peer, "IK + ID tools, one process per trial "
                           + (f"({60 / peer.median:.1f} trials/min)" if peer else ""), "s"))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, nargs="+", default=[20, 80])
    parser.add_argument("--analyses", nargs="+", default=["leg", "fullbody"])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--peer-repeat", type=int, default=3)
    args = parser.parse_args()
    print(f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())} "
          f"({os.cpu_count()} cores)")
    table = rows(args.peer_repeat, trials=args.trials, analyses=args.analyses,
                 workers=args.workers)
    print_rows(table)
    if table[0].peer is None:
        print(f"OpenSim: {NOT_AVAILABLE}")
    print(f"load average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
