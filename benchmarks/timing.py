"""Shared timing for the benchmarks: repeats, min and median, wall and CPU, and the peer.

Every ratio printed by a benchmark compares two figures measured in the same run by these
functions; when the peer (OpenSim 4.6 in the Python named by the environment variable
OPENSIM_PYTHON) cannot run, the benchmark prints "peer not available" instead of a ratio.
"""

from __future__ import annotations

import contextlib
import json
import os
import resource
import statistics
import subprocess
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
NOT_AVAILABLE = "peer not available"


@dataclass(frozen=True)
class Timing:
    """Repeated measurements of one piece of work, seconds."""

    wall: tuple[float, ...]
    cpu: tuple[float, ...]

    @property
    def best(self) -> float:
        return min(self.wall)

    @property
    def median(self) -> float:
        return statistics.median(self.wall)

    def describe(self, unit: str = "ms") -> str:
        """``min / median wall (min / median CPU)`` in ``unit`` (``ms`` or ``s``)."""
        scale, fmt = (1e3, ".1f") if unit == "ms" else (1.0, ".2f")
        return (f"{min(self.wall) * scale:{fmt}} / {self.median * scale:{fmt}} {unit} wall "
                f"({min(self.cpu) * scale:{fmt}} / {statistics.median(self.cpu) * scale:{fmt}} "
                f"{unit} CPU)")

    def to_json(self) -> dict:
        return {"wall": list(self.wall), "cpu": list(self.cpu)}

    @classmethod
    def from_json(cls, data: dict) -> Timing:
        return cls(tuple(data["wall"]), tuple(data["cpu"]))


def time_call(function: Callable[[], object], repeat: int = 5, *, warmup: bool = False
              ) -> Timing:
    """Wall (perf_counter) and CPU (process_time, all threads) of ``repeat`` calls."""
    if warmup:
        function()
    wall, cpu = [], []
    for _ in range(repeat):
        w0, c0 = time.perf_counter(), time.process_time()
        function()
        cpu.append(time.process_time() - c0)
        wall.append(time.perf_counter() - w0)
    return Timing(tuple(wall), tuple(cpu))


def time_interleaved(sides: Sequence[Callable[[], object]], repeat: int = 5
                     ) -> tuple[Timing, ...]:
    """Wall and CPU of each side, called in turn A, B, A, B ... ``repeat`` times.

    Fair by construction: a change of the machine's load during the run falls on every
    side alike (timing all of A and then all of B charges it to one).
    """
    wall = [[] for _ in sides]
    cpu = [[] for _ in sides]
    for _ in range(repeat):
        for i, side in enumerate(sides):
            w0, c0 = time.perf_counter(), time.process_time()
            side()
            cpu[i].append(time.process_time() - c0)
            wall[i].append(time.perf_counter() - w0)
    return tuple(Timing(tuple(w), tuple(c)) for w, c in zip(wall, cpu, strict=True))


def load_text() -> str:
    """The machine's load while timing: 1, 5, 15 min load averages and the cores."""
    one, five, fifteen = os.getloadavg()
    return (f"load average {one:.2f} / {five:.2f} / {fifteen:.2f} (1 / 5 / 15 min) on "
            f"{os.cpu_count()} cores")


def _adopt_descendants() -> bool:
    """Make this process the reaper of its orphaned descendants (Linux); True if so.

    A child's own children that outlive it (a forkserver and the processes it forked, as
    the batch's Dask workers) are then reparented here, so their CPU is counted once
    :func:`_reap_descendants` has waited for them.
    """
    import ctypes
    import sys

    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(36, 1, 0, 0, 0) == 0   # PR_SET_CHILD_SUBREAPER
    except (OSError, AttributeError):
        return False


