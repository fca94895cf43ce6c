"""Closed loop in the simulator: replan the rest of the motion from the measured state every period
and whenever the state leaves a tube around the tracked plan (issue 39 item 3), and hand the
controller the new plan as its reference.

    replanner = Replanner(Previous.from_record(task, model.com_offset), model, terrain, dyn_params, period=0.3)
    simulate(samples, robot, terrain_map, params, goal, replanner=replanner)
    replanner.columns()        # one row per replan: time, trigger, measured state, iterations, CPU s, status

`legplan.sim.run.simulate` asks `due(t, position_error, velocity_error)` every control tick (the
base's distance and velocity error against the tracked reference) and, when due, calls the
replanner with the simulated state, the feet it has in contact among it (a robot's contact sensing:
a foot planned down that has not landed is replanned as in the air, `legplan.dyn.replan.lifted_feet`).
A replan is due every `period` s ("period") and, event-triggered model predictive control, as soon
as the base leaves the tube `ReplanParams.tube_position` / `tube_velocity` around the tracked plan
("tube"; at most every `trigger_gap` s): a push is answered
when it happens, not up to a period later, while the period still bounds how long a slow drift
goes unanswered. The periods restart at a triggered replan.

The simulation waits for the replan (no latency: the new plan holds from the
tick it was measured at); each replan's CPU seconds are recorded so that its latency shows. A
converged replan (`legplan.dyn.replan.replan`) becomes the reference (its samples on the plan's
clock) and the plan later replans start from; so does one that ran out of iterations or stalled
near feasible (`ReplanParams.track_violation`, in the solver's row scale): it starts from the
measured state, where the last reference starts from a state the robot has left (a push); so does
one stopped by its CPU time (`ReplanParams.cpu_budget`), at the point its solve reached. A replan
further off, one whose plan is not finite, or a numerical failure keeps the last reference. Every
replan is recorded: `trigger` what started it, `success` convergence, `status` why its solve
stopped (converged; max_iterations, the `ReplanParams.max_iterations` budget; time_limit, the
`cpu_budget`; stalled, the solver's stall test; numerical_failure),
`tracked` whether the controller took it, `recovery` whether it landed the feet in the air early
(`ReplanParams.recovery_velocity`, `legplan.dyn.rest_gait.early_touchdown`), as the first replan
after a push does, `extension` the seconds of strides a tracked replan inserted
(`ReplanParams.extension`; the simulation then runs to the longer plan's end).

Bounded: a replan spends at most `ReplanParams.max_iterations` LM iterations and `cpu_budget` CPU
seconds, and each control tick's QP at most `legplan.sim.controller.QP_MAX_OUTER` ×
`QP_MAX_INNER` ProxQP iterations; a run lasts its plan, the inserted strides (at most
`ReplanParams.extension`) and its settle.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from legplan.dyn.replan import MeasuredState, Previous, ReplanParams, replan
from legplan.dyn.rest_gait import PHASE_END
from legplan.sim.run import REPLAN_UNITS, TEXT_COLUMNS
from legplan.solve.lm import Status

LAST_REPLAN = 0.3  # s: no replan starts closer than this to the plan's end (the closing Stand)


def trackable(out, track_violation: float) -> bool:
    """Whether the controller takes the replan `out` (module docstring): its plan finite, and
    converged, or stopped by a budget (iterations, CPU time) or stalled within `track_violation`."""
    samples = out.plan.samples
    if not all(np.isfinite(np.asarray(samples[name], float)).all() for name in samples if name != "contact"):
        return False
    return out.success or (out.status in (Status.MAX_ITERATIONS, Status.TIME_LIMIT, Status.STALLED)
                           and out.scaled_violation <= track_violation)


class Replanner:
    """Replans every `period` s of the plan's clock (the first one `period` after the start)."""

    def __init__(self, previous: Previous, model, terrain, params, period: float,
                 settings: ReplanParams = ReplanParams()):
        self.previous, self.model, self.terrain, self.params = previous, model, terrain, params
        self.settings = settings
        self.period = float(period)
        self.next = self.period
        self.rows: list[dict] = []

    def due(self, t: float, position_error: float = 0.0, velocity_error: float = 0.0) -> str | None:
        """Why a replan is due at t — "period", "tube" (the base `position_error` m or
        `velocity_error` m/s from the tracked plan beyond the tube) — or None."""
        if t - self._origin >= self.previous.form.duration - LAST_REPLAN - PHASE_END:
            return None
        if t >= self.next - 1e-9:
            return "period"
        s = self.settings
        outside = ((s.tube_position is not None and position_error > s.tube_position)
                   or (s.tube_velocity is not None and velocity_error > s.tube_velocity))
        return "tube" if outside and t - self._last >= s.trigger_gap - 1e-9 else None

    def __call__(self, t: float, base_pos, base_rot, base_vel, base_ang_vel, feet_pos,
                 trigger: str = "period", contact=None) -> dict | None:
        """Replan from the measured state (world frame; `feet_pos` the contact points under the feet,
        `contact` which feet touch the terrain, None: not sensed) for `trigger` (`due`); the new
        plan's samples on the plan's clock, or None when the replan failed or was not tracked (the
        controller keeps its reference)."""
        self.next = self.next + self.period if trigger == "period" else t + self.period
        self._last = t
        state = MeasuredState(t, base_pos, pin.rpy.matrixToRpy(base_rot), base_vel, base_ang_vel, feet_pos, contact)
        offset = t - self._origin
        shifted = MeasuredState(offset, state.base_pos, state.base_euler, state.base_vel, state.base_ang_vel,
                                state.feet_pos, state.contact)
        try:
            out = replan(self.previous, shifted, self.model, self.terrain, self.params, settings=self.settings)
        except ValueError:  # outside the plan
            return None
        tracked = trackable(out, self.settings.track_violation)
        self.rows.append({**state.record(), "trigger": trigger, "iterations": out.iterations,
                          "cpu_seconds": out.cpu_seconds, "violation": out.violation,
                          "scaled_violation": out.scaled_violation, "recovery": out.recovery,
                          "extension": out.extension if tracked else 0.0,
                          "success": out.success,
                          "status": out.status.name.lower(), "tracked": tracked})
        if not tracked:
            return None
        self.previous = Previous.from_plan(out.plan, self.previous.stride, self.previous.extended + out.extension)
        self._origin = t
        samples = dict(out.plan.samples)
        samples["t"] = samples["t"] + t
        return samples

    _origin = 0.0  # the plan's clock at the start of `previous`
    _last = -np.inf  # the plan's clock at the last replan

    def columns(self) -> dict[str, np.ndarray]:
        """One row per replan (`REPLAN_UNITS`; words as bytes, which HDF5 stores); empty when none ran."""
        if not self.rows:
            return {}
        return {name: np.asarray([row[name] for row in self.rows], dtype="S" if name in TEXT_COLUMNS else None)
                for name in REPLAN_UNITS}
