"""OpenSim's InverseDynamicsSolver on predgait's planar leg (run by bench_inverse.py).

Usage: python benchmarks/opensim_leg.py STATES.npz

Reads the segments (mass, sagittal inertia, COM and joint offsets in OpenSim axes) and the
states (q, qd, qdd, predgait's coordinates, one row per frame) from STATES.npz, builds the
leg with the OpenSim API (PlanarJoint on the foot, PinJoints at ankle and knee, Y-up),
solves each frame from Python, and writes tau (predgait's coordinates and signs), the best
of three timings and the OpenSim version back into the same file. Only numpy and opensim
are imported here: OpenSim's bundled CasADi clashes with the casadi wheel.
"""

import sys
import time

import numpy as np
import opensim as osim

#: predgait (base_x, base_z, base_pitch, ankle, knee) -> OpenSim (rz, tx, ty, ankle, knee):
#: a rotation about lab +Y is one about OpenSim -Z.
ORDER, SIGN = [2, 0, 1, 3, 4], np.array([-1.0, 1.0, 1.0, -1.0, -1.0])


def build_leg(segments, gravity):
    """The leg as an OpenSim model; returns (model, initial state)."""
    model = osim.Model()
    model.setGravity(osim.Vec3(0, -gravity, 0))
    bodies = []
    for i, name in enumerate(("foot", "shank", "thigh")):
        i_sagittal = float(segments["inertia"][i])   # only the axis of rotation matters
        body = osim.Body(name, float(segments["mass"][i]), osim.Vec3(*segments["com"][i]),
                         osim.Inertia(i_sagittal, i_sagittal, i_sagittal))
        model.addBody(body)
        bodies.append(body)
    zero = osim.Vec3(0)
    model.addJoint(osim.PlanarJoint("base", model.getGround(), zero, zero, bodies[0], zero,
                                    zero))
    for i, name in ((1, "ankle"), (2, "knee")):
        model.addJoint(osim.PinJoint(name, bodies[i - 1], osim.Vec3(*segments["offset"][i]),
                                     zero, bodies[i], zero, zero))
    return model, model.initSystem()


def main(path):
    data = dict(np.load(path))
    model, state = build_leg(data, float(data["gravity"]))
    solver = osim.InverseDynamicsSolver(model)
    q, qd, qdd = data["q"], data["qd"], data["qdd"]

    def to_osim(x):
        return osim.Vector.createFromMat(SIGN * x[ORDER])

    def solve_all():
        out = np.empty(q.shape)
        for k in range(len(q)):
            state.setQ(to_osim(q[k]))
            state.setU(to_osim(qd[k]))
            model.realizeVelocity(state)
            tau = solver.solve(state, to_osim(qdd[k]))
            out[k, ORDER] = SIGN * np.array([tau.get(i) for i in range(q.shape[1])])
        return out

    best = np.inf
    for _ in range(3):
        start = time.perf_counter()
        solve_all()
        best = min(best, time.perf_counter() - start)
    np.savez(path, tau=solve_all(), seconds=best, version=osim.__version__)


if __name__ == "__main__":
    main(sys.argv[1])
