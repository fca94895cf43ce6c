"""Least-squares problems of eq. (24) kept across TEB rounds and control cycles.

The problem's Jacobian pattern depends only on the band's structure — its size, which poses are
fixed, and the terms' patterns (`objective_key`) — and consecutive rounds and receding-horizon
cycles mostly see the same few structures. `ProblemCache` keeps one `Problem` per structure: for a
known structure only the objective's data (`TebObjective.refresh`) and the band values (which
include the fixed start and goal poses) are replaced, so the JᵀJ slot analysis of `TebObjective`
and the solver core's sorted assembly indices are reused instead of rebuilt every round.
"""

from __future__ import annotations

from collections import OrderedDict

import numpy as np

from legplan.nav.teb.band import Band
from legplan.nav.teb.objective import TebObjective, Weighted, objective_key
from legplan.nav.teb.residuals import BAND, band_vector
from legplan.solve import Problem, VariableBlock


def new_problem(band: Band, entries: list[Weighted], dt_min: float) -> Problem:
    """One variable `band` (z of `band_vector`; fixed poses held, ΔT_i ≥ dt_min) and one
    `TebObjective` over it."""
    n = band.n
    fixed = np.concatenate([np.repeat(band.fixed, 3), np.zeros(n - 1, bool)])
    lower = np.concatenate([np.full(3 * n, -np.inf), np.full(n - 1, dt_min)])
    problem = Problem([VariableBlock(BAND, band_vector(band), fixed=fixed, lower=lower)])
    problem.add_residual(TebObjective(n, entries))
    return problem


class ProblemCache:
    """Up to `capacity` problems by band structure, least recently used dropped (not thread-safe)."""

    def __init__(self, capacity: int = 16):
        self.capacity = capacity
        self._problems: OrderedDict[tuple, Problem] = OrderedDict()

    def problem(self, band: Band, entries: list[Weighted], dt_min: float) -> Problem:
        """The problem for `band` with objective `entries`: cached and refreshed, or new."""
        key = (objective_key(band.n, entries), band.fixed.tobytes(), dt_min)
        problem = self._problems.pop(key, None)
        if problem is None:
            problem = new_problem(band, entries, dt_min)
            if len(self._problems) >= self.capacity:
                self._problems.popitem(last=False)
        else:
            problem.blocks[0].refresh(entries)
            problem.layout.blocks[BAND].value = band_vector(band)
        self._problems[key] = problem
        return problem
