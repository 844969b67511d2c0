"""STO files of a muscle-driven gait in OpenSim's own column names (Moco can load them).

* ``solution.sto``: the half stride as solved, a MocoTrajectory table (header
  ``num_states``/``num_controls``/..., states then controls), like Moco's
  ``gaitPrediction_solution.sto``; with compliant tendons (``[model] compliant_tendons``)
  also their states ``/<muscle>/normalized_tendon_force``;
* ``states.sto``: the full stride from right heel strike: ``/jointset/<joint>/<coord>/value``
  and ``/speed`` (OpenSim values: rad, m, rad/s, m/s) and ``/<muscle>/activation``; with
  ``controls.sto`` (``/<muscle>`` excitations, ``/lumbarAct``) a MocoTrajectory too;
* ``muscle_forces.sto``: tendon forces (N) per muscle;
* ``grf.sto``: the external-loads layout of referenceGRF.sto / Moco's
  createExternalLoadsTableForGait, in OpenSim's frame (Y up, Z right): per foot the force
  ``ground_force_<r|l>_v[xyz]`` (N), the centre of pressure ``_p[xyz]`` (m, on the floor)
  and ``ground_torque_<r|l>_[xyz]`` (0: each sphere's force acts at its own point; their
  sum is applied at the centre of pressure).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from predgait.data.storage import write_storage

#: predgait lab vector (x, y_left, z_up) -> OpenSim ground (x, y_up, z_right).
TO_OPENSIM = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])


def state_columns(planar, plant, q, v, act) -> dict[str, np.ndarray]:
    """OpenSim state paths -> (n,) values."""
    osim = planar.osim
    values, speeds = planar.osim_from_q(q), planar.osim_from_q(v)
    out = {}
    for kind, table in (("value", values), ("speed", speeds)):
        for name in planar.osim_coordinates:
            joint = osim.coordinate(name).joint
            out[f"/jointset/{joint}/{name}/{kind}"] = np.asarray(table[name])
    for i, muscle in enumerate(plant.muscle_names):
        out[f"/{muscle}/activation"] = act[:, i]
    return out


def control_columns(plant, exc, u) -> dict[str, np.ndarray]:
    """OpenSim control paths -> (n,) values (excitations, lumbar control)."""
    out = {f"/{m}": exc[:, i] for i, m in enumerate(plant.muscle_names)}
    out[f"/{plant.osim.actuators[0].name}"] = np.asarray(u)
    return out


def moco_header(n_states: int, n_controls: int, extra: dict | None = None) -> dict:
    """The header entries a MocoTrajectory file carries."""
    return {"num_controls": str(n_controls), "num_derivatives": "0",
            "num_input_controls": "0", "num_multipliers": "0", "num_parameters": "0",
            "num_slacks": "0", "num_states": str(n_states), "DataType": "double",
            **(extra or {})}


def grf_columns(plant, grf: np.ndarray, points: np.ndarray) -> dict[str, np.ndarray]:
    """External-loads columns per foot from sphere forces (n, k, 3) at points (lab)."""
    names = [s.name for s in plant.spheres]
    out = {}
    for side in ("r", "l"):
        rows = [i for i, n in enumerate(names) if n.endswith(f"_{side}")]
        force = grf[:, rows].sum(axis=1)
        fz = grf[:, rows, 2]
        weight = np.where(fz.sum(axis=1) > 1e-6, fz.sum(axis=1), np.inf)[:, None]
        cop = (fz[:, :, None] * points[:, rows]).sum(axis=1) / weight
        cop[:, 2] = 0.0
        f_os, p_os = force @ TO_OPENSIM.T, cop @ TO_OPENSIM.T
        for k, axis in enumerate("xyz"):
            out[f"ground_force_{side}_v{axis}"] = f_os[:, k]
        for k, axis in enumerate("xyz"):
            out[f"ground_force_{side}_p{axis}"] = p_os[:, k]
    for side in ("r", "l"):
        for axis in "xyz":
            out[f"ground_torque_{side}_{axis}"] = np.zeros(grf.shape[0])
    return out


def write_gait_files(stage: Path, planar, plant, gait, stride, *, status: str,
                     prefix: str = "") -> list[str]:
    """Write the STO files of a solution into ``stage``; returns the file names."""
    p = gait.path
    states = state_columns(planar, plant, p.q, p.v, p.act)
    if p.ft is not None:           # compliant tendons: their state (Moco's column name)
        states |= {f"/{plant.muscle_names[row]}/normalized_tendon_force": p.ft[:, i]
                   for i, row in enumerate(plant.compliant)}
    controls = control_columns(plant, p.exc, p.u)
    header = moco_header(len(states), len(controls), {"status": status})
    names = [f"{prefix}solution.sto", f"{prefix}states.sto", f"{prefix}controls.sto",
             f"{prefix}muscle_forces.sto", f"{prefix}grf.sto"]
    write_storage(stage / names[0], p.t, states | controls, header=header)
    full_states = state_columns(planar, plant, stride.q, stride.v, stride.act)
    full_controls = control_columns(plant, stride.exc, stride.u)
    write_storage(stage / names[1], stride.t, full_states,
                  header=moco_header(len(full_states), 0, {"status": status}))
    write_storage(stage / names[2], stride.t, full_controls,
                  header=moco_header(0, len(full_controls), {"status": status}))
    write_storage(stage / names[3], stride.t,
                  {f"/{m}/tendon_force": stride.force[:, i]
                   for i, m in enumerate(plant.muscle_names)},
                  header={"units": "N", "status": status})
    write_storage(stage / names[4], stride.t, grf_columns(plant, stride.grf, stride.points),
                  header={"units": "N, m, N m (OpenSim ground frame, Y up)",
                          "status": status})
    return names
