"""OpenSim's body frames and kinetic energy for predgait's osim2d model tests, written once.

Run with the OpenSim 4.6 Python (the peer; predgait never imports opensim):

    OMP_NUM_THREADS=1 $OPENSIM_PYTHON tests/reference/osim2d/make_body_frames.py \
        [--model PATH/2D_gait.osim]

Beside ``make_reference.py`` (whose ``model_frames.csv`` holds the body frames of the
unmodified 2D gait model), this writes, next to itself:

``offsets_2d_gait.osim``: 2D_gait.osim with offset frames the original does not have, saved
    by OpenSim 4.6 itself (``Model.printToXML``, format 40600, every property written): the
    pelvis' PlanarJoint child frame translated and turned about Z, the left hip's child frame,
    the right knee's parent and child frames, the right subtalar weld's frames and the lumbar
    parent frame turned about Z; products of inertia on the torso and the right talus. It
    tests the link-frame and inertia mapping of ``predgait.models.osim_model`` and that the
    reader takes a file OpenSim wrote.
``offsets_frames.csv``: for that model at 5 poses, one row per body: ``pose``, ``name``, the
    10 coordinates, ``x/y/z`` (body origin in ground, m), ``com_x/y/z`` (body COM in ground,
    m), ``r00..r22`` (body rotation to ground, row-major).
``kinetic_energy.csv``: for both models (``model`` = ``original`` or ``offsets``), 5 poses x
    3 random speed vectors: the 10 coordinates, the 10 speeds ``<coordinate>.speed`` (rad/s,
    m/s) and OpenSim's kinetic energy ``kinetic_energy`` (J,
    SimbodyMatterSubsystem.calcKineticEnergy). 0.5 v^T M(q) v must equal it for every v: a
    check of the whole planar mass matrix (in which, of a body's inertia, only Izz appears).

Everything in OpenSim's frames (X forward, Y up, Z right), SI units, 15 significant digits.
Samples come from a seeded generator, so a rerun gives the same files.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

import numpy as np
import opensim as osim
from peer_csv import write_table

HERE = Path(__file__).resolve().parent
DEFAULT_MODEL = HERE.parents[3] / "shared" / "data" / "opensim_moco_2d_walking" / "2D_gait.osim"
SEED = 2026120426

#: joint -> frame name -> (translation, orientation) written into the offsets model.
OFFSETS = {
    "groundPelvis": {"pelvis_offset": ((0.02, -0.03, 0.01), (0.0, 0.0, 0.1))},
    "hip_l": {"femur_l_offset": ((0.0, 0.05, 0.01), (0.0, 0.0, 0.4))},
    "knee_r": {"femur_r_offset": ((-0.0045122123214679797, -0.39690724592144699, 0.0),
                                  (0.0, 0.0, 0.3)),
               "tibia_r_offset": ((0.01, 0.02, 0.0), (0.0, 0.0, -0.2))},
    "subtalar_r": {"talus_r_offset": ((-0.044572091911732101, -0.038339127654237401,
                                       0.0072382810732195598), (0.0, 0.0, 0.25)),
                   "calcn_r_offset": ((0.01, 0.0, 0.0), (0.0, 0.0, -0.1))},
    "lumbar": {"pelvis_offset": ((-0.0972499926058214, 0.078707789447611198, 0.0),
                                 (0.0, 0.0, -0.15))},
}
#: body -> inertia (Ixx Iyy Izz Ixy Ixz Iyz), kg m^2, about the mass centre.
INERTIAS = {
    "torso": (1.14043571182129, 0.593400919285897, 1.14043571182129, 0.05, 0.02, -0.03),
    "talus_r": (0.00068896770091018196, 0.00068896770091018196, 0.00068896770091018196,
                0.0001, -0.00005, 0.00002),
}






def _vec(v) -> list[float]:
    return [v.get(0), v.get(1), v.get(2)]


def write_offsets_model(source: Path, target: Path) -> None:
    """The offsets variant of ``source``, printed by OpenSim to ``target``."""
    model = osim.Model(str(source))
    for joint_name, frames in OFFSETS.items():
        joint = model.getJointSet().get(joint_name)
        for i in range(joint.getPropertyByName("frames").size()):
            frame = joint.upd_frames(i)
            if frame.getName() in frames:
                translation, orientation = frames[frame.getName()]
                frame.set_translation(osim.Vec3(*translation))
                frame.set_orientation(osim.Vec3(*orientation))
    for body_name, inertia in INERTIAS.items():
        model.getBodySet().get(body_name).setInertia(osim.Inertia(*inertia))
    model.finalizeConnections()
    tmp = target.with_suffix(".osim.tmp")
    model.printToXML(str(tmp))
    os.replace(tmp, target)


def _poses(model: osim.Model, rng: np.random.Generator) -> list[dict]:
    poses = []
    for _ in range(5):
        q = {}
        for coord in model.getCoordinateSet():
            lo, hi = coord.getRangeMin(), coord.getRangeMax()
            q[coord.getName()] = rng.uniform(max(lo, -1.2), min(hi, 1.2))
        q.update(pelvis_tx=rng.uniform(-1.0, 1.0), pelvis_ty=rng.uniform(0.7, 1.1))
        poses.append(q)
    return poses


def tables(original: Path, offsets: Path) -> None:
    rng = np.random.default_rng(SEED)
    frame_rows, energy_rows = [], []
    names = None
    for label, path in (("original", original), ("offsets", offsets)):
        model = osim.Model(str(path))
        state = model.initSystem()
        coords = list(model.getCoordinateSet())
        names = [c.getName() for c in coords]
        for k, q in enumerate(_poses(model, rng)):
            for c in coords:
                c.setValue(state, q[c.getName()], False)
            model.realizePosition(state)
            qv = [q[n] for n in names]
            if label == "offsets":
                for body in model.getBodySet():
                    rot = body.getTransformInGround(state).R()
                    com = body.findStationLocationInGround(state, body.getMassCenter())
                    frame_rows.append([str(k), body.getName(), *qv,
                                       *_vec(body.getPositionInGround(state)), *_vec(com),
                                       *[rot.get(i, j) for i in range(3) for j in range(3)]])
            for _ in range(3):
                u = rng.uniform(-2.0, 2.0, len(coords))
                for c, speed in zip(coords, u, strict=True):
                    c.setSpeedValue(state, float(speed))
                model.realizeVelocity(state)
                energy = model.getMatterSubsystem().calcKineticEnergy(state)
                energy_rows.append([label, str(k), *qv, *u, energy])
    frame_header = ["pose", "name", *names, "x", "y", "z", "com_x", "com_y", "com_z",
                    *[f"r{i}{j}" for i in range(3) for j in range(3)]]
    energy_header = ["model", "pose", *names, *[f"{n}.speed" for n in names],
                     "kinetic_energy"]
    write_table(HERE / "offsets_frames.csv", frame_header, frame_rows, digits=15)
    write_table(HERE / "kinetic_energy.csv", energy_header, energy_rows, digits=15)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", type=Path, default=DEFAULT_MODEL)
    args = parser.parse_args()
    offsets = HERE / "offsets_2d_gait.osim"
    write_offsets_model(args.model, offsets)
    tables(args.model, offsets)


if __name__ == "__main__":
    main()
