"""Solved muscle-driven baselines kept on disk: a scenario run does not solve its baseline again.

``predgait scenario`` on a muscle scenario solves its baseline problem before the edit
(~40-60 s at 50 intervals on a 2-core machine), and that problem is the same every time a
scenario of the same baseline file runs. When it converges (and has no ``[multistart]``),
every solve of it (the stages, then the prediction) is stored: Ipopt's point, multipliers,
parameters and statistics. A later run with the same key rebuilds the NLP's graph (not
its solver: ~2 s) and evaluates the stored points, so its gait, Pinocchio check and
stride are recomputed, not read.

The key (:func:`baseline_key`) is a SHA-256 of everything the solve depends on: predgait's
own source code (every ``.py`` file of the package), the CasADi, NumPy and SciPy versions,
the parsed problem (:class:`~predgait.problems.muscle_prediction.MusclePredictSpec`) and
the bytes of its model and reference files. The solve runs on one BLAS thread, so the
stored answer is the one a new solve of the same problem would return on this machine
(another OpenBLAS kernel can round differently: issue 26 item 6).

Files: ``muscle-baseline-KEY.npz`` in the cache folder of :mod:`predgait.function_cache`
(pruned with it), written under a temporary name and renamed. Off with
``PREDGAIT_SOLVER_CACHE=off``. A file that cannot be read is reported in one line and the
baseline is solved again.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from predgait import function_cache
from predgait.problems.collocation import Solved

log = logging.getLogger(__name__)
#: Bumped when the stored layout changes.
LAYOUT = "muscle-baseline 1"
HISTORY = ("objective", "constraint_violation", "dual_infeasibility")


@dataclass(frozen=True)
class StoredSolve:
    """One stored Ipopt solve: its name (a stage's, or "prediction"), parameters, outcome."""

    name: str
    p: np.ndarray
    solved: Solved


def _source_digest() -> str:
    """SHA-256 of predgait's own Python source (every .py file, by relative path)."""
    package = Path(__file__).resolve().parents[1]
    digest = hashlib.sha256()
    for path in sorted(package.rglob("*.py")):
        digest.update(str(path.relative_to(package)).encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def baseline_key(spec, files: list[Path]) -> str:
    """The key of a baseline problem: code, library versions, spec, file contents."""
    import numpy
    import scipy

    parts = [LAYOUT, _source_digest(), numpy.__version__, scipy.__version__, repr(spec)]
    parts += [Path(f).read_bytes() for f in files]
    return function_cache.key_of(parts)


def _path(key: str) -> Path:
    return function_cache.cache_folder() / f"muscle-baseline-{key}.npz"


def enabled() -> bool:
    """Stored baselines are used (the cache is on and its folder is the user's own)."""
    from predgait import cache_library

    return function_cache.enabled() and cache_library.usable(function_cache.cache_folder(),
                                                             function_cache.SWITCH)


def load(key: str) -> tuple[list[StoredSolve], Path] | None:
    """The stored solves of ``key`` (in order) and their file, or None."""
    path = _path(key)
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as data:
            meta = json.loads(str(data["meta"]))
            solves = []
            for i, m in enumerate(meta["solves"]):
                history = {h: data[f"{i}_{h}"].tolist() for h in HISTORY}
                solved = Solved(w=data[f"{i}_w"], status=m["status"], success=m["success"],
                                iterations=m["iterations"], seconds=m["seconds"],
                                objective=m["objective"],
                                constraint_violation=m["constraint_violation"],
                                history=history,
                                multipliers=(data[f"{i}_lam_x"], data[f"{i}_lam_g"]))
                solves.append(StoredSolve(m["name"], data[f"{i}_p"], solved))
    except (OSError, ValueError, KeyError, TypeError) as exc:
        log.warning("stored baseline %s cannot be read (%s): solving it again", path.name,
                    str(exc).splitlines()[0][:200] if str(exc) else type(exc).__name__)
        return None
    path.touch()            # recently used: kept by function_cache.prune
    return solves, path


def store(key: str, solves: list[StoredSolve]) -> Path | None:
    """Write the solves under ``key`` (whole or not at all); None if it cannot be written."""
    path = _path(key)
    arrays = {"meta": np.array(json.dumps({"solves": [
        {"name": s.name, "status": s.solved.status, "success": s.solved.success,
         "iterations": s.solved.iterations, "seconds": s.solved.seconds,
         "objective": s.solved.objective,
         "constraint_violation": s.solved.constraint_violation} for s in solves]}))}
    for i, s in enumerate(solves):
        arrays |= {f"{i}_w": s.solved.w, f"{i}_p": s.p,
                   f"{i}_lam_x": s.solved.multipliers[0], f"{i}_lam_g": s.solved.multipliers[1],
                   **{f"{i}_{h}": np.asarray(s.solved.history.get(h, []), float)
                      for h in HISTORY}}
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=path.parent, prefix=f".{path.name}.",
                                         suffix=".tmp", delete=False) as handle:
            np.savez(handle, **arrays)
        os.replace(handle.name, path)
    except OSError as exc:
        log.warning("baseline not stored in %s: %s", path.parent, exc)
        return None
    return path
