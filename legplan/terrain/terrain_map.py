"""`TerrainMap`: heightmap, SDF, foothold mask and 2D navigation layers of one map, and its artefact.

map.h5 layout (kind "map"):
  /terrain             attrs name, ground (m)
  /terrain/height      (ny, nx) m, attrs origin [x0, y0] (centre of cell [0, 0]), resolution
  /terrain/sdf         (nz, ny, nx) m, attrs origin [x0, y0, z0], resolution
  /terrain/foothold    (ny, nx) uint8, attrs flat_radius, flat_tolerance, edge_margin, origin, resolution
  /nav/occupancy       (ny, nx) uint8, attrs obstacle_height, origin, resolution
  /nav/distance        (ny, nx) m (distance from cell centre to nearest obstacle cell centre)
  /nav/costmap         (ny, nx), attrs l1, l2, c_max, lambda_c, resolution, origin (eqs. (15)-(16))
  /summary             size, resolution, height range, foothold and occupied fractions
"""

from __future__ import annotations

import logging
import os
from dataclasses import asdict, dataclass

import numpy as np

from legplan.artefacts import (check_finite, open_artefact, read_array, require, write_artefact, write_dataset,
                               write_summary)
from legplan.errors import ArtefactError, SpecError
from legplan.terrain.grid import Grid2D
from legplan.terrain.layers import (CostmapParams, FootholdParams, costmap_from_distance, foothold_mask,
                                    obstacle_distance, occupancy_grid)
from legplan.terrain.sdf import Progress, SignedDistanceField, heightmap_sdf, sdf_layers

log = logging.getLogger(__name__)

MAX_MAP_BYTES = 2 * 1024 ** 3
"""Refuse maps whose estimated working memory exceeds this (bytes)."""
MAX_SDF_WORK = 5e9
"""Refuse SDFs whose vertical combination (voxels x layers / 2 element steps, quadratic in the
layer count) exceeds this: about a minute here; 14x the largest shipped map (stairs, 3.5e8)."""

_BYTES_PER_CELL = 120   # heightmap, 2D layers and temporaries, float64
_BYTES_PER_VOXEL = 32   # SDF values, four per-layer stacks (distance, top) and temporaries, float32


@dataclass(frozen=True)
class SdfParams:
    """Vertical extent of the SDF: from `z_min` (default: lowest height - 2 cells) to `z_max`
    (default: highest height + `clearance`)."""

    z_min: float | None = None
    z_max: float | None = None
    clearance: float = 0.3

    def bounds(self, height: np.ndarray, resolution: float) -> tuple[float, float]:
        z_min = float(height.min()) - 2 * resolution if self.z_min is None else self.z_min
        z_max = float(height.max()) + self.clearance if self.z_max is None else self.z_max
        return z_min, z_max


@dataclass
class TerrainMap:
    """Everything the planners need to know about one terrain (see module docstring for the file)."""

    name: str
    grid: Grid2D
    ground: float
    height: np.ndarray
    sdf: SignedDistanceField
    foothold: np.ndarray
    occupancy: np.ndarray
    distance: np.ndarray
    costmap: np.ndarray
    foothold_params: FootholdParams
    nav_params: CostmapParams

    def height_at(self, xy, method: str = "bilinear") -> np.ndarray:
        """Terrain height (m) at points (n, 2): bilinear between cell centres, or the containing
        cell's height (`method="nearest"`, the column model the SDF uses). Border cells repeat."""
        if method == "nearest":
            return self.grid.nearest(self.height, xy)
        return self.grid.bilinear(self.height, xy)

    def surface_distance(self, points, vertical: bool = False) -> np.ndarray:
        """Signed distance (m) of points (n, 3) to the terrain: the true (SDF) distance, or with
        `vertical=True` the height above the containing cell's surface (z - H). Negative inside."""
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        if vertical:
            return points[:, 2] - self.height_at(points[:, :2], method="nearest")
        return self.sdf.values(points)

    def is_foothold(self, xy) -> np.ndarray:
        """Whether the cell containing each point (n, 2) is a foothold (False outside the grid)."""
        iy, ix, inside = self.grid.cell_of(xy)
        return self.foothold[iy, ix] & inside

    def summary(self) -> dict:
        ny, nx = self.grid.shape
        r = self.grid.resolution
        return {"size_x": (nx * r, "m"), "size_y": (ny * r, "m"), "cells_x": nx, "cells_y": ny,
                "resolution": (r, "m"), "height_min": (float(self.height.min()), "m"),
                "height_max": (float(self.height.max()), "m"), "sdf_layers": self.sdf.shape[0],
                "foothold_fraction": float(self.foothold.mean()),
                "occupied_fraction": float(self.occupancy.mean())}


