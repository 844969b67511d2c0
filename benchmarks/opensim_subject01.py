"""OpenSim 4.6's own tools on subject01_walk1 (run by bench_fullbody.py in its own process).

Usage: OPENSIM_PYTHON benchmarks/opensim_subject01.py GAIT2354_DIR
GAIT2354_DIR holds opensim-models' Pipelines/Gait2354_Simbody files: subject01_Setup_IK.xml,
subject01_Setup_InverseDynamics.xml, subject01_walk1.trc, subject01_walk1_grf.mot/.xml and
OutputReference/subject01_simbody.osim (copied next to them). Prints one JSON line:
seconds for the InverseKinematicsTool and the InverseDynamicsTool (best of 3 runs each,
model loading included as in a tool run, Python import excluded) and the frames solved.
"""

import json
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

import opensim as osim


def best_of(run, repeat=3):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        run()
        times.append(time.perf_counter() - t0)
    return min(times)


def main(source: Path) -> None:
    work = Path(tempfile.mkdtemp(prefix="osim_subject01_"))
    for f in source.iterdir():
        if f.is_file():
            shutil.copy(f, work)
    os.chdir(work)
    osim.Logger.setLevelString("error")

    def ik():
        tool = osim.InverseKinematicsTool("subject01_Setup_IK.xml")
        tool.setResultsDir(str(work))
        tool.run()

    def id_():
        tool = osim.InverseDynamicsTool("subject01_Setup_InverseDynamics.xml")
        tool.setResultsDir(str(work))
        tool.setCoordinatesFileName("subject01_walk1_ik.mot")
        tool.run()

    t_ik = best_of(ik)
    t_id = best_of(id_)
    frames = osim.TimeSeriesTable("inverse_dynamics.sto").getNumRows()
    print(json.dumps({"version": osim.__version__, "ik_s": t_ik, "id_s": t_id,
                      "frames": frames}))


if __name__ == "__main__":
    main(Path(sys.argv[1]))
