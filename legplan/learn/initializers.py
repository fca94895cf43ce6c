"""The `--init` resolver: the initializer object a command hands the planner, y₀ = A(x) of eq. (2).

    init = initializer("heuristic")      # A_h, `legplan.dyn.init.heuristic`
    init = initializer("init_2.h5")      # A_θ, `legplan.learn.network.LearnedInit`
    init = initializer("single_pallet_walk")  # A_θ shipped for that task space (`legplan.shipped`)
    plan(task, model, terrain, params, init)

The planner (`legplan.dyn`) takes any callable of the initializer signature and never resolves a
name: the names and the learned initializer live here, above it. Every command that takes `--init`
(`dyn plan`, `learn dataset`, `learn cycle`) resolves it through `initializer`, and
`check_warm_stage` refuses a warm stage that needs a learned guess before any work.
"""

from __future__ import annotations

import os

from legplan.dyn.init import INITIALIZERS
from legplan.errors import LegplanError


def resolve_init(name) -> str:
    """`--init` as the command uses it: a built-in initializer's name or an INIT.h5 path as given; the
    name of a task space with a shipped trained initializer (`legplan.shipped.shipped_initializer`)
    becomes that init.h5's path, so the rest of a command (checks, provenance) sees the file."""
    from legplan.shipped import shipped_initializer

    name = os.fspath(name)
    if name in INITIALIZERS or name.endswith(".h5"):
        return name
    shipped = shipped_initializer(name)
    return str(shipped) if shipped is not None else name


def is_learned(name) -> bool:
    """Whether `--init` names a trained init.h5 (A_θ), a file or a shipped one, rather than a built-in
    initializer."""
    return resolve_init(name).endswith(".h5")


def initializer(name) -> object:
    """The initializer `--init` names: one of `legplan.dyn.init.INITIALIZERS`, an init.h5 trained by
    `legplan learn train` (the learned initializer, eq. (2) with A_θ) or a shipped one by its task
    space's name; a one-line error otherwise."""
    name = resolve_init(name)
    if is_learned(name):
        if not os.path.isfile(name):
            raise LegplanError(f"--init: {name}: no such file")
        from legplan.learn.network import LearnedInit  # a learned --init only (start-up time)

        return LearnedInit(os.path.abspath(name))
    if name not in INITIALIZERS:
        from legplan.shipped import list_shipped_initializers

        shipped = list_shipped_initializers()
        raise LegplanError(f"--init: unknown initializer '{name}' (known: {', '.join(INITIALIZERS)}, an INIT.h5"
                           f"{', or a shipped one: ' + ', '.join(shipped) if shipped else ''})")
    return INITIALIZERS[name]


def check_warm_stage(warm_stage: str, init) -> None:
    """`--warm-stage projection` and `polish` project a learned guess: refused (one line) with any other
    `--init`; `polish` also needs the training filter an init.h5 keeps (`learn.network.CostBound`)."""
    if warm_stage == "costs":
        return
    init = resolve_init(init)
    if not is_learned(init):
        raise LegplanError(f"--warm-stage {warm_stage}: needs a learned --init INIT.h5, not '{init}' "
                           "(only a near-solution guess is projected; others are solved in stages)")
    from legplan.learn.network import load_bound, missing_filter  # a learned --init only (start-up time)

    if warm_stage == "polish" and os.path.isfile(init) and load_bound(init) is None:
        raise missing_filter(init)
