"""The check a report makes of every artefact before rendering anything: an artefact missing what
its kind's reader needs (a steps.h5 without `/q`, a motion.h5 without `/steps`, ...) is bad input
(`ArtefactError`, exit 2, no report written), not a page with silently missing figures."""

from __future__ import annotations

import os

from legplan.artefacts import open_artefact, read_array, require, require_attrs
from legplan.errors import ArtefactError


def check_artefact(path: str | os.PathLike, kind: str) -> None:
    """Read the artefact with its kind's own reader (which names the file and the missing dataset)."""
    if kind == "steps":
        from legplan.stepseq import read_steps

        read_steps(path)
    elif kind == "motion":
        from legplan.stepplan.batch import read_motion

        read_motion(path)
    elif kind == "traj":
        from legplan.dyn.artefact import read_tasks

        read_tasks(path)
    elif kind == "sim":
        _check_sim(path)
    elif kind == "map":
        with open_artefact(path, kind="map") as handle:
            require(handle, "terrain/height")


SIM_SERIES = {"t": 1, "base_pos": 2, "base_quat": 2, "joint_pos": 2, "foot_forces": 3}
"""The series of an executed sim task the report draws (name: dimensions), `legplan.sim.artefact`."""


def _check_sim(path) -> None:
    """A sim.h5: its robot and joint order, and of every executed task (one with `series/`) the
    series the sim section draws, readable, finite, of their dimensions and one row per sample."""
    with open_artefact(path, kind="sim") as handle:
        require_attrs(handle, ("robot", "joints"))
        tasks = require(handle, "tasks")
        for name in sorted(tasks):
            if "series" not in tasks[name]:
                continue
            series = tasks[name]["series"]
            arrays = {key: read_array(series, key, ndim=ndim) for key, ndim in SIM_SERIES.items()}
            rows = {key: len(value) for key, value in arrays.items()}
            if len(set(rows.values())) > 1 or rows["t"] < 1:
                raise ArtefactError(f"{path}: tasks/{name}/series: datasets of different lengths {rows}")
