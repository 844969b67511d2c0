"""OpenSim's contact sphere positions and toe spring torques of 2D_gait_toes.osim, written once.

Run with the OpenSim 4.6 Python (the peer; predgait never imports opensim):

    $OPENSIM_PYTHON tests/reference/osim2d/make_toes_reference.py

Writes ``toes_reference.csv`` next to itself: for 6 seeded random poses and speeds of the
model (every coordinate within half its range), one row per contact sphere: ``pose``,
``sphere``, the 12 coordinates and the 12 speeds (``<name>.speed``), the sphere centre in
ground ``x``, ``y``, ``z`` (m, OpenSim frames: X forward, Y up, Z right) and the two toe
springs' generalised forces ``mtp_passive_r``, ``mtp_passive_l`` (N m, the force's record
value). 15 significant digits.
"""

import csv
from pathlib import Path

import numpy as np
import opensim as osim

HERE = Path(__file__).resolve().parent
MODEL = HERE.parents[2] / "src" / "predgait" / "datasets" / "moco_2d_walking" / \
    "2D_gait_toes.osim"


def main():
    model = osim.Model(str(MODEL))
    state = model.initSystem()
    coords = model.getCoordinateSet()
    names = [coords.get(i).getName() for i in range(coords.getSize())]
    spheres = [model.getContactGeometrySet().get(i).getName()
               for i in range(model.getContactGeometrySet().getSize())]
    spheres = [s for s in spheres if s != "floor"]
    springs = ["mtp_passive_r", "mtp_passive_l"]
    rng = np.random.default_rng(26)
    rows = []
    for pose in range(6):
        values, speeds = {}, {}
        for name in names:
            c = coords.get(name)
            low, high = c.getRangeMin(), c.getRangeMax()
            mid, half = 0.5 * (low + high), 0.25 * (high - low)
            values[name] = mid + half * rng.uniform(-1, 1)
            speeds[name] = rng.uniform(-2, 2)
            c.setValue(state, values[name], False)
            c.setSpeedValue(state, speeds[name])
        model.assemble(state)
        model.realizeVelocity(state)
        torque = {n: osim.SpringGeneralizedForce.safeDownCast(model.getComponent(n))
                  .getRecordValues(state).get(0) for n in springs}
        for name in spheres:
            g = osim.ContactSphere.safeDownCast(model.getContactGeometrySet().get(name))
            p = g.getFrame().findStationLocationInGround(state, g.get_location())
            rows.append({"pose": pose, "sphere": name, **values,
                         **{f"{n}.speed": speeds[n] for n in names},
                         "x": p.get(0), "y": p.get(1), "z": p.get(2), **torque})
    with open(HERE / "toes_reference.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        for row in rows:
            writer.writerow({k: (f"{v:.15g}" if isinstance(v, float) else v)
                             for k, v in row.items()})
    print(f"wrote {len(rows)} rows")


if __name__ == "__main__":
    main()
