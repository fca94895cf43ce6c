"""What a receding-horizon run is asked to do: its goals and its settings."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from legplan.errors import LegplanError

YAW_POLICIES = ("velocity", "target", "heading")


@dataclass(frozen=True)
class Goal:
    """Where to go: position, heading (NaN = any), seconds to stay there once reached."""

    xy: tuple[float, float]
    heading: float = float("nan")
    dwell: float = 0.0


@dataclass(frozen=True)
class SimParams:
    """Settings of a run (`nav simulate --param sim.KEY=VALUE` for the numbers and flags)."""

    rate: float = 10.0  # Hz, TEB cycles
    substeps: int = 10  # robot integration steps per cycle
    window: float = 5.0  # m of global path in the local band
    sensing_radius: float = 4.0  # m
    goal_tolerance: float = 0.1  # m
    heading_tolerance: float = 0.1  # rad
    stop_speed: float = 0.05  # m/s, "at rest" for arrival at a via point
    max_time: float = 300.0  # s of simulated time before the run fails
    stall_time: float = 20.0  # s: the run fails when the robot moved less than `stall_distance` in this time
    stall_distance: float = 0.3  # m
    max_wall_seconds: float = float("inf")  # wall-clock budget of the run
    warm_start: bool = True  # warm-start the local band from the previous cycle
    yaw: str = "velocity"  # yaw policy on the way: "velocity", "target" (face `target`) or "heading"
    target: tuple[float, float] | None = None  # world point faced with yaw "target"
    heading: float = 0.0  # rad, held with yaw "heading"
    clearance_margin: float = 0.1  # m the TEB keeps beyond the collision radius (soft obstacle term, tracking lag)

    def __post_init__(self):
        checks = [("rate", self.rate > 0), ("substeps", self.substeps >= 1), ("window", self.window > 0),
                  ("sensing_radius", self.sensing_radius >= 0), ("goal_tolerance", self.goal_tolerance > 0),
                  ("heading_tolerance", self.heading_tolerance > 0), ("stop_speed", self.stop_speed > 0),
                  ("max_time", self.max_time > 0), ("stall_time", self.stall_time > 0),
                  ("stall_distance", self.stall_distance >= 0), ("clearance_margin", self.clearance_margin >= 0), ("max_wall_seconds", self.max_wall_seconds > 0),
                  ("yaw", self.yaw in YAW_POLICIES)]
        for name, ok in checks:
            if not ok:
                raise LegplanError(f"simulation parameter '{name}' out of range: {getattr(self, name)!r}")

    def as_dict(self) -> dict:
        return dataclasses.asdict(self)