def estimate_bytes(shape: tuple[int, int], layers: int = 0) -> int:
    """Working memory (bytes) to build a map of `shape` cells with an SDF of `layers` layers."""
    cells = int(shape[0]) * int(shape[1])
    return cells * _BYTES_PER_CELL + cells * int(layers) * _BYTES_PER_VOXEL


def check_memory(shape, layers: int, source: str, field: str) -> None:
    """The one size check of a map, for all three axes, before allocating: refuse (naming `field`)
    a map of `shape` cells and `layers` SDF layers (0: the 2D layers alone) whose estimated memory
    exceeds `MAX_MAP_BYTES` or whose SDF work exceeds `MAX_SDF_WORK`."""
    needed = estimate_bytes(shape, layers)
    size = f"{shape[1]}x{shape[0]} cells x {max(layers, 1)} layers"
    if needed > MAX_MAP_BYTES:
        raise SpecError(f"{source}: field '{field}' gives a map too large for memory: {size} needs ~"
                        f"{needed / 1024 ** 3:.1f} GiB > {MAX_MAP_BYTES / 1024 ** 3:.0f} GiB")
    work = int(shape[0]) * int(shape[1]) * int(layers) ** 2 / 2
    if work > MAX_SDF_WORK:
        raise SpecError(f"{source}: field '{field}' gives an SDF too large to build: {size} is "
                        f"{work:.2g} voxel-layer steps > {MAX_SDF_WORK:.0e}")


def terrain_from_heightmap(height, grid: Grid2D, *, name: str = "", ground: float = 0.0,
                           holes=None, obstacles=None, foothold: FootholdParams = FootholdParams(),
                           nav: CostmapParams = CostmapParams(), sdf: SdfParams = SdfParams(),
                           source: str = "<heightmap>", progress: Progress | None = None) -> TerrainMap:
    """Build every layer from a heightmap (ny, nx) on `grid`.

    `holes` (bool) cells are never footholds; `obstacles` (bool) are always occupied in 2D.
    """
    height = np.asarray(height, dtype=float)
    if height.shape != tuple(grid.shape) or min(height.shape) < 2:
        raise SpecError(f"{source}: heightmap must have at least 2x2 cells matching the grid, "
                        f"got {height.shape}")
    if not np.all(np.isfinite(height)):
        raise SpecError(f"{source}: field 'height' contains NaN or infinite values")
    r = grid.resolution
    z_min, z_max = sdf.bounds(height, r)
    if not z_max > z_min:
        raise SpecError(f"{source}: field 'sdf.z_max' must be above 'sdf.z_min' ({z_max} <= {z_min})")
    explicit = sdf.z_min is not None or sdf.z_max is not None
    layers = sdf_layers(z_min, z_max, r).size
    # the grid alone was checked before: what is refused here comes from the z range
    check_memory(grid.shape, layers, source, "sdf.z_min/z_max" if explicit else "height")
    log.info("%s: building %dx%d cells, SDF of %d layers", source, grid.shape[1], grid.shape[0], layers)
    field = heightmap_sdf(height, grid.origin, r, z_min, z_max, progress=progress)
    occupancy = occupancy_grid(height, ground, nav.obstacle_height, obstacles)
    distance = obstacle_distance(occupancy, r)
    costmap = costmap_from_distance(distance, nav.l1, nav.l2, nav.c_max, nav.lambda_c)
    return TerrainMap(name=name, grid=grid, ground=float(ground), height=height, sdf=field,
                      foothold=foothold_mask(height, r, foothold, holes), occupancy=occupancy,
                      distance=distance, costmap=costmap, foothold_params=foothold, nav_params=nav)


def save_map(terrain: TerrainMap, path: str | os.PathLike, *, params: dict | None = None,
             inputs=(), overwrite: bool = False) -> None:
    """Write `terrain` as a "map" artefact (layout in the module docstring), atomically."""
    grid = terrain.grid
    origin2 = np.asarray(grid.origin, dtype=float)
    r = grid.resolution
    with write_artefact(path, "map", params=params or {}, inputs=inputs, overwrite=overwrite) as f:
        group = f.create_group("terrain")
        group.attrs["name"] = terrain.name
        group.attrs["ground"] = terrain.ground
        write_dataset(f, "terrain/height", terrain.height, units="m", origin=origin2, resolution=r)
        write_dataset(f, "terrain/sdf", terrain.sdf.data, units="m", origin=terrain.sdf.origin,
                      resolution=terrain.sdf.resolution)
        write_dataset(f, "terrain/foothold", terrain.foothold.astype(np.uint8), units="",
                      origin=origin2, resolution=r, **asdict(terrain.foothold_params))
        nav = terrain.nav_params
        write_dataset(f, "nav/occupancy", terrain.occupancy.astype(np.uint8), units="",
                      origin=origin2, resolution=r, obstacle_height=nav.obstacle_height)
        write_dataset(f, "nav/distance", terrain.distance, units="m", origin=origin2, resolution=r)
        write_dataset(f, "nav/costmap", terrain.costmap, units="", origin=origin2, resolution=r,
                      l1=nav.l1, l2=nav.l2, c_max=nav.c_max, lambda_c=nav.lambda_c)
        write_summary(f, terrain.summary())


