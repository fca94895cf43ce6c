"""`legplan learn train`: dataset.h5 (or a cycle's datasets) → filter (eq. (4)) → weighted fit (eq. (3)) → init.h5.

    report = train_initializer("dataset.h5", "init.h5", g_max="auto", hidden=(256, 256), seed=0)
    report = train_initializer(["dataset_0.h5", "dataset_1.h5"], "init_2.h5")  # best outcome per task
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from legplan.learn.dataset import best_outcomes, read_dataset
from legplan.learn.network import FitParams, filter_good, fit, read_weights, save_init


def train_initializer(dataset_paths, output, *, g_max: float | str = "auto", hidden: tuple[int, ...] = (256, 256),
                      weights_path=None, seed: int = 0, validation: float = 0.2, overwrite: bool = False,
                      fit_params: FitParams = FitParams()) -> dict:
    """Train A_θ on the filtered outcomes and write init.h5; returns the fit report (also its /summary).

    `dataset_paths`: one dataset.h5, or several of the same tasks (a cycle's), of which each task's
    best converged outcome is used (`best_outcomes`); `fit_params`: penalty, output normalization
    and ensemble of the fit (`legplan.learn.network.FitParams`)."""
    paths = [dataset_paths] if isinstance(dataset_paths, (str, os.PathLike)) else list(dataset_paths)
    weights = read_weights(weights_path)  # the small input first: a bad file fails before the dataset is read
    data = best_outcomes(paths) if len(paths) > 1 else read_dataset(paths[0])
    source = ", ".join(map(os.fspath, paths))
    good, bound = filter_good(data["success"], data["cost"], g_max, source, data["x"])
    net, report, _ = fit(data["x"][good], data["y"][good], data["layout"], weights, tuple(hidden), seed, validation,
                             params=fit_params)
    report = {"tasks": len(good), "converged": int(np.sum(data["success"])), "good": int(good.sum()),
              "g_max": bound.threshold, "g_max_conditional": float(bound.conditional), **report}
    if len(paths) > 1:  # where the kept outcomes came from
        for path, count in zip(paths, np.bincount(data["source"][good], minlength=len(paths))):
            report[f"good_from_{Path(path).stem}"] = int(count)
    settings = {"g_max": g_max, "hidden": list(hidden), "weights": weights, "validation": validation,
                "fit": fit_params.as_dict()}
    inputs = paths + ([weights_path] if weights_path is not None else [])
    save_init(output, net, data["layout"], data["space"], report, settings, seed, inputs, overwrite, bound)
    return report
