"""Navigation queries: start and goal states read from a CSV or MovingAI `.scen` file.

CSV header (all columns required, one query per row, SI units):
    start_x,start_y,start_vx,start_vy,goal_x,goal_y,goal_vx,goal_vy

MovingAI scenario files (`*.scen`, "version 1" then one tab-separated row per query: bucket, map,
map width, map height, start x, start y, goal x, goal y, optimal length) give cells of the `.map`
they name: x counts columns from the left, y counts rows from the *top* (the first row of the
`.map`). `legplan map import movingai` puts the first map row at the largest y, so row y of the
scenario is grid row `height - 1 - y`; the query is the centre of that cell, at rest (velocities 0).
The map's width and height in each row must equal the grid's.
"""

from __future__ import annotations

import os

import numpy as np

from legplan.errors import SpecError
from legplan.parameters import COORDINATE, VELOCITY
from legplan.specio import FieldReader, read_csv_table

QUERY_COLUMNS = ("start_x", "start_y", "start_vx", "start_vy", "goal_x", "goal_y", "goal_vx",
                 "goal_vy")


def read_queries(path: str | os.PathLike, grid=None) -> np.ndarray:
    """Queries (n, 8) of a CSV file, or of a `.scen` file on `grid` (its `origin`, `resolution`,
    `shape`: a `NavGrid` or `Grid2D`) — by suffix."""
    if str(path).endswith(".scen"):
        if grid is None:
            raise SpecError(f"{path}: a .scen file needs the map it refers to")
        return read_scen(path, grid)
    return read_queries_csv(path)


def read_scen(path: str | os.PathLike, grid) -> np.ndarray:
    """Queries (n, 8) at rest at the cell centres of a MovingAI `.scen` file (module docstring);
    `SpecError` naming the file, line and field."""
    ny, nx = grid.shape
    fields = ("bucket", "map", "width", "height", "start_x", "start_y", "goal_x", "goal_y")
    try:
        lines = open(path).read().splitlines()
    except UnicodeDecodeError as exc:
        raise SpecError(f"{path}: not a text .scen file ({exc})") from None
    if not lines or not lines[0].startswith("version"):
        raise SpecError(f"{path}: field 'version' missing (first line of a MovingAI .scen file)")
    rows = []
    for text in lines[1:]:
        if not text.strip():
            continue
        line = len(rows)
        columns = text.split("\t")
        if len(columns) < len(fields):
            raise SpecError(f"{path}: row {line}, field '{fields[len(columns)]}' missing")
        values = {}
        for name, value in zip(fields, columns):
            if name == "map":
                continue
            try:
                values[name] = int(value)
            except ValueError:
                raise SpecError(f"{path}: row {line}, field '{name}' must be an integer, "
                                f"got {value!r}") from None
        if (values["width"], values["height"]) != (nx, ny):
            raise SpecError(f"{path}: row {line}, field 'width'/'height' {values['width']}x"
                            f"{values['height']} differs from the map's {nx}x{ny} cells")
        for name, size in (("start_x", nx), ("start_y", ny), ("goal_x", nx), ("goal_y", ny)):
            if not 0 <= values[name] < size:
                raise SpecError(f"{path}: row {line}, field '{name}' = {values[name]} is outside "
                                f"the map (0..{size - 1})")
        cells = np.array([[values["start_x"], ny - 1 - values["start_y"]],
                          [values["goal_x"], ny - 1 - values["goal_y"]]], float)
        start, goal = np.asarray(grid.origin, float) + grid.resolution * cells
        rows.append([*start, 0.0, 0.0, *goal, 0.0, 0.0])
    if not rows:
        raise SpecError(f"{path}: no queries (the file has a version line but no rows)")
    return np.array(rows)


def read_queries_csv(path: str | os.PathLike) -> np.ndarray:
    """Queries (n, 8) in `QUERY_COLUMNS` order; `SpecError` naming the file, row and column."""
    header, table = read_csv_table(path, "queries CSV file")
    missing = [name for name in QUERY_COLUMNS if name not in header]
    if missing:
        raise SpecError(f"{path}: missing column '{missing[0]}' (expected {','.join(QUERY_COLUMNS)})")
    columns = [header.index(name) for name in QUERY_COLUMNS]
    rows = []
    for i, cells in enumerate(table):
        values = []
        for name, column in zip(QUERY_COLUMNS, columns, strict=True):
            try:
                value = float(cells[column])
            except ValueError:
                raise SpecError(f"{path}: row {i}: field '{name}' must be a number, "
                                f"got {cells[column]!r}") from None
            if not np.isfinite(value):
                raise SpecError(f"{path}: row {i}: field '{name}' must be finite, got {cells[column]!r}")
            values.append(FieldReader(path, f"row {i}").number(value, name, VELOCITY if "_v" in name else COORDINATE))
        rows.append(values)
    if not rows:
        raise SpecError(f"{path}: no queries (the file has a header but no rows)")
    return np.array(rows)
