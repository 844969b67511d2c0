"""The muscle-driven prediction does not depend on the process' BLAS thread count.

NumPy's least squares (path fits, the guess) round differently on 1 and 2 OpenBLAS
threads, and the prediction's optimum follows round-off: before
:func:`predgait.problems.muscle_prediction.solve_prediction` ran on one BLAS thread, this
12-interval problem gave objective 0.16026686 (89 iterations) with one thread and
0.16022130 (90) with two. Each run is a fresh process with OPENBLAS_NUM_THREADS set.
"""

import os
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SCRIPT = """
import hashlib
from predgait.problemfile import load_problem
from predgait.problems import muscle_prediction as mp
spec = mp.parse_muscle_predict(load_problem(
    "problems/predict_2d_muscles_impact.toml", ("grid.nodes=12", "check.human_likeness=false")))
s = mp.solve_prediction(spec).gait.solved
print(repr(s.objective), s.iterations, hashlib.sha256(s.w.tobytes()).hexdigest())
"""


def run_with_threads(threads: int) -> str:
    env = os.environ | {"OPENBLAS_NUM_THREADS": str(threads), "OMP_NUM_THREADS": str(threads)}
    result = subprocess.run([sys.executable, "-c", SCRIPT], cwd=REPO, env=env,
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    return result.stdout.strip()


def test_one_and_two_blas_threads_give_the_same_optimum_bit_for_bit():
    assert run_with_threads(1) == run_with_threads(2)
