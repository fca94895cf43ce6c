"""Terrain primitives of a map spec, rasterized onto a `Grid2D` heightmap.

Painter's model: primitives are applied in the order listed; each writes its height into the cells
whose centres lie in its footprint, replacing what was there (so a beam listed after a gap spans it).
Heights are absolute (`top`, m) or relative to the ground plane (`height`, m); a gap is a hole
`depth` metres below the ground. Any primitive may carry `obstacle: true` to force its cells into the
2D occupancy grid regardless of height.

| type            | fields                                                                     |
|-----------------|----------------------------------------------------------------------------|
| box / block     | center [x, y], size [sx, sy], yaw (rad, 0), top or height                  |
| gap             | center, size, yaw, depth (> 0): height = ground - depth; never a foothold  |
| beam            | start [x, y], end [x, y], width, top or height                             |
| pillar          | center, shape cylinder (radius) or box (size, yaw), top or height          |
| stairs          | start [x, y] (middle of the first riser), yaw (ascent direction), width,   |
|                 | steps n, rise, run, base (ground), landing (0): step i covers              |
|                 | [i run, (i+1) run) along yaw at base + (i+1) rise, landing at base + n rise |
| slope           | center, size [length along yaw, width], yaw, from, to (heights at the low  |
|                 | and high-x ends along yaw, absolute)                                       |
| polygon         | vertices [[x, y], ...] (>= 3, any simple polygon), top or height           |
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from legplan.errors import SpecError
from legplan.parameters import RangeError, check_value

_EPS = 1e-9


@dataclass
class Raster:
    """One rasterized primitive: cells it covers, their heights, and its flags."""

    mask: np.ndarray
    heights: np.ndarray | float
    hole: bool = False
    obstacle: bool = False


class Fields:
    """Typed access to one primitive's mapping; errors name the file and the field path."""

    def __init__(self, entry: dict, where: str, source: str):
        if not isinstance(entry, dict):
            raise SpecError(f"{source}: field '{where}' must be a mapping, got {entry!r}")
        self.entry, self.where, self.source = entry, where, source

    def fail(self, key: str, message: str):
        raise SpecError(f"{self.source}: field '{f'{self.where}.{key}' if self.where else key}' {message}")

    def number(self, key: str, default=None, *, positive=False, nonnegative=False,
               allowed: str | None = None) -> float:
        """A finite number within `legplan.parameters.MAGNITUDE` and the range `allowed` if given."""
        if key not in self.entry:
            if default is None:
                self.fail(key, "is required")
            return float(default)
        value = self.entry[key]
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(key, f"must be a number, got {value!r}")
        try:
            value = float(value)
        except OverflowError:  # an int beyond any float
            value = math.inf
        if not math.isfinite(value):
            self.fail(key, f"must be finite, got {value}")
        try:
            check_value(value, allowed or "(-inf, inf)", "")
        except RangeError as exc:
            self.fail(key, str(exc).strip())
        if positive and value <= 0:
            self.fail(key, f"must be > 0, got {value:g}")
        if nonnegative and value < 0:
            self.fail(key, f"must be >= 0, got {value:g}")
        return value

    def integer(self, key: str, *, minimum: int = 1) -> int:
        value = self.entry.get(key)
        if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
            self.fail(key, f"must be an integer >= {minimum}, got {value!r}")
        return value

    def vector(self, key: str, length: int, *, positive=False, allowed: str | None = None) -> np.ndarray:
        value = self.entry.get(key)
        if value is None:
            self.fail(key, "is required")
        try:
            array = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            self.fail(key, f"must be a list of {length} numbers, got {value!r}")
        if array.shape != (length,):
            self.fail(key, f"must be a list of {length} numbers, got {value!r}")
        if not np.all(np.isfinite(array)):
            self.fail(key, f"must be finite, got {value!r}")
        for v in array:
            try:
                check_value(float(v), allowed or "(-inf, inf)", "")
            except RangeError as exc:
                self.fail(key, str(exc).strip())
        if positive and np.any(array <= 0):
            self.fail(key, f"must be > 0, got {value!r}")
        return array

    def flag(self, key: str) -> bool:
        value = self.entry.get(key, False)
        if not isinstance(value, bool):
            self.fail(key, f"must be true or false, got {value!r}")
        return value

    def top(self, ground: float) -> float:
        """Absolute height from `top`, or `height` above the ground plane (exactly one)."""
        if ("top" in self.entry) == ("height" in self.entry):
            self.fail("top", "or 'height' must be given (exactly one)")
        if "top" in self.entry:
            return self.number("top")
        return ground + self.number("height")


