"""Size budgets: what one command may allocate, checked before it allocates.

A count an input gives (strides, tasks, hidden units, iterations) multiplies into memory and time
long before a stage could notice; a stage therefore computes the size its input asks for
(optimization variables, network weights, batch items) from the input alone and calls `check_size`
first. (A map's grid has its own estimate of bytes per cell and SDF layer,
`legplan.terrain.terrain_map.check_memory`.) The limits are far above any real use (a walk of
thousands of footsteps, a network of millions of weights) and far below what exhausts a
workstation; a refusal is one line naming the input and the field that asked for it:

    check_size("variables", variables, f"{source}: row {i}: field 'strides'")
    -> "tasks.csv: row 0: field 'strides' asks for 800120 optimization variables, more than the
       budget of 200000 (legplan.budget.VARIABLES)"

`LIMITS` also bounds every count option of the command line (`legplan.cli.options.count`).
"""

from __future__ import annotations

from legplan.errors import LegplanError

VARIABLES = 200_000
"""Optimization variables of one problem (a centroidal plan, a step's Bézier curves)."""
WEIGHTS = 20_000_000
"""Weights of one network (160 MB of float64; the training keeps a few copies)."""
ITEMS = 1_000_000
"""Items of one batch (tasks, queries, step pairs, dataset tasks)."""
ITERATIONS = 1_000_000
"""Iterations, rounds, moves or restarts a user asks for."""
STRIDES = 10_000
"""Strides of one motion."""
WORKERS = 1024
"""Worker processes of one command."""

LIMITS = {"variables": VARIABLES, "weights": WEIGHTS, "items": ITEMS,
          "iterations": ITERATIONS, "strides": STRIDES, "workers": WORKERS}
_NAMES = {"variables": "VARIABLES", "weights": "WEIGHTS", "items": "ITEMS",
          "iterations": "ITERATIONS", "strides": "STRIDES",
          "workers": "WORKERS"}
_WHAT = {"variables": "optimization variables", "weights": "network weights",
         "items": "items", "iterations": "iterations", "strides": "strides",
         "workers": "worker processes"}


class SizeError(LegplanError):
    """An input asks for more than a size budget."""


def check_size(quantity: str, needed: float, where: str) -> None:
    """`SizeError` "WHERE asks for N QUANTITY, more than the budget of LIMIT" when `needed` (computed
    from the input before anything is allocated) exceeds `LIMITS[quantity]`."""
    limit = LIMITS[quantity]
    if needed > limit:
        shown = f"{needed:.3g}" if needed >= 1e9 else f"{int(needed)}"
        raise SizeError(f"{where} asks for {shown} {_WHAT[quantity]}, more than the budget of {limit} "
                        f"(legplan.budget.{_NAMES[quantity]})")
