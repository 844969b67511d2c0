"""Plot speed: the inverse-dynamics figures, the layout cost, the GIF, --no-plots.

Run: ``python benchmarks/bench_plots.py [--repeats 5]``. Prints min and median CPU
seconds over the repeats (process CPU, so other load on the machine matters less):

1. ``save_gait_plots`` (angles, moments, powers, GRF of the bundled right leg) as shipped
   (Pillow charts, report/raster.py);
2. the same three-panel figure drawn with matplotlib's constrained layout, with
   matplotlib and predgait's fixed margins (report/figures.py), and with Pillow
   (report/raster.py, what ``predgait inverse`` writes); all in this run, like for like;
3. ``write_gif`` of the leg over 1 s (21 frames, Pillow);
4. ``predgait simulate problems/resynthesis.toml`` as a whole process, with and without
   ``--no-plots`` (wall seconds).
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]


def cpu(fn, repeats: int) -> list[float]:
    times = []
    for _ in range(repeats):
        start = time.process_time()
        fn()
        times.append(time.process_time() - start)
    return times


def show(name: str, times: list[float], unit: str = "s CPU") -> None:
    print(f"{name:<58} min {min(times):7.3f}  median {statistics.median(times):7.3f} {unit}")


def three_panels_pillow(path: Path) -> None:
    from predgait.report.raster import Line, Panel, save_chart

    x = np.linspace(0, 100, 151)
    panels = [Panel((Line(x, np.sin(x / 10 + k)),), title=f"panel {k}", xlabel="% gait cycle",
                    ylabel="angle (deg)" if k == 0 else "") for k in range(3)]
    save_chart(path, panels, size=(12, 3.4), title="three panels")


def three_panels(constrained: bool, path: Path) -> None:
    x = np.linspace(0, 100, 151)
    if constrained:
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(1, 3, figsize=(12, 3.4), constrained_layout=True)
    else:
        from predgait.report.figures import new_figure

        fig, axes = new_figure(1, 3, figsize=(12, 3.4), title=True)
    for k, ax in enumerate(axes):
        ax.plot(x, np.sin(x / 10 + k))
        ax.set_title(f"panel {k}")
        ax.set_xlabel("% gait cycle")
    axes[0].set_ylabel("angle (deg)")
    fig.suptitle("three panels")
    fig.savefig(path, dpi=110)
    if constrained:
        import matplotlib.pyplot as plt

        plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    import matplotlib

    matplotlib.use("Agg")
    from predgait.dynamics.inverse_trial import bundled_inverse
    from predgait.models.loading import load_model
    from predgait.report.gait_plots import save_gait_plots
    from predgait.report.stick import write_gif

    result = bundled_inverse("right")
    print("machine shared with other work: compare medians, not single runs")
    with tempfile.TemporaryDirectory() as folder:
        out = Path(folder)
        save_gait_plots(result, out)  # warm-up: fonts, caches
        show("1. inverse plots (4 figures, 10 panels)",
             cpu(lambda: save_gait_plots(result, out), args.repeats))
        old = cpu(lambda: three_panels(True, out / "a.png"), args.repeats)
        new = cpu(lambda: three_panels(False, out / "b.png"), args.repeats)
        light = cpu(lambda: three_panels_pillow(out / "c.png"), args.repeats)
        show("2. three-panel figure, matplotlib constrained layout", old)
        show("   three-panel figure, matplotlib fixed margins", new)
        show("   three-panel figure, Pillow (report.raster)", light)
        print(f"   ratio of medians constrained / fixed: "
              f"{statistics.median(old) / statistics.median(new):.2f}; fixed / Pillow: "
              f"{statistics.median(new) / statistics.median(light):.2f}")
        leg = load_model("leg")
        t = np.linspace(0.0, 1.0, 201)
        q = np.zeros((t.size, leg.nq))
        q[:, 4] = -np.sin(3 * t)
        show("3. stick.gif of the leg, 1 s (21 frames)",
             cpu(lambda: write_gif(out / "s.gif", leg, t, q, reference_q=0.5 * q),
                 args.repeats))
        for flags, name in (([], "with plots"), (["--no-plots"], "--no-plots")):
            walls = []
            for k in range(max(2, args.repeats // 2)):
                start = time.perf_counter()
                subprocess.run([sys.executable, "-m", "predgait", "simulate",
                                str(REPO / "problems" / "resynthesis.toml"), "--out",
                                str(out / f"r{name}{k}"), *flags], check=True,
                               capture_output=True)
                walls.append(time.perf_counter() - start)
            show(f"4. predgait simulate resynthesis.toml, {name}", walls, "s wall")


if __name__ == "__main__":
    main()
