"""Figures of predicted gait7 strides: stick figures, joint angles, vertical GRF."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from predgait.kinematics.clinical import clinical_joint
from predgait.report.figures import new_figure, save_figure
from predgait.report.stick import plot_stick

ANGLES = ("hip", "knee", "ankle")


def save_prediction_plots(stage: Path, model, predictions: dict, *,
                          models: dict | None = None) -> list[Path]:
    """predicted_stick.png, predicted_angles.png, predicted_grf.png for named predictions.

    Args:
        stage: Output folder.
        model: gait7 (stick figures of every prediction unless ``models`` names its own).
        predictions: label -> :class:`predgait.scenarios.predict.Prediction`.
        models: Optional label -> the (edited) model of that prediction.
    """
    models = models or {}
    paths = []
    n = len(predictions)
    fig, axes = new_figure(1, n, figsize=(4.5 * n, 4.0), squeeze=False)
    for ax, (label, pred) in zip(axes[0], predictions.items(), strict=True):
        st = pred.aligned
        plot_stick(models.get(label, model), st["t"], st["q"], interval=0.1, ax=ax)
        ax.set_title(f"{label}: one stride, every 0.1 s")
    paths.append(save_figure(fig, stage / "predicted_stick.png"))

    fig, axes = new_figure(1, 3, figsize=(13, 3.8), squeeze=False)
    for ax, joint in zip(axes[0], ANGLES, strict=True):
        for label, pred in predictions.items():
            st = pred.aligned
            cycle = 100 * st["t"] / st["t"][-1]
            j = clinical_joint(model, f"{joint}_r")
            angle = j.clinical(st["q"][:, model.coordinate_index(f"{joint}_r")])
            ax.plot(cycle, np.degrees(angle), label=label)
        ax.set_title(f"right {j.angle.removesuffix('_r').replace('_', ' ')}")
        ax.set_xlabel("% stride (from right heel strike)")
        ax.set_ylabel("deg")
    axes[0][0].legend(fontsize=8)
    paths.append(save_figure(fig, stage / "predicted_angles.png"))

    fig, ax = new_figure(figsize=(6, 3.8))
    for label, pred in predictions.items():
        st = pred.aligned
        cycle = 100 * st["t"] / st["t"][-1]
        ax.plot(cycle, st["contact"][:, :2, 1].sum(axis=1), label=f"{label} (right foot)")
    ax.set_xlabel("% stride (from right heel strike)")
    ax.set_ylabel("vertical GRF (N)")
    ax.legend(fontsize=8)
    paths.append(save_figure(fig, stage / "predicted_grf.png"))
    return paths
