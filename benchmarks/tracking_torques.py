"""Corrected torques of the whole-body tracking against the measured moments (issue 27).

Solves each problem file (default: subject01's first right gait cycle and walking5) and
prints, per sagittal joint, the corrected-minus-measured RMS (N m and N m/kg), the
largest |corrected - measured|, the corrected torque's largest node-to-node change next
to the measured one's, and the spike above the measured peak; the floor, its source, the
plane of the foot-moment cost and the plates' COP plane; then the issue's Done-when
yardstick: within 0.15 N m/kg RMS, no spike above the measured peak + 30 N m, no
node-to-node change above 30 N m (all joints); and the measured pelvis residual's
sagittal moment against the summed hip and lumbar corrections, which must cancel it (so
the largest of the three corrections' RMS is at least a third of their sum's). No
re-simulation.

Run:  python benchmarks/tracking_torques.py [problem.toml ...] [--set key=value ...]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PROBLEMS = [REPO / "problems" / "fullbody_tracking.toml",
            REPO / "problems" / "fullbody_tracking_walking5.toml"]


def report(path: Path, overrides: list[str]) -> bool:
    """Solve one problem and print its torque table; True when the yardstick holds."""
    from predgait.problemfile import load_problem
    from predgait.workflows.fullbody_tracking import (
        SAGITTAL,
        parse_tracking,
        pelvis_moment_share,
        torque_deviation,
    )
    from predgait.workflows.fullbody_tracking_run import solve_spec

    spec = parse_tracking(load_problem(path, overrides))
    started = time.perf_counter()
    drive, data, solution = solve_spec(spec)
    seconds = time.perf_counter() - started
    dev = torque_deviation(drive.model, data, solution)
    mass = drive.model.total_mass()
    print(f"{path.name}: {solution.status}, {solution.iterations} iterations, "
          f"{seconds:.1f} s with IK/ID, {data.nodes} nodes")
    plates = "none" if data.plate_z is None else f"{data.plate_z:.4f} m"
    print(f"  floor {data.ground_z:.4f} m ({data.floor_source}); foot-moment plane "
          f"{float(data.cop[:, :, 2].mean()):.4f} m; plates' COP plane {plates}")
    print(f"  {'joint':10s} {'RMS N m':>8s} {'N m/kg':>7s} {'peak':>7s} {'d/node':>7s} "
          f"{'meas d':>7s} {'spike':>7s}")
    for name in SAGITTAL + ("lumbar_y",):
        print(f"  {name:10s} {dev['rms_n_m'][name]:8.1f} {dev['rms_n_m'][name] / mass:7.3f} "
              f"{dev['peak_n_m'][name]:7.1f} {dev['node_change_n_m'][name]:7.1f} "
              f"{dev['measured_node_change_n_m'][name]:7.1f} {dev['spike_n_m'][name]:7.1f}")
    share = pelvis_moment_share(drive, data, solution)
    print(f"  measured pelvis residual My {share['residual_my']:.1f} N m RMS; hips + lumbar "
          f"corrections summed {share['correction_sum']:.1f}, their sum + My "
          f"{share['left']:.1f} (the corrections cancel the residual)")
    worst = dev["worst"]
    ok = (worst["sagittal_rms_n_m_per_kg"]["value"] <= 0.15
          and worst["spike_n_m"]["value"] <= 30.0 and worst["node_change_n_m"]["value"] <= 30.0)
    print("  worst: " + ", ".join(f"{k} {v['joint']} {v['value']:.3g}" for k, v in worst.items()))
    print(f"  yardstick (0.15 N m/kg, spike 30 N m, node change 30 N m): "
          f"{'holds' if ok else 'fails'}")
    return ok


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("problems", nargs="*", type=Path, default=PROBLEMS)
    parser.add_argument("--set", action="append", default=[], dest="overrides")
    args = parser.parse_args()
    for path in args.problems:
        report(path, args.overrides)


if __name__ == "__main__":
    main()
