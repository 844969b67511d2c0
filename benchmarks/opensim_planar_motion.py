"""OpenSim 4.6 plays a planar motion on 2D_gait.osim and gives its bodies' poses (peer of
tests/test_osim2d_motion.py).

Usage: OPENSIM_PYTHON benchmarks/opensim_planar_motion.py MODEL.osim MOTION.mot OUT.npz
Loads the model with OpenSim's API and the motion with OpenSim's Storage (degrees turned
into radians by the model, as OpenSim's GUI and tools do when the file says
inDegrees=yes), sets every coordinate the motion names at each row, realizes positions
and writes to OUT.npz: ``coordinates`` (n, k) the values OpenSim holds (rad, m) with
``labels``; ``angles`` (n, b) each body's rotation about the ground's Z (rad) with
``bodies``; ``hips`` (n, 2, 3) the ground positions of femur_r and femur_l (m). Prints
one JSON line.
"""

import json
import sys

import numpy as np
import opensim as osim

osim.Logger.removeFileSink()
osim.Logger.setLevelString("error")

BODIES = ("pelvis", "torso", "femur_r", "tibia_r", "calcn_r", "femur_l", "tibia_l", "calcn_l")


def main(model_path: str, motion_path: str, out: str) -> None:
    model = osim.Model(model_path)
    state = model.initSystem()
    storage = osim.Storage(motion_path)
    if storage.isInDegrees():
        model.getSimbodyEngine().convertDegreesToRadians(storage)
    labels = [storage.getColumnLabels().get(i) for i in range(storage.getColumnLabels().getSize())]
    labels = [label for label in labels if label != "time"]
    coordinates = model.getCoordinateSet()
    n = storage.getSize()
    values = np.zeros((n, len(labels)))
    angles = np.zeros((n, len(BODIES)))
    hips = np.zeros((n, 2, 3))
    for k in range(n):
        row = storage.getStateVector(k).getData()
        for j, label in enumerate(labels):
            coordinates.get(label).setValue(state, row.get(j), False)
        model.realizePosition(state)
        for j, label in enumerate(labels):
            values[k, j] = coordinates.get(label).getValue(state)
        for i, name in enumerate(BODIES):
            r = model.getBodySet().get(name).getTransformInGround(state).R()
            angles[k, i] = np.arctan2(r.get(1, 0), r.get(0, 0))
        for i, name in enumerate(("femur_r", "femur_l")):
            p = model.getBodySet().get(name).getPositionInGround(state)
            hips[k, i] = [p.get(0), p.get(1), p.get(2)]
    np.savez(out, coordinates=values, labels=np.array(labels), angles=angles,
             bodies=np.array(BODIES), hips=hips)
    print(json.dumps({"frames": n, "coordinates": len(labels), "opensim": osim.__version__}))


if __name__ == "__main__":
    main(*sys.argv[1:4])
