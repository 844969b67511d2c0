"""OpenSim on predgait's planar leg (the peer of bench_inverse.py and bench_forward.py).

Usage: OPENSIM_PYTHON benchmarks/opensim_leg.py STATES.npz

Reads the segments (mass, sagittal inertia, COM and joint offsets in OpenSim axes) from
STATES.npz and builds the leg with the OpenSim API (PlanarJoint on the foot, PinJoints at
ankle and knee, Y-up). Then, by the file's ``mode``:

* ``inverse``: the states (q, v, a, predgait's coordinates, one row per frame) are solved
  frame by frame from Python with the InverseDynamicsSolver; writes tau (predgait's
  coordinates and signs).
* ``forward``: the foot is welded to the ground and the Manager (Runge-Kutta-Merson,
  accuracy ``accuracy``) integrates ``duration`` s from ``x0`` = (ankle, knee, rates in
  predgait's coordinates), no torques; writes the final free state ``xf``.

Each is run ``repeat`` times; writes the wall and CPU seconds of each run (``wall``,
``cpu``) and the OpenSim version back into the same file. Only numpy and opensim are
imported here: OpenSim's bundled CasADi clashes with the casadi wheel.
"""

import sys
import time

import numpy as np
import opensim as osim

osim.Logger.removeFileSink()   # no opensim.log in the working folder
osim.Logger.setLevelString("error")

#: predgait (base_x, base_z, base_pitch, ankle, knee) -> OpenSim (rz, tx, ty, ankle, knee):
#: a rotation about lab +Y is one about OpenSim -Z.
ORDER, SIGN = [2, 0, 1, 3, 4], np.array([-1.0, 1.0, 1.0, -1.0, -1.0])


def build_leg(segments, gravity, *, weld_foot=False):
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
    if weld_foot:
        model.addJoint(osim.WeldJoint("base", model.getGround(), zero, zero, bodies[0], zero,
                                      zero))
    else:
        model.addJoint(osim.PlanarJoint("base", model.getGround(), zero, zero, bodies[0],
                                        zero, zero))
    for i, name in ((1, "ankle"), (2, "knee")):
        model.addJoint(osim.PinJoint(name, bodies[i - 1], osim.Vec3(*segments["offset"][i]),
                                     zero, bodies[i], zero, zero))
    return model, model.initSystem()


def timed(run, repeat):
    wall, cpu = [], []
    for _ in range(repeat):
        w0, c0 = time.perf_counter(), time.process_time()
        result = run()
        cpu.append(time.process_time() - c0)
        wall.append(time.perf_counter() - w0)
    return result, {"wall": np.array(wall), "cpu": np.array(cpu)}


def inverse(data):
    model, state = build_leg(data, float(data["gravity"]))
    solver = osim.InverseDynamicsSolver(model)
    q, v, a = data["q"], data["qd"], data["qdd"]

    def to_osim(x):
        return osim.Vector.createFromMat(SIGN * x[ORDER])

    def solve_all():
        out = np.empty(q.shape)
        for k in range(len(q)):
            state.setQ(to_osim(q[k]))
            state.setU(to_osim(v[k]))
            model.realizeVelocity(state)
            tau = solver.solve(state, to_osim(a[k]))
            out[k, ORDER] = SIGN * np.array([tau.get(i) for i in range(q.shape[1])])
        return out

    tau, times = timed(solve_all, int(data["repeat"]))
    return {"tau": tau, **times}


def forward(data):
    """Manager run of the welded-foot leg; the model is built once, as a tool would."""
    model, _ = build_leg(data, float(data["gravity"]), weld_foot=True)
    x0 = data["x0"]
    free_sign = SIGN[3:]

    def run():
        state = model.initSystem()
        state.setQ(osim.Vector.createFromMat(free_sign * x0[:2]))
        state.setU(osim.Vector.createFromMat(free_sign * x0[2:]))
        manager = osim.Manager(model)
        manager.setIntegratorMethod(osim.Manager.IntegratorMethod_RungeKuttaMerson)
        manager.setIntegratorAccuracy(float(data["accuracy"]))
        manager.initialize(state)
        end = manager.integrate(float(data["duration"]))
        q, u = end.getQ(), end.getU()
        return np.concatenate([free_sign * np.array([q.get(0), q.get(1)]),
                               free_sign * np.array([u.get(0), u.get(1)])])

    xf, times = timed(run, int(data["repeat"]))
    return {"xf": xf, **times}


def main(path):
    data = dict(np.load(path))
    result = (forward if str(data["mode"]) == "forward" else inverse)(data)
    np.savez(path, version=osim.__version__, **result)


if __name__ == "__main__":
    main(sys.argv[1])
