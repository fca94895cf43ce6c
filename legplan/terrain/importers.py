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


GREY_SCALE = {"L": 255.0, "I;16": 65535.0, "I;16B": 65535.0, "I": 65535.0}
"""Full-scale value per Pillow mode of a grey image (Pillow scales PGM maxval to 255 or 65535)."""


def read_grey_image(path: str | os.PathLike) -> np.ndarray:
    """Grey levels in [0, 1] of a PGM (P5/P2, 8 or 16 bit) or PNG image read with Pillow, first
    row at the top (colour channels averaged, alpha ignored). A missing, truncated or non-image
    file is a one-line `SpecError` naming it."""
    from PIL import Image, UnidentifiedImageError

    path = Path(path)
    if not path.is_file():
        raise SpecError(f"{path}: no such image file")
    try:
        with Image.open(path) as image:  # lazy: the header only, so the size is checked first
            check_memory((image.height, image.width), 0, str(path), "resolution")
            image.load()
            if image.mode not in GREY_SCALE:
                image = image.convert("RGB")
            scale = GREY_SCALE.get(image.mode, 255.0)
            pixels = np.asarray(image, dtype=float)
    except (UnidentifiedImageError, Image.DecompressionBombError) as exc:
        raise SpecError(f"{path}: not a readable PGM/PNG image ({exc})") from None
    except (OSError, ValueError, SyntaxError) as exc:  # truncated data, a broken header
        raise SpecError(f"{path}: truncated or corrupt image ({' '.join(str(exc).split())})") from None
    if pixels.ndim == 3:
        pixels = pixels.mean(axis=2)
    return pixels / scale


def npy_shape(path: Path) -> tuple[int, ...]:
    """The array shape in a .npy file's header (the data is not read), or a one-line `SpecError`."""
    readers = {(1, 0): np.lib.format.read_array_header_1_0, (2, 0): np.lib.format.read_array_header_2_0}
    try:
        with open(path, "rb") as handle:
            version = np.lib.format.read_magic(handle)
            if version not in readers:
                raise SpecError(f"{path}: unsupported .npy format version {version[0]}.{version[1]}")
            shape = readers[version](handle)[0]
    except ValueError as exc:
        raise SpecError(f"{path}: not a readable .npy array ({' '.join(str(exc).split())})") from None
    if len(shape) != 2:
        raise SpecError(f"{path}: heightmap must be a 2D numeric array, got shape {shape}")
    return shape


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
        check_memory(npy_shape(path), 0, str(path), "resolution")
        try:
            array = np.load(path, allow_pickle=False)
        except ValueError as exc:
            raise SpecError(f"{path}: cannot read heightmap ({exc})") from exc
        if array.ndim != 2 or not np.issubdtype(array.dtype, np.number):
            raise SpecError(f"{path}: heightmap must be a 2D numeric array, got {array.shape}")
        height = array.astype(float)
    else:
        height = np.flipud(read_grey_image(path))
    grid = Grid2D((float(origin[0]), float(origin[1])), float(resolution), height.shape)
    return terrain_from_heightmap(height * scale, grid, name=path.stem, source=str(path), **options)
