"""A trained initializer made ready to ship, and the ones that ship (`legplan learn ship`, `learn shipped`).

The learned initializer exists so that plans of a task space are fast from the first call (the
TOWR-costs paper, Sec. IV); a user should not need the hours of `learn cycle` to get it. A shipped
initializer is one init.h5 in the shipped `tasks/initializers/` (`legplan.shipped.INITIALIZERS`), named
after the task space it was trained on (tasks/NAME.yaml), which `--init NAME` resolves to. It holds
the trained network's arrays as `legplan learn train` wrote them (plain arrays, no pickle), and its
provenance is that of `legplan learn ship` (inputs: the trained init.h5 and the held-out dataset, by
sha256) with params recording

* `trained` — how it was made: the training's command, seed, params and the sha256 of every dataset
  it was trained on (from the trained init.h5's provenance);
* `held_out` — how it did on tasks the training never saw (a dataset of another seed solved from it,
  `summarize`: converged share, median iterations and time, cost quantiles, and max/median cost, the
  paper's spread measure).

`ship_initializer` refuses a dataset that was not solved from that init.h5 or whose seed is a
training seed (not held out).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from legplan.errors import LegplanError


def ship_initializer(init_path, held_out_path, output_dir, *, overwrite: bool = False) -> dict:
    """NAME.h5 in `output_dir` (module docstring) from a trained init.h5 and the dataset `legplan learn
    dataset --init INIT` solved on held-out tasks; returns {"name", "space", "trained", "held_out"}."""
    from legplan.artefacts import open_artefact, read_provenance, sha256_file, write_artefact
    from legplan.learn.dataset import KIND as DATASET_KIND
    from legplan.learn.dataset import read_dataset, summarize
    from legplan.learn.network import KIND as INIT_KIND

    for path in (init_path, held_out_path):  # each readable, in the order given, before their kinds
        with open_artefact(path):
            pass
    with open_artefact(init_path, kind=INIT_KIND) as f:
        trained = read_provenance(f)
        space = json.loads(f.attrs["space"])
    with open_artefact(held_out_path, kind=DATASET_KIND) as f:
        held = read_provenance(f)
    init_sha = sha256_file(init_path)
    solved_from = [record for record in held["inputs"] if record.get("sha256") == init_sha]
    if not solved_from:
        raise LegplanError(f"{held_out_path}: field 'inputs': not solved from {init_path} (its sha256 is not among "
                           "the dataset's inputs): solve the held-out tasks with --init INIT")
    training_seeds = {trained["seed"], *_dataset_seeds(trained["inputs"])}
    if held["seed"] in training_seeds:
        raise LegplanError(f"{held_out_path}: field 'seed': {held['seed']} is a seed of the training's datasets, so its "
                           "tasks are not held out: sample them with another --seed")
    data = read_dataset(held_out_path)
    summary = {key: _number(value[0] if isinstance(value, tuple) else value)
               for key, value in summarize(data["success"], data["iterations"], data["cost"], data["seconds"]).items()}
    summary["cost_max_over_median"] = (summary["cost_max"] / summary["cost_median"]
                                       if summary["cost_median"] else None)  # None: no cost (or none converged)
    name = str(space["name"])
    record = {"trained": {"command": trained["command"], "seed": trained["seed"], "created": trained["created"],
                          "legplan_version": trained["legplan_version"], "params": trained["params"],
                          "datasets": _datasets(trained["inputs"])},
              "held_out": {"command": held["command"], "seed": held["seed"], "created": held["created"],
                           "dataset_sha256": sha256_file(held_out_path), **summary}}
    target = Path(output_dir) / f"{name}.h5"
    Path(output_dir).mkdir(parents=True, exist_ok=True)
    with open_artefact(init_path, kind=INIT_KIND) as source, \
            write_artefact(target, INIT_KIND, params=record, seed=trained["seed"], inputs=[init_path, held_out_path],
                           overwrite=overwrite) as handle:
        for key, value in source.attrs.items():
            if key not in handle.attrs:  # the network's own attributes; the provenance is this command's
                handle.attrs[key] = value
        for key in source:
            source.copy(source[key], handle, key)
    return {"name": name, "space": space, **record}


def shipped_records() -> list[dict]:
    """What `ship_initializer` recorded of every shipped initializer (`legplan.shipped`), with its name
    and space: {"name", "space", "trained", "held_out"}."""
    from legplan.artefacts import open_artefact, read_provenance
    from legplan.learn.network import KIND as INIT_KIND
    from legplan.shipped import shipped_initializer, list_shipped_initializers

    records = []
    for name in list_shipped_initializers():
        path = shipped_initializer(name)
        with open_artefact(path, kind=INIT_KIND) as f:
            params = read_provenance(f)["params"]
            space = json.loads(f.attrs["space"])
        missing = [key for key in ("trained", "held_out") if key not in params]
        if missing:
            raise LegplanError(f"{path}: field 'params.{missing[0]}' is missing (not written by legplan learn ship)")
        records.append({"name": name, "space": space, **params})
    return records


def _number(value):
    """A JSON value of a summary number: None for NaN (nothing converged)."""
    value = float(value)
    return None if value != value else value


def _datasets(inputs: list[dict]) -> list[dict]:
    """The datasets among an artefact's recorded inputs: their file names and sha256."""
    return [{"path": os.path.basename(record["path"]), "sha256": record["sha256"]}
            for record in inputs if str(record.get("path", "")).endswith(".h5")]


def _dataset_seeds(inputs: list[dict]) -> set:
    """The seeds of the datasets among `inputs` that still exist where they were recorded."""
    from legplan.artefacts import open_artefact, read_provenance

    seeds = set()
    for record in inputs:
        path = str(record.get("path", ""))
        if path.endswith(".h5") and os.path.isfile(path):
            with open_artefact(path) as f:
                seeds.add(read_provenance(f)["seed"])
    return seeds
