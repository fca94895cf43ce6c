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
