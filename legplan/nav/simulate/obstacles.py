"""Hidden obstacles of a run: a YAML list of map primitives rasterized on the map's grid."""

from __future__ import annotations

import numpy as np

from legplan.errors import SpecError
from legplan.specio import read_yaml_mapping
from legplan.terrain.grid import Grid2D
from legplan.terrain.primitives import rasterize


def hidden_obstacles(spec_path, grid: Grid2D) -> np.ndarray:
    """Cells covered by the obstacles of a YAML spec `obstacles: [<map primitive>, ...]` (the map
    primitives of `legplan.terrain.primitives`; every listed shape is an obstacle)."""
    data = read_yaml_mapping(spec_path, "hidden-obstacles spec")
    entries = data.get("obstacles")
    if not isinstance(entries, list):
        raise SpecError(f"{spec_path}: field 'obstacles' must be a list of map primitives")
    X, Y = grid.centres()
    mask = np.zeros(grid.shape, bool)
    for i, entry in enumerate(entries):
        mask |= rasterize(entry, f"obstacles[{i}]", str(spec_path), X, Y, 0.0).mask
    return mask