def _reap_descendants(timeout: float = 60.0) -> None:
    """Wait (up to ``timeout`` s) for every remaining child, adopted ones included."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        try:
            pid, _ = os.waitpid(-1, os.WNOHANG)
        except ChildProcessError:
            return
        if pid == 0:
            time.sleep(0.01)


def time_process(argv: Sequence[str], repeat: int = 5, *, cwd: Path | str = REPO,
                 env: dict | None = None) -> Timing:
    """Wall and CPU (user + system of the child and all its descendants) of ``repeat``
    whole processes.

    The child may write and read cached bytecode (PYTHONDONTWRITEBYTECODE is dropped from
    the environment), as an installed package does: otherwise every run of an editable
    install recompiles its modules, which no user's run does. On Linux the descendants
    that outlive the child (e.g. a forkserver's workers) are adopted and waited for, so
    their CPU counts; the wall is the child's.

    Raises:
        RuntimeError: the command failed (its last stderr line).
    """
    env = dict(os.environ if env is None else env)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    adopted = _adopt_descendants()
    wall, cpu = [], []
    for _ in range(repeat):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        w0 = time.perf_counter()
        done = subprocess.run(list(argv), cwd=cwd, env=env, capture_output=True, text=True)
        wall.append(time.perf_counter() - w0)
        if adopted:
            _reap_descendants()
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu.append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
        if done.returncode != 0:
            last = (done.stderr.strip().splitlines() or ["?"])[-1]
            raise RuntimeError(f"{' '.join(map(str, argv))} failed: {last}")
    return Timing(tuple(wall), tuple(cpu))


@contextlib.contextmanager
def environment(values: dict):
    """Environment variables set inside the block, restored after."""
    saved = {key: os.environ.get(key) for key in values}
    os.environ.update(values)
    try:
        yield
    finally:
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value


def opensim_python() -> str | None:
    """The peer's Python (OPENSIM_PYTHON) if it imports opensim, else None."""
    python = os.environ.get("OPENSIM_PYTHON")
    if not python:
        return None
    try:
        done = subprocess.run([python, "-c", "import opensim"], capture_output=True,
                              timeout=120)
    except (OSError, subprocess.TimeoutExpired):
        return None
    return python if done.returncode == 0 else None


def run_peer(script: str, *args: str) -> dict:
    """Run ``benchmarks/SCRIPT`` in the peer's Python; its last stdout line is JSON.

    Returns:
        The parsed JSON, or ``{"error": reason}`` when the peer is not available or failed.
    """
    python = opensim_python()
    if python is None:
        return {"error": "OPENSIM_PYTHON is not set to a Python that imports opensim"}
    done = subprocess.run([python, str(HERE / script), *args], capture_output=True, text=True)
    if done.returncode != 0:
        return {"error": (done.stderr.strip().splitlines() or ["failed"])[-1]}
    return json.loads(done.stdout.strip().splitlines()[-1])


def ratio(ours: Timing | None, peer: Timing | None) -> str:
    """``peer/ours`` on the minimum and the median (> 1: predgait faster)."""
    if ours is None or peer is None:
        return NOT_AVAILABLE
    cpu = min(peer.cpu) / min(ours.cpu)
    return (f"{peer.best / ours.best:.2f}x (min wall), {peer.median / ours.median:.2f}x "
            f"(median wall), {cpu:.2f}x (min CPU); > 1 = predgait faster")


def gait2354_folder() -> str | None:
    """opensim-models' Pipelines/Gait2354_Simbody files (GAIT2354_DIR), if given."""
    folder = os.environ.get("GAIT2354_DIR")
    return folder if folder and Path(folder, "subject01_simbody.osim").is_file() else None


@dataclass(frozen=True)
class Row:
    """One line of the comparison table: the same work done by predgait and by the peer."""

    work: str
    ours: Timing | None
    ours_does: str
    peer: Timing | None = None
    peer_does: str = ""
    unit: str = "ms"

    def lines(self) -> list[str]:
        """The row as text: what each side does, min / median wall and CPU, the ratio."""
        ours = self.ours.describe(self.unit) if self.ours else "not run"
        peer = self.peer.describe(self.unit) if self.peer else NOT_AVAILABLE
        out = [f"{self.work}", f"    predgait: {ours}  [{self.ours_does}]",
               f"    OpenSim:  {peer}" + (f"  [{self.peer_does}]" if self.peer_does else "")]
        if self.peer is not None and self.ours is not None:
            out.append(f"    ratio OpenSim/predgait: {ratio(self.ours, self.peer)}")
        return out


def print_rows(rows: Sequence[Row]) -> None:
    """The rows, after the load they were timed under."""
    print(load_text())
    for row in rows:
        print("\n".join(row.lines()))


def markdown_table(rows: Sequence[Row]) -> str:
    """The rows as one Markdown table: min / median wall per side and the ratios."""
    def cell(timing: Timing | None, unit: str) -> str:
        if timing is None:
            return NOT_AVAILABLE
        scale = 1e3 if unit == "ms" else 1.0
        return f"{timing.best * scale:.3g} / {timing.median * scale:.3g} {unit}"

    lines = ["| work | predgait (min / median wall) | OpenSim 4.6 (min / median wall) | "
             "OpenSim / predgait (min wall; min CPU) |", "|---|---|---|---|"]
    for row in rows:
        if row.ours is not None and row.peer is not None:
            ratios = (f"{row.peer.best / row.ours.best:.2f}x; "
                      f"{min(row.peer.cpu) / min(row.ours.cpu):.2f}x")
        else:
            ratios = NOT_AVAILABLE
        lines.append(f"| {row.work} | {cell(row.ours, row.unit)} | "
                     f"{cell(row.peer, row.unit)} | {ratios} |")
    return "\n".join(lines)


def run_peer_npz(script: str, **arrays) -> dict:
    """Run ``benchmarks/SCRIPT FILE.npz`` in the peer's Python on ``arrays``; returns the
    arrays it wrote back (with ``timing``: a :class:`Timing` from its ``wall``/``cpu``), or
    ``{"error": reason}``."""
    import numpy as np

    python = opensim_python()
    if python is None:
        return {"error": "OPENSIM_PYTHON is not set to a Python that imports opensim"}
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "exchange.npz"
        np.savez(path, **arrays)
        done = subprocess.run([python, str(HERE / script), str(path)], capture_output=True,
                              text=True)
        if done.returncode != 0:
            return {"error": (done.stderr.strip().splitlines() or ["failed"])[-1]}
        out = dict(np.load(path))
    out["timing"] = Timing(tuple(map(float, out["wall"])), tuple(map(float, out["cpu"])))
    return out


def leg_segments(model) -> dict:
    """The leg's segments in OpenSim axes (Y up) for opensim_leg.py."""
    import numpy as np

    lab_to_osim = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
    pm = model.pin_model
    inertias = [pm.inertias[j] for j in range(1, pm.njoints)]
    return {"mass": [i.mass for i in inertias], "inertia": [i.inertia[1, 1] for i in inertias],
            "com": [lab_to_osim @ i.lever for i in inertias],
            "offset": [lab_to_osim @ pm.jointPlacements[j].translation for j in range(1, 4)],
            "gravity": model.gravity}
