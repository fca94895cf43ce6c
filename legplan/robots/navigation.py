"""A robot's 2D navigation model (the `navigation:` section of robot.yaml): footprint, radii and the
Table I limits — read without building the robot's pinocchio model, so navigation commands start
fast (`read_navigation`) and do not depend on the URDF.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from legplan.errors import LegplanError
from legplan.specio import FieldReader, read_yaml_mapping

RADIUS_TOLERANCE = 1e-3       # m, stated navigation radii vs the footprint
LIMIT_UNITS = {"v_x_max": "m/s", "v_x_min": "m/s", "v_y_max": "m/s", "omega_max": "rad/s",
               "a_x_max": "m/s^2", "a_y_max": "m/s^2", "alpha_max": "rad/s^2"}  # Table I


@dataclass(frozen=True)
class KinodynamicLimits:
    """Velocity/acceleration limits of the omnidirectional base (quadruped paper, Table I).

    v_x_min is the largest backwards speed (a positive number)."""

    v_x_max: float
    v_x_min: float
    v_y_max: float
    omega_max: float
    a_x_max: float
    a_y_max: float
    alpha_max: float


@dataclass(frozen=True)
class Navigation:
    """2D navigation model: footprint polygon (k, 2) in the base frame, radii (m) and limits."""

    footprint: np.ndarray
    inscribed_radius: float
    circumscribed_radius: float
    limits: KinodynamicLimits


def parse_navigation(reader: FieldReader, data: dict) -> Navigation | None:
    """The `navigation:` section of robot.yaml `data` (None when absent), checked field by field."""
    nav = reader.get(data, "navigation", "navigation", dict, None)
    if nav is None:
        return None
    points = reader.get(nav, "footprint", "navigation.footprint", list)
    if len(points) < 3:
        reader.fail("navigation.footprint", "must have at least 3 vertices")
    footprint = np.array([reader.vector(p, f"navigation.footprint[{i}]", 2) for i, p in enumerate(points)])
    edges = np.roll(footprint, -1, axis=0) - footprint
    cross = edges[:, 0] * footprint[:, 1] - edges[:, 1] * footprint[:, 0]  # edge x (0 - vertex)
    if not (np.all(cross < 0) or np.all(cross > 0)):
        reader.fail("navigation.footprint", "must be a convex polygon around the base origin")
    inscribed = float(np.min(np.abs(cross) / np.linalg.norm(edges, axis=1)))
    circumscribed = float(np.max(np.linalg.norm(footprint, axis=1)))
    for key, computed in (("inscribed_radius", inscribed), ("circumscribed_radius", circumscribed)):
        if key in nav:
            stated = reader.positive(nav[key], f"navigation.{key}")
            if abs(stated - computed) > RADIUS_TOLERANCE:
                reader.fail(f"navigation.{key}", f"is {stated} but the footprint gives {computed:.4f}")
    limits = reader.get(nav, "limits", "navigation.limits", dict)
    unknown = sorted(set(limits) - set(LIMIT_UNITS))
    if unknown:
        reader.fail(f"navigation.limits.{unknown[0]}", f"is unknown (expected {', '.join(LIMIT_UNITS)})")
    values = {name: reader.positive(reader.get(limits, name, f"navigation.limits.{name}"),
                                    f"navigation.limits.{name}") for name in LIMIT_UNITS}
    return Navigation(footprint=_read_only(footprint), inscribed_radius=inscribed,
                      circumscribed_radius=circumscribed, limits=KinodynamicLimits(**values))


def read_navigation(robot: str | os.PathLike) -> Navigation:
    """The navigation model of a robot by name, folder or robot.yaml path (`resolve_robot`); a
    one-line error when robot.yaml has no `navigation:` section."""
    from legplan.robots.registry import resolve_robot

    path = resolve_robot(robot)
    navigation = parse_navigation(FieldReader(path), read_yaml_mapping(path, "robot spec"))
    if navigation is None:
        raise LegplanError(f"robot '{robot}': robot.yaml has no 'navigation' section (limits of Table I)")
    return navigation


def _read_only(array: np.ndarray) -> np.ndarray:
    array.setflags(write=False)
    return array
