"""Robot models: pinocchio model from the URDF plus robot.yaml, with batch kinematics.

    robot = load_robot("scarab2")
    feet = robot.foot_positions(Q)                  # (n, n_legs, 3)
    J_x = robot.foot_jacobians(Q) @ robot.tangent_map(X)[:, None]   # w.r.t. x = [p, ω, joints]
    c = load_robot("anymal").centroidal             # single-rigid-body model, or None
    reach = leg_reach(robot, base_pos, base_rot, feet_world)      # per-foot IK inside the limits
"""

from legplan.robots.centroidal import Centroidal
from legplan.robots.kinematics import Kinematics, KinematicsWorkspace
from legplan.robots.legik import ReachResult, leg_reach
from legplan.robots.model import RobotModel
from legplan.robots.registry import (RobotEntry, list_robots, load_robot, resolve_robot, robot_search_path,
                                     shipped_robots_dir, survey_robots)
from legplan.robots.spec import KinodynamicLimits, Leg, Navigation, RobotSpec, SphereSet, read_spec

__all__ = ["Centroidal", "Kinematics", "KinematicsWorkspace", "KinodynamicLimits", "Leg", "Navigation",
           "ReachResult", "RobotEntry", "RobotModel", "RobotSpec", "SphereSet", "leg_reach", "list_robots",
           "load_robot", "read_spec", "resolve_robot", "robot_search_path", "shipped_robots_dir",
           "survey_robots"]
