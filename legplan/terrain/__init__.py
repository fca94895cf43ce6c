"""Terrain: heightmap, 3D signed distance field, foothold mask, occupancy, costmap; specs, importers.

    terrain = build_map("maps/gap_crossing.yaml")
    values, gradients = terrain.sdf.value_and_gradient(points)      # points (n, 3), trilinear
    values, gradients = ColumnDistance.of(terrain, reach).value_and_gradient(points)   # exact up to reach
    save_map(terrain, "map.h5"); terrain = load_map("map.h5")

Names are imported on first use (PEP 562 `__getattr__`): a command that loads a map.h5 does not
import the map specs' primitives and parser (`spec`, `primitives`), which only `build_map` needs.
"""

from legplan.lazy_exports import lazy_exports

_HOMES = {
    "ColumnDistance": "columns", "CostmapParams": "layers", "FootholdParams": "layers", "Grid2D": "grid",
    "SdfParams": "terrain_map", "SignedDistanceField": "sdf", "TerrainMap": "terrain_map", "build_map": "spec",
    "costmap_from_distance": "layers", "foothold_mask": "layers", "heightmap_sdf": "sdf", "load_map": "terrain_map",
    "obstacle_distance": "layers", "occupancy_grid": "layers", "save_map": "terrain_map",
    "terrain_from_heightmap": "terrain_map",
}
__all__ = sorted(_HOMES)

__getattr__, __dir__ = lazy_exports(__name__, _HOMES)
