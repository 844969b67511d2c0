"""gait7 contact simulation speed: 1 s of the subject01 walk (thesis 2.3.1, 2.4).

Runs (min / median of 3, wall and CPU), HAT height free on four fitted IMPACT contacts, all other
coordinates prescribed (``kinematic``), then also the left knee free and moment-driven
(``knee``); trial time 0.62..1.62 s, output at the 600 Hz plate samples:
  * LSODA (rtol 1e-6, atol 1e-8), the problem file's default;
  * RK4 with h = 0.2 ms (same forces to < 0.1 N).

Run:  .venv/bin/python benchmarks/bench_gait7.py
"""

from __future__ import annotations

from timing import time_call

from predgait.dynamics.contact_fit import fit_impact_to_meglan
from predgait.dynamics.gait7_motion import bundled_gait7_motion, gait7_model
from predgait.dynamics.integrators import IntegratorOptions, Method
from predgait.dynamics.passive import LinearSpringDamper, PassiveJoint
from predgait.simulations.gait7_sim import GAIT7_FALL, KneeMoment, kinematic_run, knee_run

SPAN = (0.62, 1.62)



def main():
    model = gait7_model(72.6, 1.8034)
    motion = bundled_gait7_motion(model)
    contact = fit_impact_to_meglan().contact
    t = motion.plate_time
    t = t[(t >= SPAN[0]) & (t <= SPAN[1])]
    passive = PassiveJoint((LinearSpringDamper(k=1.0, c=0.1),))
    for label, options in (("LSODA 1e-6", IntegratorOptions(method=Method.LSODA)),
                           ("RK4 h=0.2 ms", IntegratorOptions(method=Method.RK4, step=2e-4))):
        def kinematic(o=options):
            return kinematic_run(model, motion, contact, ground_z=-0.0075, t_span=SPAN,
                                 options=o, t_eval=t)

        kin = kinematic()
        print(f"gait7 kinematic (HAT height free), 1 s, {label}: "
              f"{time_call(kinematic, 3).describe()}, {kin.run.n_rhs_evaluations} rhs")

        def knee(o=options, k=kin):
            return knee_run(model, motion, k, contact, ground_z=-0.0075, sides=("left",),
                            source=KneeMoment.MODEL, passive=passive, fall=GAIT7_FALL,
                            options=o, t_eval=t)

        run = knee()
        print(f"gait7 left knee moment-driven, 1 s, {label}: {time_call(knee, 3).describe()}, "
              f"{run.run.n_rhs_evaluations} rhs ({run.status}); OpenSim: peer not available")


if __name__ == "__main__":
    main()
