"""Map specs (`maps/*.yaml`): parse, validate and rasterize into a `TerrainMap`.

    name: gap_crossing
    resolution: 0.01                      # m, cell side
    extent: {x: [-1.0, 1.0], y: [-0.5, 0.5]}   # outer cell edges, m
    ground: 0.0                           # ground plane height, m
    primitives: [...]                     # see legplan.terrain.primitives
    foothold: {flat_radius, flat_tolerance, edge_margin}   # optional, m
    nav: {obstacle_height, l1, l2, c_max, lambda_c}        # optional, eqs. (15)-(16)
    sdf: {z_min, z_max, clearance}                          # optional, m

Every error is a one-line `SpecError` naming the file and the field.
"""

from __future__ import annotations

import os
from dataclasses import fields as dataclass_fields
from pathlib import Path

import numpy as np

from legplan.errors import SpecError
from legplan.parameters import COORDINATE, RESOLUTION
from legplan.specio import read_yaml_mapping
from legplan.terrain.grid import Grid2D
from legplan.terrain.layers import CostmapParams, FootholdParams
from legplan.terrain.primitives import Fields, rasterize
from legplan.terrain.sdf import Progress
from legplan.terrain.terrain_map import SdfParams, TerrainMap, check_memory, terrain_from_heightmap

TOP_LEVEL = ("name", "resolution", "extent", "ground", "primitives", "foothold", "nav", "sdf")


def section(data: dict, key: str, cls, source: str, none_ok: tuple[str, ...] = ()):
    """Dataclass `cls` from the optional mapping `data[key]`; unknown or bad fields are SpecErrors."""
    entry = data.get(key) or {}
    fields = Fields(entry, key, source)
    known = {f.name: f.default for f in dataclass_fields(cls)}
    for name in entry:
        if name not in known:
            fields.fail(name, f"is unknown (known: {', '.join(known)})")
    values = {}
    for name, default in known.items():
        if name in none_ok and entry.get(name) is None:
            values[name] = None
        elif name in entry:
            values[name] = fields.number(name, nonnegative=name != "z_min" and name != "z_max")
        else:
            values[name] = default
    return cls(**values)


def parse_grid(data: dict, source: str) -> Grid2D:
    """The grid from `resolution` and `extent` (outer edges); sizes rounded to whole cells."""
    top = Fields(data, "", source)  # top-level fields are named as they are
    resolution = top.number("resolution", allowed=RESOLUTION)
    extent = Fields(data.get("extent"), "extent", source)
    xs, ys = extent.vector("x", 2, allowed=COORDINATE), extent.vector("y", 2, allowed=COORDINATE)
    for name, (low, high) in (("x", xs), ("y", ys)):
        if not high > low:
            extent.fail(name, f"must be [min, max] with max > min, got {[low, high]}")
    nx = max(int(round((xs[1] - xs[0]) / resolution)), 2)
    ny = max(int(round((ys[1] - ys[0]) / resolution)), 2)
    check_memory((ny, nx), 0, source, "resolution")
    origin = (xs[0] + 0.5 * resolution, ys[0] + 0.5 * resolution)
    return Grid2D((float(origin[0]), float(origin[1])), float(resolution), (ny, nx))


def build_map(spec_path: str | os.PathLike, progress: Progress | None = None) -> TerrainMap:
    """Parse, validate and build the map described by the YAML spec at `spec_path`."""
    source = str(spec_path)
    data = read_yaml_mapping(spec_path, "map spec")
    for key in data:
        if key not in TOP_LEVEL:
            raise SpecError(f"{source}: field '{key}' is unknown (known: {', '.join(TOP_LEVEL)})")
    grid = parse_grid(data, source)
    ground = Fields(data, "spec", source).number("ground", 0.0, allowed=COORDINATE)
    foothold = section(data, "foothold", FootholdParams, source)
    nav = section(data, "nav", CostmapParams, source)
    sdf = section(data, "sdf", SdfParams, source, none_ok=("z_min", "z_max"))
    if nav.l2 < nav.l1:
        raise SpecError(f"{source}: field 'nav.l2' must be >= 'nav.l1' ({nav.l2} < {nav.l1})")
    primitives = data.get("primitives") or []
    if not isinstance(primitives, list):
        raise SpecError(f"{source}: field 'primitives' must be a list")
    X, Y = grid.centres()
    height = np.full(grid.shape, ground)
    holes = np.zeros(grid.shape, dtype=bool)
    obstacles = np.zeros(grid.shape, dtype=bool)
    for index, entry in enumerate(primitives):
        where = f"primitives[{index}]"
        raster = rasterize(entry, where, source, X, Y, ground)
        values = np.broadcast_to(raster.heights, grid.shape)[raster.mask]
        if not np.all(np.isfinite(values)):
            raise SpecError(f"{source}: field '{where}' gives NaN or infinite heights")
        height[raster.mask] = values
        holes[raster.mask] = raster.hole
        obstacles[raster.mask] = raster.obstacle
    return terrain_from_heightmap(height, grid, name=str(data.get("name", Path(source).stem)),
                                  ground=ground, holes=holes, obstacles=obstacles,
                                  foothold=foothold, nav=nav, sdf=sdf, source=source,
                                  progress=progress)
