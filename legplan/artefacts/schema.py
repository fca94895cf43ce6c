"""Artefact kinds and the schema version each writer produces (ARCHITECTURE.md, "Artefacts").

A reader accepts a file whose `schema_version` is at most the version listed here; a newer file was
written by a newer legplan and is refused with a message saying so.
"""

SCHEMA_VERSIONS: dict[str, int] = {
    "map": 1,
    "steps": 1,
    "motion": 1,
    "nav": 1,
    "traj": 1,
    "sim": 1,
    "dataset": 1,
    "init": 1,
    "report": 1,
    "series": 1,
}

ROOT_ATTRS = ("legplan_kind", "schema_version", "legplan_version", "created", "command", "params",
              "seed", "inputs")

NAN_MEANS_NONE: dict[str, dict[str, str | None]] = {
    "steps": {"footholds": None, "checks/*": None},
    "dataset": {"y": "success", "cost": "success", "max_violation": "success", "seconds": "success"},
    "traj": {"tasks/*/nodes/*/span": None},
}
"""The float datasets of a kind (glob patterns on the path without the leading '/') in which NaN means
"none" rather than corruption: the swing legs' footholds of a steps file, the outcomes of a dataset's
tasks that did not converge, the time span of a node that ends no polynomial in a traj. A pattern mapped to the name of a boolean dataset is excused only in the
rows where that dataset is false. Every other float dataset of every kind holds finite values only
(`legplan.artefacts.reader.open_artefact` checks it for every reader)."""
