"""OpenSim 4.6's Bhargava2004SmoothedMuscleMetabolics on the 2D gait model, written once as a CSV.

Run with the OpenSim 4.6 Python (the peer; predgait never imports opensim), from anywhere:

    OMP_NUM_THREADS=1 $OPENSIM_PYTHON tests/reference/osim2d/make_metabolics.py \
        [--model PATH/2D_gait.osim] [--moco-solution gaitTracking_solution_fullcycle.sto]

It loads ``2D_gait.osim`` (default: ``../shared/data/opensim_moco_2d_walking/`` beside the
repository) and adds Bhargava2004SmoothedMuscleMetabolics components with ``use_smoothing``
true and every other property at OpenSim 4.6's default (tanh smoothing, velocity, power and
heat-rate smoothing 10, basal coefficient 1.2 W/kg, exponent 1, minimum heat rate per muscle
enforced, negative total power forbidden, negative mechanical work included, muscle mass from
max isometric force / specific tension 0.25 MPa * density 1059.7 kg/m^3 * optimal fibre length):

- ``all_default``: all 18 muscles, slow-twitch ratio 0.5 (OpenSim's default) - its
  ``getMuscleMetabolicRate`` per muscle and ``getTotalMetabolicRate`` (basal included);
- ``all_literature``: all 18 muscles with the per-muscle ratios of
  ``SLOW_TWITCH`` below (predgait.dynamics.metabolics.SLOW_TWITCH_LITERATURE);
- one component per muscle and ratio set, whose ``getTotal{Activation,Maintenance,Shortening,
  MechanicalWork}Rate`` are that muscle's terms.

States (seeded, 40): joint coordinates uniform in their ranges, joint speeds 0 (4 states),
up to 4 rad/s (16) or 12 rad/s (20); activations uniform in [0, 1] (the first 6 states in
[0, 0.03], where the minimum heat rate of 1 W/kg binds); excitations set through the model's
controls (``Model.setControls``; control 0 is the lumbar actuator, 1..18 the muscles in file
order), uniform in [0, 1] (the first 6 states in [0, 0.03]).

Table ``metabolics.csv``, one row per (state, ratio set, muscle): ``state``, ``ratios``
(``default`` or ``literature``), ``muscle``, ``length`` (muscle-tendon, m),
``lengthening_speed`` (m/s), ``activation``, ``excitation`` (the muscle's getControl),
``normalized_fiber_length``, ``fiber_velocity`` (m/s), ``active_fiber_force``,
``passive_fiber_force`` (getPassiveFiberForce, N), ``slow_twitch_ratio``,
``activation_rate``, ``maintenance_rate``, ``shortening_rate``, ``mechanical_work_rate``,
``metabolic_rate`` (W, the muscle's total) and ``total_metabolic_rate`` (W, all muscles plus
basal) and ``model_mass`` (kg).

With ``--moco-solution`` (Moco's example2DWalking tracking solution, full cycle, as
``benchmarks/opensim_moco_2d_walking.py --write`` writes it), also
``metabolics_gait.csv``: every state of
that trajectory (states and controls as Moco solved them, through ``StatesTrajectory`` and
``Model.setControls``), one row per time: ``time``, the 10 coordinate values and
``<coordinate>.speed``, per muscle ``<muscle>.activation``, ``.excitation``, ``.length``,
``.lengthening_speed``, ``.metabolic_rate`` (W, ``all_default``), then
``total_metabolic_rate`` (W, basal included) and ``model_mass``. Tables are written whole
(temporary file, then renamed), 12 significant digits.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import opensim as osim
from peer_csv import write_table

HERE = Path(__file__).resolve().parent
DEFAULT_MODEL = HERE.parents[3] / "shared" / "data" / "opensim_moco_2d_walking" / "2D_gait.osim"
SEED = 20261205
JOINT_COORDS = ("hip_flexion_l", "hip_flexion_r", "knee_angle_l", "knee_angle_r",
                "ankle_angle_l", "ankle_angle_r", "lumbar")
#: Slow-twitch ratios by muscle (side suffix dropped); must equal predgait's table.
SLOW_TWITCH = {"hamstrings": 0.486666666667, "bifemsh": 0.529, "glut_max": 0.55,
               "iliopsoas": 0.5, "rect_fem": 0.3865, "vasti": 0.500333333333,
               "gastroc": 0.5365, "soleus": 0.803, "tib_ant": 0.7}
TERMS = ("activation_rate", "maintenance_rate", "shortening_rate", "mechanical_work_rate")




def _metabolics(name: str, muscles, ratios: dict | None):
    met = osim.Bhargava2004SmoothedMuscleMetabolics()
    met.setName(name)
    met.set_use_smoothing(True)
    for muscle in muscles:
        if ratios is None:
            met.addMuscle(muscle.getName(), muscle)
        else:
            met.addMuscle(muscle.getName(), muscle, ratios[muscle.getName()[:-2]], 0.25e6)
    return met


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", type=Path, default=DEFAULT_MODEL)
    parser.add_argument("--moco-solution", type=Path, default=None)
    args = parser.parse_args()
    model = osim.Model(str(args.model))

    def find_muscles():
        return [osim.DeGrooteFregly2016Muscle.safeDownCast(c) for c in model.getComponentsList()
                if c.getConcreteClassName() == "DeGrooteFregly2016Muscle"]

    muscles = find_muscles()
    sets = {"default": None, "literature": SLOW_TWITCH}
    for label, ratios in sets.items():
        model.addComponent(_metabolics(f"all_{label}", muscles, ratios))
        for muscle in muscles:
            model.addComponent(_metabolics(f"{label}_{muscle.getName()}", [muscle], ratios))
    state = model.initSystem()
    muscles = find_muscles()
    coords = {c.getName(): c for c in model.getCoordinateSet()}
    parts = {p.getName(): osim.Bhargava2004SmoothedMuscleMetabolics.safeDownCast(p)
             for p in model.getComponentsList()
             if p.getConcreteClassName() == "Bhargava2004SmoothedMuscleMetabolics"}
    mass = model.getTotalMass(state)
    rng = np.random.default_rng(SEED)
    header = ["state", "ratios", "muscle", "length", "lengthening_speed", "activation",
              "excitation", "normalized_fiber_length", "fiber_velocity", "active_fiber_force",
              "passive_fiber_force", "slow_twitch_ratio", *TERMS, "metabolic_rate",
              "total_metabolic_rate", "model_mass"]
    rows = []
    for k in range(40):
        scale = 0.0 if k < 4 else (4.0 if k < 20 else 12.0)
        top = 0.03 if k < 6 else 1.0
        for name, coord in coords.items():
            low, high = coord.getRangeMin(), coord.getRangeMax()
            coord.setValue(state, rng.uniform(low, high) if name in JOINT_COORDS else 0.0, False)
            coord.setSpeedValue(state, scale * rng.uniform(-1, 1) if name in JOINT_COORDS
                                else 0.0)
        activations = rng.uniform(0.0, top, len(muscles))
        excitations = rng.uniform(0.0, top, len(muscles))
        model.realizeVelocity(state)
        for muscle, a in zip(muscles, activations, strict=True):
            muscle.setActivation(state, float(a))
        controls = model.updControls(state)
        for i, u in enumerate(excitations):
            controls.set(i + 1, float(u))
        model.setControls(state, controls)
        model.realizeDynamics(state)
        for label in sets:
            whole = parts[f"all_{label}"]
            for muscle, u in zip(muscles, excitations, strict=True):
                if abs(muscle.getControl(state) - u) > 1e-15:
                    raise RuntimeError(f"{muscle.getName()}: control not set")
                one = parts[f"{label}_{muscle.getName()}"]
                ratio = 0.5 if sets[label] is None else SLOW_TWITCH[muscle.getName()[:-2]]
                rows.append([
                    str(k), label, muscle.getName(), muscle.getLength(state),
                    muscle.getLengtheningSpeed(state), muscle.getActivation(state),
                    muscle.getControl(state), muscle.getNormalizedFiberLength(state),
                    muscle.getFiberVelocity(state), muscle.getActiveFiberForce(state),
                    muscle.getPassiveFiberForce(state), ratio,
                    one.getTotalActivationRate(state), one.getTotalMaintenanceRate(state),
                    one.getTotalShorteningRate(state), one.getTotalMechanicalWorkRate(state),
                    whole.getMuscleMetabolicRate(state, muscle.getAbsolutePathString()),
                    whole.getTotalMetabolicRate(state), mass])
    write_table(HERE / "metabolics.csv", header, rows)
    if args.moco_solution is not None:
        header, rows = _gait(model, state, muscles, coords, parts["all_default"],
                             args.moco_solution)
        write_table(HERE / "metabolics_gait.csv", header, rows)


def _gait(model, state, muscles, coords, whole, solution: Path):
    """Rows of metabolics_gait.csv along a Moco solution."""
    table = osim.TimeSeriesTable(str(solution))
    labels = list(table.getColumnLabels())
    times = list(table.getIndependentColumn())
    names = list(coords)
    header = ["time", *names, *[f"{n}.speed" for n in names]]
    for m in muscles:
        header += [f"{m.getName()}.{k}" for k in ("activation", "excitation", "length",
                                                 "lengthening_speed", "metabolic_rate")]
    header += ["total_metabolic_rate", "model_mass"]

    def value(label, row):
        return table.getDependentColumnAtIndex(labels.index(label))[row]

    rows = []
    for k, t in enumerate(times):
        state.setTime(t)
        for name, coord in coords.items():
            joint = coord.getJoint().getName()
            coord.setValue(state, value(f"/jointset/{joint}/{name}/value", k), False)
            coord.setSpeedValue(state, value(f"/jointset/{joint}/{name}/speed", k))
        model.realizeVelocity(state)
        for muscle in muscles:
            muscle.setActivation(state, value(f"/{muscle.getName()}/activation", k))
        controls = model.updControls(state)
        controls.set(0, value("/lumbarAct", k))
        for i, muscle in enumerate(muscles):
            controls.set(i + 1, value(f"/{muscle.getName()}", k))
        model.setControls(state, controls)
        model.realizeDynamics(state)
        row = [t, *[coords[n].getValue(state) for n in names],
               *[coords[n].getSpeedValue(state) for n in names]]
        for muscle in muscles:
            row += [muscle.getActivation(state), muscle.getControl(state),
                    muscle.getLength(state), muscle.getLengtheningSpeed(state),
                    whole.getMuscleMetabolicRate(state, muscle.getAbsolutePathString())]
        rows.append(row + [whole.getTotalMetabolicRate(state), model.getTotalMass(state)])
    return header, rows




if __name__ == "__main__":
    main()
