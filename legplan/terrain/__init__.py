"""Terrain: heightmap, 3D signed distance field, foothold mask, occupancy, costmap; specs, importers.

    terrain = build_map("maps/gap_crossing.yaml")
    values, gradients = terrain.sdf.value_and_gradient(points)      # points (n, 3), trilinear
    values, gradients = ColumnDistance.of(terrain, reach).value_and_gradient(points)   # exact up to reach
    save_map(terrain, "map.h5"); terrain = load_map("map.h5")
"""

from legplan.terrain.columns import ColumnDistance
from legplan.terrain.grid import Grid2D
from legplan.terrain.layers import (CostmapParams, FootholdParams, costmap_from_distance, foothold_mask,
                                    obstacle_distance, occupancy_grid)
from legplan.terrain.sdf import SignedDistanceField, heightmap_sdf
from legplan.terrain.spec import build_map
from legplan.terrain.terrain_map import (SdfParams, TerrainMap, load_map, save_map,
                                         terrain_from_heightmap)

__all__ = ["ColumnDistance", "CostmapParams", "FootholdParams", "Grid2D", "SdfParams", "SignedDistanceField",
           "TerrainMap", "build_map", "costmap_from_distance", "foothold_mask", "heightmap_sdf", "load_map",
           "obstacle_distance", "occupancy_grid", "save_map", "terrain_from_heightmap"]
