"""OpenSim Moco as the peer of the leg optimisations: its inputs, a bounded run, its report.

The problems are posed in opensim_moco_leg.py (run in the Python named by OPENSIM_PYTHON);
this module gives it the same leg, window, grid and measured data as predgait's
collocation (problems/fitting.py), runs it as fresh processes each stopped after
``minutes``, and turns what came back into :class:`timing.Timing` figures, or into the
reason there is no figure (not available, stopped by the time bound with the Ipopt
iteration it had reached, or Ipopt's failure status).
"""

from __future__ import annotations

import re
import resource
import subprocess
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from timing import HERE, NOT_AVAILABLE, Timing, leg_segments, opensim_python

from predgait.problems.collocation import NodeData, Transcription

SCRIPT = HERE / "opensim_moco_leg.py"
HS = Transcription.HERMITE_SIMPSON
#: One line of Ipopt's iteration table: iteration (r: restoration), objective, inf_pr, inf_du.
IPOPT_LINE = re.compile(r"^\s*(\d+)(r?)\s+(\S+)\s+(\S+)\s+(\S+)\s+\S+\s+\S+", re.MULTILINE)


@dataclass(frozen=True)
class MocoRuns:
    """What the Moco runs gave: timings only when every run finished and Ipopt succeeded.

    Attributes:
        in_process: build + solve inside each fresh process (the first solve: cold).
        whole: each whole process (interpreter, imports, build, solve).
        facts: the peer's own figures of the last run (mesh points, states, controls,
            iterations, status, parameters, RMS angle errors), or {}.
        why: the reason there are no timings ("" when there are).
    """

    in_process: Timing | None
    whole: Timing | None
    facts: dict
    why: str = ""

    def describe(self, unit: str = "s") -> str:
        if self.in_process is None:
            return f"{NOT_AVAILABLE} ({self.why})"
        return (f"in process {self.in_process.describe(unit)}; whole process "
                f"{self.whole.describe(unit)}")


def moco_inputs(inverse, drivers, mode: str, intervals: int, window=(0.0, 1.0), *,
                foot: str = "tracked", joints=("knee",)) -> dict:
    """The arrays opensim_moco_leg.py reads: the same leg, window, grid and data as predgait.

    Measured histories are sampled every 5 ms (Moco's GCV splines of them) and on the
    Hermite-Simpson grid of ``intervals`` (the reference and the guess); the start and
    bounds of the spring-damper parameters are :func:`predgait.problems.fitting.fit_knee`'s.
    """
    t0, t1 = window
    nodes = NodeData.from_drivers(drivers, t0, t1, HS.grid_intervals(intervals))
    dense = NodeData.from_drivers(drivers, t0, t1, round((t1 - t0) / 0.005))
    model = inverse.model
    frame = model.pin_model.frames[model.frame_id("hip_center")]   # on the thigh
    lab_to_osim = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
    a = np.array([drivers.reference_qdd(t) for t in nodes.t])
    return {**leg_segments(model), "mode": mode, "foot": foot, "joints": list(joints),
            "intervals": intervals, "t_dense": dense.t, "qb_dense": dense.qb,
            "tau_dense": dense.tau, "hip_dense": dense.hip,
            "hip_point": lab_to_osim @ frame.placement.translation, "t_nodes": nodes.t,
            "x0": nodes.x_ref[0], "q_nodes": np.column_stack([nodes.qb, nodes.x_ref[:, :2]]),
            "qd_nodes": np.column_stack([nodes.vb, nodes.x_ref[:, 2:]]),
            "qdd_nodes": a, "tau_nodes": nodes.tau, "p0": [10.0, 1.0, 0.0],
            "k_max": 2000.0, "c_max": 200.0, "theta0_max": np.radians(60.0),
            # correct_torques: 1e4 x the mean squared error of 2 angles (rad^2) and 1 x the
            # mean (change / 10 N m)^2 of 2 moments; Moco integrates sums over 1 s and its
            # controls are in units of 100 N m: weights 5e3 and 50. fit_knee: angles only.
            "tracking_weight": 5e3 if mode == "torque_correction" else 1e2,
            "base_weight": 1.0, "effort_weight": 1e-3, "change_weight": 50.0,
            # Moco's settings that did best here: explicit dynamics (implicit: restoration
            # phase); variables scaled by their bounds for the parameter fits only (the
            # torque correction then stalls at dual infeasibility ~1).
            "tol": 1e-4, "hessian": "limited-memory", "dynamics": "explicit",
            "scale": mode == "knee_fit", "sparsity": "random",
            "max_iter": 3000, "print_level": 5, "repeat": 1}


def last_iteration(output: str) -> str:
    """The last Ipopt iteration line in ``output``, said in words ("" if there is none)."""
    lines = IPOPT_LINE.findall(output)
    if not lines:
        return ""
    k, restoration, objective, inf_pr, inf_du = lines[-1]
    phase = " (restoration phase)" if restoration else ""
    return (f"Ipopt iteration {k}{phase}, objective {objective}, constraint violation "
            f"{inf_pr}, dual infeasibility {inf_du}")


def _text(stream) -> str:
    if stream is None:
        return ""
    return stream.decode(errors="replace") if isinstance(stream, bytes) else stream


def run_moco(arrays: dict, repeat: int, minutes: float) -> MocoRuns:
    """opensim_moco_leg.py on ``arrays`` in ``repeat`` fresh processes, each at most
    ``minutes``; stops at the first run that does not finish or fails. The processes run
    in a temporary folder: Moco writes its tracked states and a stop file where it runs."""
    python = opensim_python()
    if python is None:
        return MocoRuns(None, None, {}, "OPENSIM_PYTHON is not set to a Python that "
                                        "imports opensim")
    inside_wall, inside_cpu, whole_wall, whole_cpu, facts = [], [], [], [], {}
    with tempfile.TemporaryDirectory() as tmp:
        file = Path(tmp) / "moco.npz"
        for _ in range(repeat):
            np.savez(file, **arrays)
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            w0 = time.perf_counter()
            try:
                done = subprocess.run([python, str(SCRIPT), str(file)], capture_output=True,
                                      text=True, timeout=60 * minutes, cwd=tmp)
            except subprocess.TimeoutExpired as stopped:
                reached = last_iteration(_text(stopped.stdout)) or "before Ipopt's first " \
                                                                   "iteration"
                return MocoRuns(None, None, facts, f"did not finish in {minutes:g} min; "
                                                   f"stopped at {reached}")
            whole_wall.append(time.perf_counter() - w0)
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            whole_cpu.append(after.ru_utime - before.ru_utime + after.ru_stime
                             - before.ru_stime)
            if done.returncode != 0:
                last = (done.stderr.strip().splitlines() or ["no message"])[-1]
                return MocoRuns(None, None, facts, f"the Moco run failed: {last}")
            out = dict(np.load(file))
            facts = {key: out[key].tolist() for key in (
                "version", "status", "success", "iterations", "parameters", "rms_deg",
                "points", "states", "controls")}
            if not facts["success"]:
                return MocoRuns(None, None, facts, f"Ipopt stopped with {facts['status']} "
                                                   f"after {facts['iterations']} iterations "
                                                   f"in {whole_wall[-1]:.0f} s")
            inside_wall.append(float(out["wall"][0]))
            inside_cpu.append(float(out["cpu"][0]))
    return MocoRuns(Timing(tuple(inside_wall), tuple(inside_cpu)),
                    Timing(tuple(whole_wall), tuple(whole_cpu)), facts)
