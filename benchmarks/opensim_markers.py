"""OpenSim 4.6 plays a motion on a model and gives the markers' positions (peer of
tests/test_osim_export.py and benchmarks/check_osim_export.py).

Usage: OPENSIM_PYTHON benchmarks/opensim_markers.py MODEL.osim MOTION.mot OUT.npz
Loads the model with OpenSim's API, sets every coordinate of each row of the motion (deg
for rotational coordinates when the file says inDegrees=yes), realizes positions and
writes the markers' ground positions (n_frames, n_markers, 3) m and names to OUT.npz;
prints one JSON line.
"""

import json
import sys

import numpy as np
import opensim as osim

osim.Logger.removeFileSink()
osim.Logger.setLevelString("error")


def main(model_path: str, motion_path: str, out: str) -> None:
    model = osim.Model(model_path)
    state = model.initSystem()
    table = osim.TimeSeriesTable(motion_path)
    degrees = table.getTableMetaDataAsString("inDegrees").strip().lower() == "yes"
    labels = list(table.getColumnLabels())
    coordinates = model.getCoordinateSet()
    markers = model.getMarkerSet()
    names = [markers.get(i).getName() for i in range(markers.getSize())]
    positions = np.zeros((table.getNumRows(), len(names), 3))
    for k in range(table.getNumRows()):
        row = table.getRowAtIndex(k)
        for j, label in enumerate(labels):
            coordinate = coordinates.get(label)
            value = row[j]
            if degrees and coordinate.getMotionType() == 1:   # rotational
                value = np.radians(value)
            coordinate.setValue(state, value, False)
        model.realizePosition(state)
        for i, name in enumerate(names):
            p = markers.get(name).getLocationInGround(state)
            positions[k, i] = [p.get(0), p.get(1), p.get(2)]
    np.savez(out, positions=positions, names=np.array(names))
    print(json.dumps({"frames": table.getNumRows(), "markers": len(names),
                      "coordinates": coordinates.getSize(), "opensim": osim.__version__}))


if __name__ == "__main__":
    main(*sys.argv[1:4])
