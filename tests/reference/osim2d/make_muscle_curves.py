"""OpenSim 4.6's DeGrooteFregly2016Muscle curves and implicit tendon residual, as CSV tables.

Run once with the OpenSim 4.6 Python (the peer; predgait never imports opensim):

    OMP_NUM_THREADS=1 $OPENSIM_PYTHON tests/reference/osim2d/make_muscle_curves.py \
        [--model PATH/2D_gait.osim]

Writes next to this script (each table whole: a temporary file, then renamed; 12 significant
digits; seeded, so a rerun on the same OpenSim gives the same files):

``muscle_curves.csv``: one row per (parameter set, abscissa): ``set``,
    ``active_force_width_scale``, ``passive_fiber_strain_at_one_norm_force``,
    ``tendon_strain_at_one_norm_force``, ``x``, then OpenSim's
    ``calcActiveForceLengthMultiplier(x)``, ``calcPassiveForceMultiplier(x)`` (x a normalized
    fibre length), ``calcTendonForceMultiplier(x)`` (x a normalized tendon length) and
    ``calcForceVelocityMultiplier(x - 1)`` (x - 1 a normalized fibre velocity), as
    ``active``, ``passive``, ``tendon``, ``velocity``.
``compliant_residual.csv``: one row per (muscle, sample) of 2D_gait.osim's 18 muscles with
    ``ignore_tendon_compliance`` false and ``tendon_compliance_dynamics_mode`` implicit:
    ``muscle``, ``length`` (m), ``speed`` (m/s), ``activation``, ``norm_tendon_force``,
    ``norm_tendon_force_rate`` (1/s) and OpenSim's
    ``calcEquilibriumResidual(length, speed, activation, f_T, df_T/dt)`` (N) as ``residual``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import opensim as osim
from peer_csv import write_table

HERE = Path(__file__).resolve().parent
DEFAULT_MODEL = HERE.parents[3] / "shared" / "data" / "opensim_moco_2d_walking" / "2D_gait.osim"
SETS = ((1.0, 0.6, 0.049), (1.5, 0.3, 0.033), (2.0, 0.9, 0.1))




def curves() -> tuple[list[str], list[list]]:
    rows = []
    for k, (width, passive, tendon) in enumerate(SETS):
        muscle = osim.DeGrooteFregly2016Muscle()
        muscle.set_active_force_width_scale(width)
        muscle.set_passive_fiber_strain_at_one_norm_force(passive)
        muscle.set_tendon_strain_at_one_norm_force(tendon)
        muscle.finalizeFromProperties()
        for x in np.linspace(0.3, 1.9, 33):
            rows.append([str(k), width, passive, tendon, x,
                         muscle.calcActiveForceLengthMultiplier(x),
                         muscle.calcPassiveForceMultiplier(x),
                         muscle.calcTendonForceMultiplier(x),
                         muscle.calcForceVelocityMultiplier(x - 1.0)])
    header = ["set", "active_force_width_scale", "passive_fiber_strain_at_one_norm_force",
              "tendon_strain_at_one_norm_force", "x", "active", "passive", "tendon",
              "velocity"]
    return header, rows


def residuals(model_path: Path) -> tuple[list[str], list[list]]:
    model = osim.Model(str(model_path))
    muscles = [osim.DeGrooteFregly2016Muscle.safeDownCast(c)
               for c in model.getComponentsList()
               if c.getConcreteClassName() == "DeGrooteFregly2016Muscle"]
    rng = np.random.default_rng(20261204)
    rows = []
    for muscle in muscles:
        muscle.set_ignore_tendon_compliance(False)
        muscle.set_tendon_compliance_dynamics_mode("implicit")
        muscle.finalizeFromProperties()
        slack, optimal = muscle.get_tendon_slack_length(), muscle.get_optimal_fiber_length()
        for _ in range(12):
            f_t = rng.uniform(0.0, 1.5)
            length = slack * (1.0 + rng.uniform(0.0, 0.06)) + optimal * rng.uniform(0.6, 1.4)
            speed, activation = rng.uniform(-0.5, 0.5), rng.uniform(0.01, 1.0)
            rate = rng.uniform(-10.0, 10.0)
            rows.append([muscle.getName(), length, speed, activation, f_t, rate,
                         muscle.calcEquilibriumResidual(length, speed, activation, f_t, rate)])
    header = ["muscle", "length", "speed", "activation", "norm_tendon_force",
              "norm_tendon_force_rate", "residual"]
    return header, rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", type=Path, default=DEFAULT_MODEL)
    args = parser.parse_args()
    write_table(HERE / "muscle_curves.csv", *curves())
    write_table(HERE / "compliant_residual.csv", *residuals(args.model))


if __name__ == "__main__":
    main()
