"""Step size and corrector iterations study on the leg (thesis 4.2: h = 1 ms with 10
iterations was found safe). Prints a table of error against a tight reference.

Run: python benchmarks/study_integrators.py

Case: the thesis' collapse test (foot fixed, shank 5 deg, thigh -5 deg, no loads) over
0.25 s, before the fall; reference: Radau with rtol 1e-12. Error: largest joint-angle
difference over the run, deg.
"""

import time

import numpy as np

from predgait.dynamics.drivers import LegDrivers
from predgait.dynamics.forward import simulate_leg
from predgait.dynamics.integrators import IntegratorOptions, Method
from predgait.models.loading import load_model

DURATION = 0.25


def main():
    leg = load_model("leg")
    x0 = np.array([np.radians(5.0), np.radians(-10.0), 0.0, 0.0])
    still = LegDrivers.still()
    t = np.linspace(0.0, DURATION, 26)
    reference = simulate_leg(leg, still, (0.0, DURATION), x0, t_eval=t, options=IntegratorOptions(
        method=Method.RADAU, rtol=1e-12, atol=1e-12, step=0.01))

    def error(options):
        start = time.perf_counter()
        sim = simulate_leg(leg, still, (0.0, DURATION), x0, t_eval=t, options=options)
        seconds = time.perf_counter() - start
        if sim.partial or len(sim.t) < len(t):
            return np.inf, seconds, sim.n_rhs_evaluations
        return (float(np.degrees(np.abs(sim.q[:, 3:] - reference.q[:, 3:]).max())), seconds,
                sim.n_rhs_evaluations)

    print(f"{'method':<16}{'h (s)':>8}{'iter':>6}{'max error (deg)':>18}{'rhs calls':>11}"
          f"{'time (ms)':>11}")
    rows = [(Method.EULER, h, 1) for h in (0.05, 0.01, 0.001)]
    rows += [(Method.MODIFIED_EULER, h, k) for h in (0.05, 0.01, 0.001) for k in (1, 2, 10)]
    rows += [(Method.RK4, h, 1) for h in (0.05, 0.01, 0.001)]
    for method, h, k in rows:
        err, seconds, calls = error(IntegratorOptions(method=method, step=h, iterations=k))
        print(f"{method.value:<16}{h:>8g}{k:>6}{err:>18.3e}{calls:>11}{seconds * 1e3:>11.1f}")
    for method in (Method.RK45, Method.RADAU, Method.BDF, Method.LSODA):
        for tol in (1e-5, 1e-8):
            err, seconds, calls = error(IntegratorOptions(method=method, rtol=tol, atol=tol,
                                                          step=0.01))
            print(f"{method.value + f' tol {tol:g}':<16}{'adapt':>8}{'':>6}{err:>18.3e}"
                  f"{calls:>11}{seconds * 1e3:>11.1f}")


if __name__ == "__main__":
    main()
