"""The solution vector y of eq. (2)-(3) of the TOWR-costs paper: a fixed layout per task space.

y is the concatenation of the full value vectors (fixed entries included) of the centroidal
problem's variable blocks, in the order of `CATEGORIES`:

    base_lin   base position spline: (nodes, value|derivative, xyz) flattened   (m, m/s)
    base_ang   base Euler-angle spline, same shape                               (rad, rad/s)
    feet       foot nodes of all feet, foot after foot: (nodes, value|derivative, xyz)   (m, m/s)
    forces     force nodes of all feet, foot after foot: (nodes, value|derivative, xyz)  (N, N/s)

(`legplan.dyn.formulation`). The sizes depend only on gait, strides, duration and the node spacing,
so one task space has one layout; an initializer trained for another layout is refused. The paper's
fifth category, phase durations, is not a variable here (the core plans the gait's fixed timings).
"""

from __future__ import annotations

import numpy as np

from legplan.errors import LegplanError

CATEGORIES = ("base_lin", "base_ang", "feet", "forces")


def layout_of(form) -> dict[str, int]:
    """Sizes of the categories of a `Formulation`: 6 values (value and derivative, xyz) per node."""
    return {"base_lin": 6 * form.base.nodes, "base_ang": 6 * form.base.nodes,
            "feet": 6 * form.motion_nodes, "forces": 6 * form.force_nodes}


def join(values: dict[str, np.ndarray]) -> np.ndarray:
    """y from the value vectors of the categories."""
    return np.concatenate([np.asarray(values[name], float).reshape(-1) for name in CATEGORIES])


def split(y: np.ndarray, layout: dict[str, int]) -> dict[str, np.ndarray]:
    """The value vectors of the categories from y (the inverse of `join`)."""
    ends = np.cumsum([layout[name] for name in CATEGORIES])
    if y.size != ends[-1]:
        raise LegplanError(f"solution vector of {y.size} values, the layout has {ends[-1]}")
    return dict(zip(CATEGORIES, np.split(np.asarray(y, float), ends[:-1])))


def category_index(layout: dict[str, int]) -> np.ndarray:
    """The category (index into `CATEGORIES`) of every entry of y."""
    return np.repeat(np.arange(len(CATEGORIES)), [layout[name] for name in CATEGORIES])


def check_layout(found: dict[str, int], expected: dict[str, int], source: str) -> None:
    """One-line error when an initializer's layout differs from the problem's."""
    for name in CATEGORIES:
        if int(found[name]) != int(expected[name]):
            raise LegplanError(f"{source}: field 'layout/{name}' has {int(found[name])} values, the problem "
                               f"needs {int(expected[name])} (trained for another gait, strides or duration)")