def _local(X, Y, centre, yaw):
    """Coordinates of cell centres in a frame at `centre` rotated by `yaw`."""
    dx, dy = X - centre[0], Y - centre[1]
    c, s = math.cos(yaw), math.sin(yaw)
    return c * dx + s * dy, -s * dx + c * dy


def _rectangle(X, Y, centre, size, yaw):
    u, v = _local(X, Y, centre, yaw)
    return (np.abs(u) <= 0.5 * size[0] + _EPS) & (np.abs(v) <= 0.5 * size[1] + _EPS)


def _box(f: Fields, X, Y, ground):
    mask = _rectangle(X, Y, f.vector("center", 2), f.vector("size", 2, positive=True),
                      f.number("yaw", 0.0))
    return Raster(mask, f.top(ground))


def _gap(f: Fields, X, Y, ground):
    mask = _rectangle(X, Y, f.vector("center", 2), f.vector("size", 2, positive=True),
                      f.number("yaw", 0.0))
    return Raster(mask, ground - f.number("depth", positive=True), hole=True)


def _beam(f: Fields, X, Y, ground):
    start, end = f.vector("start", 2), f.vector("end", 2)
    length = float(np.linalg.norm(end - start))
    if length <= 0:
        f.fail("end", "must differ from 'start'")
    yaw = math.atan2(end[1] - start[1], end[0] - start[0])
    size = (length, f.number("width", positive=True))
    return Raster(_rectangle(X, Y, 0.5 * (start + end), size, yaw), f.top(ground))


def _pillar(f: Fields, X, Y, ground):
    centre = f.vector("center", 2)
    shape = f.entry.get("shape", "cylinder")
    if shape == "cylinder":
        radius = f.number("radius", positive=True)
        mask = (X - centre[0]) ** 2 + (Y - centre[1]) ** 2 <= radius ** 2 + _EPS
    elif shape == "box":
        mask = _rectangle(X, Y, centre, f.vector("size", 2, positive=True), f.number("yaw", 0.0))
    else:
        f.fail("shape", f"must be 'cylinder' or 'box', got {shape!r}")
    return Raster(mask, f.top(ground))


def _stairs(f: Fields, X, Y, ground):
    start, yaw = f.vector("start", 2), f.number("yaw", 0.0)
    steps, rise = f.integer("steps"), f.number("rise")
    run, width = f.number("run", positive=True), f.number("width", positive=True)
    base, landing = f.number("base", ground), f.number("landing", 0.0, nonnegative=True)
    u, v = _local(X, Y, start, yaw)
    length = steps * run + landing
    mask = (u >= -_EPS) & (u < length - _EPS) & (np.abs(v) <= 0.5 * width + _EPS)
    index = np.minimum(np.floor((u + _EPS) / run), steps - 1)
    return Raster(mask, base + (index + 1) * rise)


def _slope(f: Fields, X, Y, ground):
    centre, size, yaw = f.vector("center", 2), f.vector("size", 2, positive=True), f.number("yaw", 0.0)
    low, high = f.number("from"), f.number("to")
    u, _ = _local(X, Y, centre, yaw)
    fraction = np.clip((u + 0.5 * size[0]) / size[0], 0.0, 1.0)
    return Raster(_rectangle(X, Y, centre, size, yaw), low + (high - low) * fraction)


def _polygon(f: Fields, X, Y, ground):
    vertices = f.entry.get("vertices")
    try:
        vertices = np.asarray(vertices, dtype=float)
    except (TypeError, ValueError):
        f.fail("vertices", "must be a list of [x, y] pairs")
    if vertices.ndim != 2 or vertices.shape[1] != 2 or len(vertices) < 3:
        f.fail("vertices", "must be a list of at least 3 [x, y] pairs")
    if not np.all(np.isfinite(vertices)):
        f.fail("vertices", "must be finite")
    from matplotlib.path import Path  # map building only (keeps matplotlib out of start-up)

    inside = Path(vertices).contains_points(np.column_stack([X.ravel(), Y.ravel()]))
    return Raster(inside.reshape(X.shape), f.top(ground))


PRIMITIVES = {"box": _box, "block": _box, "gap": _gap, "beam": _beam, "pillar": _pillar,
              "stairs": _stairs, "slope": _slope, "polygon": _polygon}


def rasterize(entry: dict, where: str, source: str, X, Y, ground: float) -> Raster:
    """Rasterize one spec primitive (`where` like 'primitives[2]', `source` the spec file)."""
    fields = Fields(entry, where, source)
    kind = entry.get("type")
    if kind not in PRIMITIVES:
        fields.fail("type", f"unknown primitive {kind!r} (known: {', '.join(sorted(PRIMITIVES))})")
    raster = PRIMITIVES[kind](fields, X, Y, ground)
    raster.obstacle = fields.flag("obstacle")
    return raster
