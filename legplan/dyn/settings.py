"""The planner settings of `legplan dyn plan`: `--costs` (a preset or a costs file) and `--init`.

Presets: ``paper`` — `legplan.dyn.problem.PAPER`, the paper's costs with its swing-height and
base-clearance constraints; ``none`` — TOWR's formulation with our defaults, `DynParams()` (leg clearance
and the between-knot dynamics on). A costs file is a YAML mapping of `CostWeights` fields (each >= 0,
`stair_edge_sigma` > 0; missing fields are 0 = off) plus optional `swing_height_min`,
`base_clearance` and `leg_clearance` (m, >= 0; null = off; missing = `DynParams()`'s); with `preset: NAME` the
missing fields are the preset's instead (null still switches a constraint off), e.g.

    base_angular_velocity: 20.0
    force_rate: 1.0e-4
    swing_height_min: 0.05

or the paper's settings with the legs kept 6 cm off the terrain:

    preset: paper
    leg_clearance: 0.06

Unknown fields and bad values are one-line errors naming the file and the field.
"""

from __future__ import annotations

import os
from dataclasses import asdict, fields, replace
from pathlib import Path

from legplan.dyn.costs import CostWeights
from legplan.dyn.init import INITIALIZERS
from legplan.dyn.problem import PAPER, DynParams
from legplan.errors import LegplanError
from legplan.specio import FieldReader, read_yaml_mapping

PRESETS = {"paper": PAPER, "none": DynParams()}
CONSTRAINT_FIELDS = ("swing_height_min", "base_clearance", "leg_clearance")
POSITIVE_WEIGHTS = ("stair_edge_sigma",)


def costs_file(costs: str) -> Path | None:
    """The costs file `--costs` names, or None for a preset."""
    return None if costs in PRESETS else Path(costs)


def dyn_params(costs: str) -> DynParams:
    """The planner parameters of `--costs` (a preset name or a costs file, see module docstring)."""
    path = costs_file(costs)
    if path is None:
        return PRESETS[costs]
    if not path.is_file():
        raise LegplanError(f"--costs: '{costs}' is neither a preset ({', '.join(PRESETS)}) nor a file")
    data = read_yaml_mapping(path, "costs file")
    reader = FieldReader(path)
    weights = [f.name for f in fields(CostWeights)]
    reader.unknown(data, ("preset", *weights, *CONSTRAINT_FIELDS))
    base = PRESETS[reader.choice(data["preset"], "preset", tuple(PRESETS))] if "preset" in data else DynParams()
    values = {name: (reader.positive if name in POSITIVE_WEIGHTS else reader.nonnegative)(data[name], name)
              for name in weights if name in data}
    limits = {name: None if data[name] is None else reader.nonnegative(data[name], name)
              for name in CONSTRAINT_FIELDS if name in data}
    return replace(base, costs=replace(base.costs, **values), **limits)


def initializer(name: str):
    """The initializer `--init` names: one of `legplan.dyn.init.INITIALIZERS`, or an init.h5 trained by
    `legplan learn train` (the learned initializer, eq. (2) with A_θ)."""
    if name.endswith(".h5"):
        from legplan.learn.network import LearnedInit  # learn builds on dyn: imported where it is used
        if not os.path.isfile(name):
            raise LegplanError(f"--init: {name}: no such file")
        return LearnedInit(os.path.abspath(name))
    if name not in INITIALIZERS:
        raise LegplanError(f"--init: unknown initializer '{name}' (known: {', '.join(INITIALIZERS)})")
    return INITIALIZERS[name]


def check_warm_stage(warm_stage: str, init: str) -> None:
    """`--warm-stage projection` and `polish` project a learned guess: refused (one line) with any other
    `--init`; `polish` also needs the training filter an init.h5 keeps (`learn.network.CostBound`)."""
    if warm_stage == "costs":
        return
    if not str(init).endswith(".h5"):
        raise LegplanError(f"--warm-stage {warm_stage}: needs a learned --init INIT.h5, not '{init}' "
                           "(only a near-solution guess is projected; others are solved in stages)")
    if warm_stage == "polish":
        from legplan.learn.network import load_bound, missing_filter  # learn builds on dyn: imported where used

        if os.path.isfile(init) and load_bound(init) is None:
            raise missing_filter(init)


def settings_record(costs: str, init: str, params: DynParams) -> dict:
    """The JSON-able settings of a run: `--costs` as given, `--init`, and every planner parameter."""
    return {"costs": os.fspath(costs), "init": init, "dyn": asdict(params)}
