"""The solution vector y of eq. (2)-(3) of the TOWR-costs paper: a fixed layout per task space.

y is the concatenation of the full value vectors (fixed entries included) of the centroidal
problem's variable blocks, in the order of `CATEGORIES`:

    base_lin   base position spline: (nodes, value|derivative, xyz) flattened   (m, m/s)
    base_ang   base Euler-angle spline, same shape                               (rad, rad/s)
    feet       foot nodes of all feet, foot after foot: (nodes, value|derivative, xyz)   (m, m/s)
    forces     force nodes of all feet, foot after foot: (nodes, value|derivative, xyz)  (N, N/s)
    phases     the phase durations, foot after foot, all but each foot's last (s): the paper's fifth
               category; present (2S values) when the tasks were solved with the durations
               optimized (`DynParams.optimize_phases`) or from a network that predicts them,
               else empty (the gait's fixed timing)

(`legplan.dyn.formulation`, `legplan.dyn.timing`). The sizes depend only on gait, strides, duration,
the node spacing and whether the durations are optimized, so one task space has one layout per
choice; an initializer trained for another layout is refused. A network that predicts the durations
initializes them (optimized from there, or kept fixed at them without `optimize_phases`: Fig. 8's
two curves); one that does not leaves the gait's. Files written before the fifth category have no
``layout/phases``: read as empty.
"""

from __future__ import annotations

import numpy as np

from legplan.errors import LegplanError

CATEGORIES = ("base_lin", "base_ang", "feet", "forces", "phases")


def layout_of(form, phases: bool = False) -> dict[str, int]:
    """Sizes of the categories of a `Formulation`: 6 values (value and derivative, xyz) per node, and
    with `phases` one per phase of every foot but its last."""
    return {"base_lin": 6 * form.base.nodes, "base_ang": 6 * form.base.nodes,
            "feet": 6 * form.motion_nodes, "forces": 6 * form.force_nodes,
            "phases": sum(len(foot.phases) - 1 for foot in form.feet) if phases else 0}


def join(values: dict[str, np.ndarray]) -> np.ndarray:
    """y from the value vectors of the categories (``phases`` empty when `values` has none)."""
    return np.concatenate([np.asarray(values.get(name, ()), float).reshape(-1) for name in CATEGORIES])


def split(y: np.ndarray, layout: dict[str, int]) -> dict[str, np.ndarray]:
    """The value vectors of the non-empty categories from y (the inverse of `join`)."""
    ends = np.cumsum([layout[name] for name in CATEGORIES])
    if y.size != ends[-1]:
        raise LegplanError(f"solution vector of {y.size} values, the layout has {ends[-1]}")
    return {name: part for name, part in zip(CATEGORIES, np.split(np.asarray(y, float), ends[:-1]))
            if layout[name] > 0}


def read_layout(f) -> dict[str, int]:
    """``layout/<category>`` of an open dataset.h5 or init.h5 (``phases`` absent: empty)."""
    from legplan.artefacts import read_array

    return {name: int(read_array(f, f"layout/{name}", ndim=0)) if name != "phases" or f"layout/{name}" in f else 0
            for name in CATEGORIES}


def category_index(layout: dict[str, int]) -> np.ndarray:
    """The category (index into `CATEGORIES`) of every entry of y."""
    return np.repeat(np.arange(len(CATEGORIES)), [layout[name] for name in CATEGORIES])


def check_layout(found: dict[str, int], expected: dict[str, int], source: str) -> None:
    """One-line error when an initializer's layout differs from the problem's (`expected` with the
    problem's phase count: an initializer may predict the durations or not)."""
    for name in CATEGORIES:
        if int(found[name]) != int(expected[name]) and not (name == "phases" and int(found[name]) == 0):
            raise LegplanError(f"{source}: field 'layout/{name}' has {int(found[name])} values, the problem "
                               f"needs {int(expected[name])} (trained for another gait, strides or duration)")
