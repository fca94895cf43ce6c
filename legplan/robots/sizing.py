"""Lengths that scale with the robot's size: the step generator's defaults and the clearance that
`robot init` / `robot check` keep in the nominal stance.

The values were tuned on SCARAB II, whose mean leg chain length (`RobotModel.leg_length`: coxa 26 +
femur 93 + tibia 122 mm) is `REFERENCE_LEG_LENGTH`; for another robot each is multiplied by its
mean leg length / 0.241 m and rounded to 0.1 mm (so SCARAB II keeps exactly the tuned values).
"""

from __future__ import annotations

REFERENCE_LEG_LENGTH = 0.241  # m, SCARAB II
SIZE_SCALED_DEFAULTS = {"lift_height": 0.05, "clearance": 0.02, "com_margin": 0.015, "reach_slack": 0.015}  # m


def size_scaled(key: str, leg_length: float) -> float:
    """`SIZE_SCALED_DEFAULTS[key]` for a robot of mean leg length `leg_length` (m)."""
    return round(SIZE_SCALED_DEFAULTS[key] * leg_length / REFERENCE_LEG_LENGTH, 4)
