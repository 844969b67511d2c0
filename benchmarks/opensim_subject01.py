"""OpenSim 4.6's own tools on subject01_walk1 (the peer of bench_fullbody.py, bench_inverse.py).

Usage: OPENSIM_PYTHON benchmarks/opensim_subject01.py GAIT2354_DIR [--tools ik,id] [--repeat N]

GAIT2354_DIR holds opensim-models' Pipelines/Gait2354_Simbody files: subject01_Setup_IK.xml,
subject01_Setup_InverseDynamics.xml, subject01_walk1.trc, subject01_walk1_grf.mot/.xml,
subject01_walk1_ik.mot and subject01_simbody.osim (copied there from OutputReference/).
Runs the InverseKinematicsTool (0.4-1.6 s, Gait2354's 23 coordinates) and/or the
InverseDynamicsTool (same window, coordinates low-passed at 6 Hz; after IK when both run,
else on the shipped subject01_walk1_ik.mot) N times each, model loading included as in a
tool run, and prints one JSON line: the wall and CPU seconds of every run, the frames
solved and the OpenSim version. Timed as a whole process from outside with ``--repeat 1``,
the figure includes starting Python and importing opensim.
"""

import argparse
import json
import os
import shutil
import tempfile
import time
from pathlib import Path

import opensim as osim

osim.Logger.removeFileSink()   # no opensim.log in the working folder
osim.Logger.setLevelString("error")

FILES = ("subject01_Setup_IK.xml", "subject01_Setup_InverseDynamics.xml",
         "subject01_walk1.trc", "subject01_walk1_grf.mot", "subject01_walk1_grf.xml",
         "subject01_walk1_ik.mot", "subject01_simbody.osim")


def timed(run, repeat):
    wall, cpu = [], []
    for _ in range(repeat):
        w0, c0 = time.perf_counter(), time.process_time()
        run()
        cpu.append(time.process_time() - c0)
        wall.append(time.perf_counter() - w0)
    return {"wall": wall, "cpu": cpu}


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("folder", type=Path)
    parser.add_argument("--tools", default="ik,id")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    tools = args.tools.split(",")
    work = Path(tempfile.mkdtemp(prefix="osim_subject01_"))
    for name in FILES:
        shutil.copy(args.folder / name, work)
    if "ik" in tools:   # IK writes its own motion; ID then reads that one
        (work / "subject01_walk1_ik.mot").unlink()
    os.chdir(work)

    def ik():
        tool = osim.InverseKinematicsTool("subject01_Setup_IK.xml")
        tool.setResultsDir(str(work))
        tool.run()

    def id_():
        tool = osim.InverseDynamicsTool("subject01_Setup_InverseDynamics.xml")
        tool.setResultsDir(str(work))
        tool.setCoordinatesFileName("subject01_walk1_ik.mot")
        tool.run()

    out = {"version": osim.__version__}
    if "ik" in tools:
        out["ik"] = timed(ik, args.repeat)
    if "id" in tools:
        out["id"] = timed(id_, args.repeat)
        out["frames"] = osim.TimeSeriesTable("inverse_dynamics.sto").getNumRows()
    shutil.rmtree(work, ignore_errors=True)
    print(json.dumps(out))


if __name__ == "__main__":
    main()
