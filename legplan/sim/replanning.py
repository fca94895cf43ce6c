"""Closed loop in the simulator: replan the rest of the motion from the measured state every period
(issue 39 item 3) and hand the controller the new plan as its reference.

    replanner = Replanner(Previous.from_record(task, model.com_offset), model, terrain, dyn_params, period=0.3)
    simulate(samples, robot, terrain_map, params, goal, replanner=replanner)
    replanner.columns()        # one row per replan: time, measured state, iterations, CPU s, violation, success

`legplan.sim.run.simulate` asks `due(t)` every control tick and, when due, calls the replanner with
the simulated state. The simulation waits for the replan (no latency: the new plan holds from the
tick it was measured at); each replan's CPU seconds are recorded so that its latency shows. A
converged replan (`legplan.dyn.replan.replan`) becomes the reference (its samples on the plan's
clock) and the plan later replans start from; so does one that ran out of iterations or stalled
near feasible (`ReplanParams.track_violation`, in the solver's row scale): it starts from the
measured state, where the last reference starts from a state the robot has left (a push). A replan
further off, or a numerical failure, keeps the last reference. Every replan's status is recorded
(`success` is convergence, `tracked` whether the controller took it).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from legplan.dyn.replan import PHASE_END, MeasuredState, Previous, ReplanParams, replan
from legplan.sim.run import REPLAN_UNITS
from legplan.solve.lm import Status

LAST_REPLAN = 0.3  # s: no replan starts closer than this to the plan's end (the closing Stand)


class Replanner:
    """Replans every `period` s of the plan's clock (the first one `period` after the start)."""

    def __init__(self, previous: Previous, model, terrain, params, period: float,
                 settings: ReplanParams = ReplanParams()):
        self.previous, self.model, self.terrain, self.params = previous, model, terrain, params
        self.settings = settings
        self.period = float(period)
        self.next = self.period
        self.rows: list[dict] = []

    def due(self, t: float) -> bool:
        return t >= self.next - 1e-9 and t - self._origin < self.previous.form.duration - LAST_REPLAN - PHASE_END

    def __call__(self, t: float, base_pos, base_rot, base_vel, base_ang_vel, feet_pos) -> dict | None:
        """Replan from the measured state (world frame; `feet_pos` the contact points under the feet);
        the new plan's samples on the plan's clock, or None when the replan failed."""
        self.next += self.period
        state = MeasuredState(t, base_pos, pin.rpy.matrixToRpy(base_rot), base_vel, base_ang_vel, feet_pos)
        offset = t - self._origin
        shifted = MeasuredState(offset, state.base_pos, state.base_euler, state.base_vel, state.base_ang_vel,
                                state.feet_pos)
        try:
            out = replan(self.previous, shifted, self.model, self.terrain, self.params, settings=self.settings)
        except ValueError:  # outside the plan
            return None
        tracked = out.success or (out.status in (Status.MAX_ITERATIONS, Status.STALLED)
                                  and out.scaled_violation <= self.settings.track_violation)
        self.rows.append({**state.record(), "iterations": out.iterations, "cpu_seconds": out.cpu_seconds,
                          "violation": out.violation, "scaled_violation": out.scaled_violation,
                          "success": out.success, "tracked": tracked})
        if not tracked:
            return None
        self.previous = Previous.from_plan(out.plan)
        self._origin = t
        samples = dict(out.plan.samples)
        samples["t"] = samples["t"] + t
        return samples

    _origin = 0.0  # the plan's clock at the start of `previous`

    def columns(self) -> dict[str, np.ndarray]:
        """One row per replan (`REPLAN_UNITS`); empty when none ran."""
        if not self.rows:
            return {}
        return {name: np.asarray([row[name] for row in self.rows]) for name in REPLAN_UNITS}