def load_map(path: str | os.PathLike) -> TerrainMap:
    """Read a "map" artefact back into a `TerrainMap` (the stored SDF is used, not rebuilt).

    Every layer is checked at the boundary (`read_array`: finite, 2-D or 3-D, the 2-D layers of the
    heightmap's shape) and the grids' origin and resolution finite: a map with a NaN cell or a bad
    layer is an `ArtefactError` naming the file and the dataset before any planner sees it."""
    with open_artefact(path, kind="map", values=False) as f:  # every float layer read by `read_array`
        height = read_array(f, "terrain/height", ndim=2)
        origin, resolution = _grid_attrs(require(f, "terrain/height"), 2)
        grid = Grid2D(tuple(float(v) for v in origin), resolution, height.shape)
        sdf_origin, sdf_resolution = _grid_attrs(require(f, "terrain/sdf"), 3)
        field = SignedDistanceField(read_array(f, "terrain/sdf", ndim=3), sdf_origin, sdf_resolution)
        foothold_ds = require(f, "terrain/foothold")
        foothold = FootholdParams(**{key: _number_attr(foothold_ds, key)
                                     for key in ("flat_radius", "flat_tolerance", "edge_margin")})
        occupancy_ds, costmap_ds = require(f, "nav/occupancy"), require(f, "nav/costmap")
        nav = CostmapParams(obstacle_height=_number_attr(occupancy_ds, "obstacle_height"),
                        **{key: _number_attr(costmap_ds, key) for key in ("l1", "l2", "c_max", "lambda_c")})
        layers = {name: read_array(f, name, ndim=2) for name in
                  ("terrain/foothold", "nav/occupancy", "nav/distance", "nav/costmap")}
        for name, layer in layers.items():
            if layer.shape != height.shape:
                raise ArtefactError(f"{path}: dataset '/{name}' has shape {layer.shape}, "
                                    f"'/terrain/height' {height.shape}")
        group = require(f, "terrain")
        return TerrainMap(name=str(group.attrs.get("name", "")),
                          grid=grid, ground=float(group.attrs.get("ground", 0.0)), height=height,
                          sdf=field, foothold=layers["terrain/foothold"].astype(bool),
                          occupancy=layers["nav/occupancy"].astype(bool),
                          distance=layers["nav/distance"], costmap=layers["nav/costmap"],
                          foothold_params=foothold, nav_params=nav)


def _number_attr(dataset, key: str) -> float:
    """A finite number attribute of a map dataset, or an `ArtefactError` naming file and attribute."""
    where = f"{dataset.file.filename}: attribute '{dataset.name}.{key}'"
    try:
        value = float(dataset.attrs[key])
    except KeyError:
        raise ArtefactError(f"{where} is missing") from None
    except (TypeError, ValueError):
        raise ArtefactError(f"{where} must be a number") from None
    if not np.isfinite(value):
        raise ArtefactError(f"{where} must be finite, got {value}")
    return value


def _grid_attrs(dataset, dims: int) -> tuple[np.ndarray, float]:
    """The `origin` (`dims` finite numbers) and `resolution` (> 0) attributes of a gridded layer."""
    where = f"{dataset.file.filename}: attribute '{dataset.name}.origin'"
    try:
        origin = np.asarray(dataset.attrs["origin"], dtype=float).reshape(-1)
    except KeyError:
        raise ArtefactError(f"{where} is missing") from None
    except (TypeError, ValueError):
        raise ArtefactError(f"{where} must be {dims} numbers") from None
    if origin.shape != (dims,):
        raise ArtefactError(f"{where} must be {dims} numbers, got {origin.size}")
    check_finite(where, origin)
    resolution = _number_attr(dataset, "resolution")
    if resolution <= 0:
        raise ArtefactError(f"{dataset.file.filename}: attribute '{dataset.name}.resolution' must be > 0")
    return origin, resolution
