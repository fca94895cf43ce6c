"""What a receding-horizon run is asked to do: its goals and its settings."""

from __future__ import annotations

from dataclasses import dataclass

from legplan.parameters import SENSING_RADIUS, TIME_LIMIT, YAW, Parameters, param

YAW_POLICIES = ("velocity", "target", "heading")


@dataclass(frozen=True)
class Goal:
    """Where to go: position, heading (NaN = any), seconds to stay there once reached."""

    xy: tuple[float, float]
    heading: float = float("nan")
    dwell: float = 0.0


@dataclass(frozen=True)
class NavRunParams(Parameters):
    """Settings of a run (`nav simulate --param sim.KEY=VALUE` for the numbers and flags)."""

    what = "simulation"

    rate: float = param(10.0, "(0, inf)", doc="Hz, TEB cycles")
    substeps: int = param(10, "[1, 10000]", doc="robot integration steps per cycle")
    window: float = param(5.0, "(0, inf)", doc="m of global path in the local band")
    sensing_radius: float = param(4.0, SENSING_RADIUS, doc="m")
    goal_tolerance: float = param(0.1, "(0, inf)", doc="m")
    heading_tolerance: float = param(0.1, "(0, inf)", doc="rad")
    stop_speed: float = param(0.05, "(0, inf)", doc="m/s, \"at rest\" for arrival at a via point")
    max_time: float = param(300.0, TIME_LIMIT, doc="s of simulated time before the run fails")
    stall_time: float = param(20.0, "(0, 86400]",
                              doc="s: the run fails when the robot moved less than `stall_distance` in this time")
    stall_distance: float = param(0.3, "[0, inf)", doc="m")
    max_wall_seconds: float = param(float("inf"), "(0, inf]", doc="wall-clock budget of the run")
    warm_start: bool = True  # warm-start the local band from the previous cycle
    yaw: str = param("velocity", YAW_POLICIES,
                     doc="yaw policy on the way: \"velocity\", \"target\" (face `target`) or \"heading\"")
    target: tuple[float, float] | None = None  # world point faced with yaw "target"
    heading: float = param(0.0, YAW, doc="rad, held with yaw \"heading\"")
    clearance_margin: float = param(0.1, "[0, inf)", doc="m the TEB keeps beyond the collision radius "
                                    "(soft obstacle term, tracking lag)")
