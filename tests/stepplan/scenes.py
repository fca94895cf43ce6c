"""Hand-made step sequences on small maps built from a YAML spec (robot layer + terrain + contact IK).

`box_scene(tmp)`: jueying_mini on flat ground with a 1.5 cm box in front of its left front foot;
q0 nominal, q1 body shifted back-right (all feet down), q2 the left front foot moved 9 cm forward
over the box. Pairs: (q0, q1) a body shift, (q1, q2) a leg swing over the box.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from legplan.contact import ContactMode, Posture, solve_ik
from legplan.contact.terms import collision_reach
from legplan.robots import load_robot
from legplan.terrain import ColumnDistance
from legplan.terrain.spec import build_map
from legplan.terrain.terrain_map import save_map

BOX_SPEC = """name: box_test
resolution: 0.01
extent: {x: [-0.6, 0.6], y: [-0.5, 0.5]}
ground: 0.0
primitives:
  - {type: box, center: [0.255, 0.15], size: [0.02, 0.08], top: 0.015}
sdf: {clearance: 0.3}
"""


def standing_configuration(robot, terrain, base, feet, clearance=0.02):
    """IK: all feet on `feet`, base near `base`, every other sphere `clearance` (default: the step
    planner's 2 cm) clear of the exact terrain distance (posture-regularised, then polished)."""
    reference = robot.to_vector(robot.q_nominal)[0]
    reference[:3] = base
    weights = np.r_[np.ones(6), np.full(robot.n_joints, 0.01)]
    mode = ContactMode(stance=np.ones(len(robot.legs), bool), footholds=feet, com_margin=0.0, clearance=clearance)
    distance = ColumnDistance.of(terrain, collision_reach(robot, mode.clearance))
    result = solve_ik(robot, distance, mode, reference, posture=Posture(reference, weights))
    assert result.success, result.reason
    return result.q


def box_scene(tmp: Path):
    """(robot, terrain, map_path, q (3, nq), stance (3, 4), footholds (3, 4, 3))."""
    spec = Path(tmp) / "box.yaml"
    spec.write_text(BOX_SPEC)
    terrain = build_map(spec)
    map_path = Path(tmp) / "map.h5"
    save_map(terrain, map_path)
    robot = load_robot("jueying_mini")
    feet = robot.foot_positions(robot.q_nominal)[0].copy()
    feet[:, 2] = 0.0
    moved = feet.copy()
    moved[0, 0] = 0.30
    q = np.stack([standing_configuration(robot, terrain, [0.0, 0.0, 0.3059], feet),
                  standing_configuration(robot, terrain, [-0.03, -0.04, 0.30], feet),
                  standing_configuration(robot, terrain, [-0.03, -0.04, 0.30], moved)])
    return robot, terrain, map_path, q, np.ones((3, 4), bool), np.stack([feet, feet, moved])
