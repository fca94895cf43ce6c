"""`legplan learn train`: dataset.h5 → filter (eq. (4)) → weighted fit (eq. (3)) → init.h5.

    report = train_initializer("dataset.h5", "init.h5", g_max="auto", hidden=(256, 256), seed=0)
"""

from __future__ import annotations

import os

import numpy as np

from legplan.learn.dataset import read_dataset
from legplan.learn.network import filter_good, fit, read_weights, save_init


def train_initializer(dataset_path, output, *, g_max: float | str = "auto", hidden: tuple[int, ...] = (256, 256),
                      weights_path=None, seed: int = 0, validation: float = 0.2, overwrite: bool = False) -> dict:
    """Train A_θ on the filtered dataset and write init.h5; returns the fit report (also its /summary)."""
    weights = read_weights(weights_path)  # the small input first: a bad file fails before the dataset is read
    data = read_dataset(dataset_path)
    good, threshold = filter_good(data["success"], data["cost"], g_max, os.fspath(dataset_path))
    net, report, _ = fit(data["x"][good], data["y"][good], data["layout"], weights, tuple(hidden), seed, validation)
    report = {"tasks": len(good), "converged": int(np.sum(data["success"])), "good": int(good.sum()),
              "g_max": float(threshold), **report}
    settings = {"g_max": g_max, "hidden": list(hidden), "weights": weights, "validation": validation}
    inputs = [dataset_path] + ([weights_path] if weights_path is not None else [])
    save_init(output, net, data["layout"], data["space"], report, settings, seed, inputs, overwrite)
    return report
