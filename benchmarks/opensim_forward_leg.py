"""OpenSim's forward simulation of predgait's planar leg (run by bench_forward.py).

Usage: python benchmarks/opensim_forward_leg.py SETUP.npz

Reads the leg's segments (as benchmarks/opensim_leg.py), the initial ankle and knee
angles (predgait coordinates, rad), the duration (s), the integrator accuracy and the
number of repeats; builds the same leg with the OpenSim API, locks the foot (the
PlanarJoint's three coordinates: the collapse test, foot still) and integrates with
OpenSim's Manager (Runge-Kutta-Merson, the given accuracy), each repeat from a fresh
copy of the initial state. Prints one JSON line: wall and CPU seconds per repeat, the
final ankle and knee angles in predgait's coordinates and OpenSim's version. Only numpy
and opensim are imported (OpenSim's bundled CasADi clashes with the casadi wheel).
"""

import json
import sys
import time

import numpy as np
import opensim as osim
from opensim_leg import ORDER, SIGN, build_leg


def main(path):
    data = dict(np.load(path))
    model, state = build_leg(data, float(data["gravity"]))
    coords = model.getCoordinateSet()
    q0 = np.zeros(5)
    q0[3:] = data["x0"][:2]
    osim_q = SIGN * q0[ORDER]
    for i in range(5):
        coords.get(i).setValue(state, float(osim_q[i]))
        coords.get(i).setSpeedValue(state, 0.0)
    for i in range(3):  # the foot: PlanarJoint rz, tx, ty locked
        coords.get(i).setLocked(state, True)
    duration, accuracy = float(data["duration"]), float(data["accuracy"])
    wall, cpu, final = [], [], None
    for _ in range(int(data["repeat"])):
        start = osim.State(state)
        manager = osim.Manager(model)
        manager.setIntegratorAccuracy(accuracy)
        w0, c0 = time.perf_counter(), time.process_time()
        manager.initialize(start)
        end = manager.integrate(duration)
        cpu.append(time.process_time() - c0)
        wall.append(time.perf_counter() - w0)
        q = np.array([coords.get(i).getValue(end) for i in range(5)])
        final = np.zeros(5)
        final[ORDER] = SIGN * q
    print(json.dumps({"wall": wall, "cpu": cpu, "final": final[3:].tolist(),
                      "version": osim.__version__}))


if __name__ == "__main__":
    main(sys.argv[1])
