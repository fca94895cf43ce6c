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


class BoxFiles:
    """`box_scene` on disk: the map and steps.h5 files of its configurations in any order (each
    written once, validated like `steps import`). Shared by a session: tests read these files and
    write their outputs elsewhere."""

    def __init__(self, tmp: Path):
        self.directory = Path(tmp)
        self.robot, self.terrain, self.map_path, self.q, self.stance, self.footholds = box_scene(tmp)
        self._written: dict[tuple[int, ...], Path] = {}

    def sequence(self, order=(0, 1, 2)):
        """The configurations `order` as a `StepSequence`."""
        from legplan.stepseq.robotinfo import robot_sha256
        from legplan.stepseq.sequence import StepSequence

        order = list(order)
        return StepSequence(q=self.q[order], stance=self.stance[order], footholds=self.footholds[order],
                            robot=self.robot.name, robot_sha256=robot_sha256(self.robot), leg_names=[leg.name for leg in self.robot.legs],
                            joint_names=self.robot.joint_names)

    def steps_file(self, order=(0, 1, 2)) -> Path:
        """steps.h5 of the configurations `order` (e.g. (0, 1, 2, 1, 0): walked there and back)."""
        from legplan.stepseq.sequence import write_steps
        from legplan.validate.checks import Validator

        order = tuple(order)
        if order not in self._written:
            seq = self.sequence(order)
            path = self.directory / f"steps_{'-'.join(map(str, order))}.h5"
            write_steps(path, seq, Validator(self.robot, self.terrain).check(seq.q, seq.stance, seq.footholds))
            self._written[order] = path
        return self._written[order]
