"""`nav search` over a queries file as batch items (`legplan.batch`): item = (index, query row
(start px py vx vy, goal px py vx vy)), record = `legplan.nav.artefact.query_record`."""

from __future__ import annotations

import numpy as np

from legplan.nav.artefact import query_record
from legplan.nav.collision import NavGrid
from legplan.nav.params import NavParams
from legplan.nav.result import SearchResult


def query_items(queries: np.ndarray) -> list[tuple[int, np.ndarray]]:
    """(index, query row) of every row of an (n, 8) query array."""
    return list(enumerate(np.asarray(queries, float).reshape(-1, 8)))


class SearchWorker:
    """A worker's context: the map's `NavGrid` (loaded once), the planner and its parameters."""

    def __init__(self, map_path: str, lethal_radius: float, planner: str, params: NavParams):
        from legplan.nav import PLANNERS

        self.grid = NavGrid.from_map(map_path, lethal_radius=lethal_radius)
        self.plan = PLANNERS[planner]
        self.params = params


def search_item(worker: SearchWorker, item) -> dict:
    """Plan one query item; the record of its result."""
    _, query = item
    return query_record(worker.plan(worker.grid, query[:4], query[4:], worker.params), worker.grid)


def failed_query(planner: str, item, reason: str) -> dict:
    """The record of a query whose planning raised or whose worker died (use with
    `functools.partial(failed_query, planner)`)."""
    _, query = item
    result = SearchResult(False, reason, planner, query[:4], query[4:], 0, float("nan"))
    return query_record(result, grid=None)
