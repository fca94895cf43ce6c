"""The check a report makes of every artefact before rendering anything: an artefact missing what
its kind's reader needs (a steps.h5 without `/q`, a motion.h5 without `/steps`, ...) is bad input
(`ArtefactError`, exit 2, no report written), not a page with silently missing figures."""

from __future__ import annotations

import os

from legplan.artefacts import open_artefact, require


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
    elif kind == "map":
        with open_artefact(path, kind="map") as handle:
            require(handle, "terrain/height")
