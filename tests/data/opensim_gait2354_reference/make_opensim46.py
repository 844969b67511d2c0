"""OpenSim 4.6 on Gait2354's subject01: the joints its moments are about, per frame.

Run with a Python that has OpenSim 4.6 (``pip install opensim``), not predgait's::

    $OPENSIM_PYTHON tests/data/opensim_gait2354_reference/make_opensim46.py GAIT2354_DIR

GAIT2354_DIR holds opensim-models' ``Pipelines/Gait2354_Simbody`` files (commit 20a888b):
``subject01_Setup_InverseDynamics.xml``, ``subject01_walk1_grf.mot/.xml`` and, from its
``OutputReference/``, ``subject01_walk1_ik.mot`` (the IK the shipped results come from,
subtalar held at 0; the pipeline folder's own ``subject01_walk1_ik.mot`` is another, with
the subtalar joint free, up to 15 deg) and ``subject01_simbody.osim``. Writes beside this
script

``opensim46_joints.sto``: at the times of the InverseDynamicsTool's output (its set-up
as shipped: t = 0.4..1.6 s) and from the same filtered coordinates (padded, IIR low-pass at
6 Hz, GCV splines, as the tool does), per side the hip, knee, ankle and subtalar joint
centres (the child frames' origins, m), the hip flexion axis (pelvis Z), the knee axis
(femur Z) with the knee origin's velocity per knee angle (dp/dq, m/rad: the knee's
translation coupler), the tibia's medio-lateral axis (its Z, to the right), the talus'
forward and upward axes (its X and Y; the calcaneus is the talus with the subtalar joint
at 0, as the IK holds it) and the subtalar axis, in OpenSim's ground frame (X forward,
Y up, Z right). The tool's own output is checked against the shipped
``inverse_dynamics.sto`` (OpenSim 4.6 reproduces it to 7e-5 N m) and not stored.
"""

import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np
import opensim as osim

HERE = Path(__file__).resolve().parent
SUBTALAR_AXIS = {"r": (0.78717961, 0.60474746, -0.12094949),
                 "l": (-0.78717961, -0.60474746, -0.12094949)}   # subject01_simbody.osim


def vec(v) -> np.ndarray:
    return np.array([v.get(i) for i in range(3)])


def rot(r) -> np.ndarray:
    return np.array([[r.get(i, j) for j in range(3)] for i in range(3)])


def inverse_dynamics(folder: Path, work: Path) -> Path:
    tool = osim.InverseDynamicsTool(str(folder / "subject01_Setup_InverseDynamics.xml"))
    tool.setModelFileName(str(folder / "subject01_simbody.osim"))
    tool.setCoordinatesFileName(str(folder / "subject01_walk1_ik.mot"))
    tool.setExternalLoadsFileName(str(folder / "subject01_walk1_grf.xml"))
    tool.setResultsDir(str(work))
    tool.setOutputGenForceFileName("inverse_dynamics.sto")
    tool.run()
    return work / "inverse_dynamics.sto"


def joints(folder: Path, times: np.ndarray) -> dict[str, np.ndarray]:
    model = osim.Model(str(folder / "subject01_simbody.osim"))
    state = model.initSystem()
    coordinates = osim.Storage(str(folder / "subject01_walk1_ik.mot"))
    model.getSimbodyEngine().convertDegreesToRadians(coordinates)
    coordinates.pad(coordinates.getSize() // 2)
    coordinates.lowpassIIR(6.0)
    splines = osim.GCVSplineSet(5, coordinates)
    cs, bodies, joint_set = model.getCoordinateSet(), model.getBodySet(), model.getJointSet()
    out: dict[str, list] = {}

    def put(name, value):
        out.setdefault(name, []).append(np.asarray(value, dtype=float))

    for t in times:
        for i in range(cs.getSize()):
            c = cs.get(i)
            c.setValue(state, splines.get(c.getName()).calcValue(osim.Vector(1, t)), False)
        model.realizePosition(state)
        put("pelvis_z", rot(bodies.get("pelvis").getTransformInGround(state).R())[:, 2])
        for s in "rl":
            for joint in ("hip", "knee", "ankle", "subtalar"):
                put(f"{joint}_{s}",
                    vec(joint_set.get(f"{joint}_{s}").getChildFrame().getPositionInGround(state)))
            put(f"knee_{s}_axis",
                rot(bodies.get(f"femur_{s}").getTransformInGround(state).R())[:, 2])
            talus = rot(bodies.get(f"talus_{s}").getTransformInGround(state).R())
            put(f"subtalar_{s}_axis", talus @ np.array(SUBTALAR_AXIS[s]))
            put(f"talus_{s}_forward", talus[:, 0])
            put(f"talus_{s}_up", talus[:, 1])
            put(f"tibia_{s}_right",
                rot(bodies.get(f"tibia_{s}").getTransformInGround(state).R())[:, 2])
            knee, frame = cs.get(f"knee_angle_{s}"), joint_set.get(f"knee_{s}").getChildFrame()
            angle, step, ends = knee.getValue(state), 1e-6, []
            for delta in (step, -step):
                knee.setValue(state, angle + delta, False)
                model.realizePosition(state)
                ends.append(vec(frame.getPositionInGround(state)))
            knee.setValue(state, angle, False)
            model.realizePosition(state)
            put(f"knee_{s}_dpdq", (ends[0] - ends[1]) / (2 * step))
    return {k: np.array(v) for k, v in out.items()}


def write_joints(path: Path, times: np.ndarray, columns: dict[str, np.ndarray]) -> None:
    labels = [f"{name}_{axis}" for name in columns for axis in "xyz"]
    data = np.column_stack([times, *[columns[name] for name in columns]])
    lines = ["opensim46_joints", "version=1", f"nRows={len(times)}",
             f"nColumns={len(labels) + 1}", "inDegrees=no",
             "units=m (joint centres), 1 (unit axes), m/rad (knee dp/dq); OpenSim ground "
             "frame (X forward, Y up, Z right)",
             f"provenance=OpenSim {osim.__version__}, subject01_simbody.osim, "
             "subject01_walk1_ik.mot low-passed at 6 Hz as the InverseDynamicsTool",
             "endheader", "\t".join(["time", *labels])]
    lines += ["\t".join(f"{v:.10g}" for v in row) for row in data]
    path.write_text("\n".join(lines) + "\n")


def largest_difference(a: Path, b: Path) -> float:
    """Largest absolute difference between two storage files' columns (same layout)."""
    ta, tb = osim.TimeSeriesTable(str(a)), osim.TimeSeriesTable(str(b))
    return max(float(np.max(np.abs(ta.getDependentColumn(c).to_numpy()
                                   - tb.getDependentColumn(c).to_numpy())))
               for c in ta.getColumnLabels())


def main() -> None:
    folder = Path(sys.argv[1]).resolve()
    work = Path(tempfile.mkdtemp(prefix="opensim46_"))
    try:
        result = inverse_dynamics(folder, work)
        print(f"OpenSim {osim.__version__} vs the shipped inverse_dynamics.sto: largest "
              f"difference {largest_difference(result, HERE / 'inverse_dynamics.sto'):.2g}")
        times = np.array(osim.TimeSeriesTable(str(result)).getIndependentColumn())
        write_joints(HERE / "opensim46_joints.sto", times, joints(folder, times))
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
