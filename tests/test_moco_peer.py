"""The benchmark's reading of an OpenSim Moco run (benchmarks/moco_peer.py), without OpenSim.

Speed itself is measured in benchmarks/bench_optimisation.py; here only the helper logic:
how far a stopped Ipopt run got, and "peer not available" without OPENSIM_PYTHON.
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from moco_peer import last_iteration, run_moco  # noqa: E402

IPOPT = """\
Total number of variables............................:      302
iter    objective    inf_pr   inf_du lg(mu)  ||d||  lg(rg) alpha_du alpha_pr  ls
   0  2.5970343e-01 5.28e+03 2.21e-05   0.0 0.00e+00    -  0.00e+00 0.00e+00   0
   4  5.8719770e-01 3.59e+03 6.55e+08   5.4 9.02e+02    -  9.90e-01 1.42e-01h  1
   5r 5.8719770e-01 3.59e+03 2.77e+02   5.4 0.00e+00    -  0.00e+00 3.89e-07R  3
"""


def test_last_iteration_reports_the_last_line_and_the_restoration_phase():
    said = last_iteration(IPOPT)
    assert said.startswith("Ipopt iteration 5 (restoration phase)")
    assert "constraint violation 3.59e+03" in said
    assert "dual infeasibility 2.77e+02" in said
    assert last_iteration(IPOPT.replace("   5r", "   6 ")).startswith("Ipopt iteration 6,")


def test_no_iteration_line_gives_nothing():
    assert last_iteration("Total number of variables............................: 302\n") == ""
    assert last_iteration("") == ""


def test_without_opensim_python_the_peer_is_not_available(monkeypatch):
    monkeypatch.delenv("OPENSIM_PYTHON", raising=False)
    runs = run_moco({}, repeat=1, minutes=0.1)
    assert runs.in_process is None and runs.whole is None
    assert "OPENSIM_PYTHON" in runs.why
    assert runs.describe().startswith("peer not available")
