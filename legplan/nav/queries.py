"""Navigation queries: start and goal states read from a CSV file or built from CLI values.

CSV header (all columns required, one query per row, SI units):
    start_x,start_y,start_vx,start_vy,goal_x,goal_y,goal_vx,goal_vy
"""

from __future__ import annotations

import csv
import os

import numpy as np

from legplan.errors import SpecError

QUERY_COLUMNS = ("start_x", "start_y", "start_vx", "start_vy", "goal_x", "goal_y", "goal_vx",
                 "goal_vy")


def read_queries_csv(path: str | os.PathLike) -> np.ndarray:
    """Queries (n, 8) in `QUERY_COLUMNS` order; `SpecError` naming the file, row and column."""
    try:
        with open(path, newline="") as handle:
            reader = csv.DictReader(handle)
            header = [name.strip() for name in (reader.fieldnames or [])]
            missing = [name for name in QUERY_COLUMNS if name not in header]
            if missing:
                raise SpecError(f"{path}: missing column '{missing[0]}' "
                                f"(expected {','.join(QUERY_COLUMNS)})")
            rows = []
            for line, row in enumerate(reader, start=2):
                row = {key.strip(): value for key, value in row.items() if key is not None}
                values = []
                for name in QUERY_COLUMNS:
                    try:
                        value = float(row[name])
                    except (TypeError, ValueError):
                        raise SpecError(f"{path}: line {line}, field '{name}' must be a number, "
                                        f"got {row[name]!r}") from None
                    if not np.isfinite(value):
                        raise SpecError(f"{path}: line {line}, field '{name}' must be finite")
                    values.append(value)
                rows.append(values)
    except UnicodeDecodeError as exc:
        raise SpecError(f"{path}: not a text CSV file ({exc})") from None
    if not rows:
        raise SpecError(f"{path}: no queries (the file has a header but no rows)")
    return np.array(rows)
