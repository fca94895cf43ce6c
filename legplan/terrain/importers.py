"""Importers of standard map formats into a `TerrainMap`.

- ROS map_server: a YAML (`image`, `resolution`, `origin` [x, y, yaw], `occupied_thresh`,
  `free_thresh`, `negate`) next to a PGM (P5/P2) or PNG image. Occupancy probability of a pixel of
  value v (0..255, colour channels averaged) is (255 - v)/255, or v/255 with `negate: 1`; occupied
  if > occupied_thresh, free if < free_thresh, unknown otherwise. Unknown cells are treated as
  obstacles (conservative). The image's top row is the largest y; `origin` is the pose of the
  lower-left pixel's corner, so cell [0, 0]'s centre is origin + resolution/2.
- MovingAI grid maps (`type octile`, `height`, `width`, `map`, then rows): `.` `G` `S` passable,
  `@` `O` `T` `W` obstacles. The first map row is the largest y.
- Heightmaps: `.npy` (2D array indexed [iy, ix], used as-is) or an image (PGM/PNG, grey levels in
  [0, 1], top row = largest y), times `scale` metres.

Obstacle cells become columns `obstacle_height` metres tall on a ground at 0 and are flagged
obstacles in the 2D occupancy grid.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from legplan.errors import SpecError
from legplan.terrain.grid import Grid2D
from legplan.terrain.primitives import Fields
from legplan.specio import read_text, read_yaml_mapping
from legplan.terrain.terrain_map import TerrainMap, check_memory, terrain_from_heightmap

PASSABLE = frozenset(".GS")
BLOCKED = frozenset("@OTW")


def read_pgm(path: str | os.PathLike) -> np.ndarray:
    """Grey levels in [0, 1] of a binary (P5) or ASCII (P2) PGM image, first row at the top."""
    data = Path(path).read_bytes()
    tokens, position = [], 0
    while len(tokens) < 4:
        while position < len(data) and data[position:position + 1].isspace():
            position += 1
        if data[position:position + 1] == b"#":
            position = data.index(b"\n", position) + 1
            continue
        end = position
        while end < len(data) and not data[end:end + 1].isspace():
            end += 1
        if end == position:
            raise SpecError(f"{path}: truncated PGM header")
        tokens.append(data[position:end])
        position = end
    magic, width, height, maxval = tokens[0], *(int(t) for t in tokens[1:])
    if magic == b"P5":
        dtype = np.dtype(">u2") if maxval > 255 else np.dtype("u1")
        count = width * height
        pixels = np.frombuffer(data, dtype=dtype, count=count, offset=position + 1)
    elif magic == b"P2":
        pixels = np.array(data[position:].split(), dtype=float)[:width * height]
    else:
        raise SpecError(f"{path}: not a PGM image (magic {magic!r}, expected P5 or P2)")
    if pixels.size != width * height:
        raise SpecError(f"{path}: truncated PGM data ({pixels.size} of {width * height} pixels)")
    return pixels.reshape(height, width).astype(float) / maxval


def read_grey_image(path: str | os.PathLike) -> np.ndarray:
    """Grey levels in [0, 1] of a PGM or PNG image (colour channels averaged, alpha ignored)."""
    path = Path(path)
    if not path.is_file():
        raise SpecError(f"{path}: no such image file")
    if path.suffix.lower() == ".pgm":
        return read_pgm(path)
    import matplotlib.image

    try:
        image = np.asarray(matplotlib.image.imread(path), dtype=float)
    except (OSError, ValueError, SyntaxError) as exc:
        raise SpecError(f"{path}: cannot read image ({exc})") from exc
    if image.ndim == 3:
        image = image[..., :3].mean(axis=2)
    if image.max() > 1.0:
        image = image / 255.0
    return image


def _obstacle_terrain(blocked: np.ndarray, grid: Grid2D, name: str, obstacle_height: float,
                      source: str, **options) -> TerrainMap:
    height = np.where(blocked, obstacle_height, 0.0)
    return terrain_from_heightmap(height, grid, name=name, ground=0.0, obstacles=blocked,
                                  source=source, **options)


def import_ros(yaml_path: str | os.PathLike, *, obstacle_height: float = 1.0, **options) -> TerrainMap:
    """A ROS map_server map (YAML + PGM/PNG) as a terrain of obstacle columns (module docstring)."""
    source = str(yaml_path)
    data = read_yaml_mapping(yaml_path, "ROS map file")
    fields = Fields(data, "map", source)
    if not isinstance(data.get("image"), str):
        raise SpecError(f"{source}: field 'image' must name the map image file")
    resolution = fields.number("resolution", positive=True)
    origin = fields.vector("origin", 3)
    if abs(origin[2]) > 1e-12:
        raise SpecError(f"{source}: field 'origin' yaw must be 0 (rotated maps are not supported)")
    occupied_thresh = fields.number("occupied_thresh", 0.65)
    free_thresh = fields.number("free_thresh", 0.196)
    if not 0 <= free_thresh <= occupied_thresh <= 1:
        raise SpecError(f"{source}: field 'free_thresh' must satisfy 0 <= free_thresh <= "
                        f"occupied_thresh <= 1")
    negate = data.get("negate", 0)
    if negate not in (0, 1, True, False):
        raise SpecError(f"{source}: field 'negate' must be 0 or 1, got {negate!r}")
    grey = read_grey_image(Path(yaml_path).parent / data["image"])
    check_memory(grey.shape, 0, source, "resolution")
    probability = grey if negate else 1.0 - grey
    blocked = np.flipud(~(probability < free_thresh))
    grid = Grid2D((origin[0] + 0.5 * resolution, origin[1] + 0.5 * resolution), resolution,
                  blocked.shape)
    return _obstacle_terrain(blocked, grid, Path(yaml_path).stem, obstacle_height, source, **options)


def import_movingai(map_path: str | os.PathLike, resolution: float, origin=(0.0, 0.0), *,
                    obstacle_height: float = 1.0, **options) -> TerrainMap:
    """A MovingAI `.map` grid; cell [0, 0]'s lower-left corner at `origin` (module docstring)."""
    path = Path(map_path)
    if not path.is_file():
        raise SpecError(f"{path}: no such map file")
    lines = read_text(path, "MovingAI map").splitlines()
    header = {}
    index = 0
    while index < len(lines) and lines[index].strip() != "map":
        parts = lines[index].split()
        if len(parts) == 2:
            header[parts[0]] = parts[1]
        index += 1
    for key in ("type", "height", "width"):
        if key not in header:
            raise SpecError(f"{path}: field '{key}' missing from the MovingAI header")
    try:
        rows, cols = int(header["height"]), int(header["width"])
    except ValueError:
        raise SpecError(f"{path}: field 'height'/'width' must be integers") from None
    body = [line.rstrip("\r") for line in lines[index + 1:index + 1 + rows]]
    if len(body) != rows or any(len(line) < cols for line in body):
        raise SpecError(f"{path}: field 'map' must have {rows} rows of {cols} cells")
    chars = np.array([list(line[:cols]) for line in body])
    unknown = set(np.unique(chars)) - PASSABLE - BLOCKED
    if unknown:
        raise SpecError(f"{path}: field 'map' has unknown cell characters {sorted(unknown)}")
    check_memory(chars.shape, 0, str(path), "resolution")
    blocked = np.flipud(np.isin(chars, list(BLOCKED)))
    grid = Grid2D((origin[0] + 0.5 * resolution, origin[1] + 0.5 * resolution), float(resolution),
                  blocked.shape)
    return _obstacle_terrain(blocked, grid, path.stem, obstacle_height, str(path), **options)


def import_heightmap(path: str | os.PathLike, resolution: float, origin=(0.0, 0.0),
                     scale: float = 1.0, **options) -> TerrainMap:
    """A heightmap from `.npy` ([iy, ix] as-is) or PGM/PNG (top row = largest y), times `scale` m.

    `origin` is the world (x, y) of cell [0, 0]'s centre.
    """
    path = Path(path)
    if path.suffix.lower() == ".npy":
        if not path.is_file():
            raise SpecError(f"{path}: no such heightmap file")
        try:
            array = np.load(path, allow_pickle=False)
        except ValueError as exc:
            raise SpecError(f"{path}: cannot read heightmap ({exc})") from exc
        if array.ndim != 2 or not np.issubdtype(array.dtype, np.number):
            raise SpecError(f"{path}: heightmap must be a 2D numeric array, got {array.shape}")
        height = array.astype(float)
    else:
        height = np.flipud(read_grey_image(path))
    check_memory(height.shape, 0, str(path), "resolution")
    grid = Grid2D((float(origin[0]), float(origin[1])), float(resolution), height.shape)
    return terrain_from_heightmap(height * scale, grid, name=path.stem, source=str(path), **options)
