"""Figures of `legplan learn` artefacts for `legplan report` (the TOWR-costs paper's Fig. 6 and Fig. 8).

    dataset_figure("dataset_1.h5", "d1.png")   # cost histogram of the converged tasks, success vs iterations
    init_figure("init_1.h5", "i1.png")         # the fit: RMS error per variable category

Success against the iteration count k (Fig. 8, phase durations fixed: the planner does not optimize
them) is read off one solve per task: the planner is deterministic, so a task that converged after
i iterations converges under every budget k ≥ i and under none below it; the curve is the fraction
of all tasks converged within k.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from legplan.artefacts import open_artefact, read_summary
from legplan.learn.dataset import read_dataset
from legplan.learn.layout import CATEGORIES
from legplan.learn.network import filter_rule


def success_within(success: np.ndarray, iterations: np.ndarray, budgets: np.ndarray) -> np.ndarray:
    """Fraction of the tasks converged within each budget k (module docstring)."""
    ok = np.asarray(success, bool)
    it = np.asarray(iterations, float)
    return np.array([np.mean(ok & (it <= k)) for k in budgets]) if ok.size else np.zeros(len(budgets))


def dataset_figure(path: Path, png: Path) -> str:
    """Cost histogram of the converged tasks and success against the iteration count."""
    data = read_dataset(path)
    ok = np.asarray(data["success"], bool)
    cost, it = np.asarray(data["cost"], float), np.asarray(data["iterations"], float)
    fig = Figure(figsize=(9.0, 3.4), layout="constrained")
    left, right = fig.subplots(1, 2)
    if ok.any():
        left.hist(cost[ok], bins=min(40, max(5, ok.sum() // 5)), color="tab:blue")
        left.axvline(np.median(cost[ok]), color="k", lw=1, label=f"median {np.median(cost[ok]):.3g}")
        left.legend(loc="upper right", fontsize=8)
    left.set(xlabel="final cost g(y)", ylabel="converged tasks", title="cost (Fig. 6)")
    budgets = np.arange(0, int(max(it.max(initial=0), 1)) + 1)
    right.step(budgets, success_within(ok, it, budgets), where="post", color="tab:green")
    right.set(xlabel="iteration budget k", ylabel="fraction converged", ylim=(0, 1.02),
              title="success vs iterations (Fig. 8)")
    right.grid(alpha=0.3)
    fig.savefig(png, dpi=90)
    return (f"{ok.sum()}/{ok.size} tasks converged; median {np.median(it[ok]) if ok.any() else float('nan'):g} "
            "iterations of the converged ones. Left: their final costs; right: the fraction of all tasks "
            "converged within k iterations.")


def init_figure(path: Path, png: Path) -> str:
    """RMS validation error per variable category of a trained initializer."""
    with open_artefact(path, kind="init") as handle:
        report = read_summary(handle)
    value = lambda key: report.get(key, (np.nan, ""))[0]  # noqa: E731
    names = [c for c in CATEGORIES if f"rms_{c}" in report]  # the categories the network predicts
    fig = Figure(figsize=(6.0, 3.0), layout="constrained")
    ax = fig.subplots()
    ax.bar(names, [value(f"rms_{c}") for c in names], color="tab:purple")
    ax.set(ylabel="RMS error (SI units)", yscale="log", title="network vs solutions, validation tasks")
    ax.tick_params(axis="x", labelrotation=20)
    fig.savefig(png, dpi=90)
    rule = filter_rule(value("g_max"), value("g_max_conditional") == 1.0)
    return (f"Trained on {value('good'):g} of {value('tasks'):g} tasks ({rule}); weighted "
            f"validation loss {value('validation_loss'):.3g}. RMS error per variable category.")
