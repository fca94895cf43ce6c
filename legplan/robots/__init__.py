"""Robot models: pinocchio model from the URDF plus robot.yaml, with batch kinematics.

    robot = load_robot("scarab2")
    feet = robot.foot_positions(Q)                  # (n, n_legs, 3)
    J_x = robot.foot_jacobians(Q) @ robot.tangent_map(X)[:, None]   # w.r.t. x = [p, ω, joints]
"""

from legplan.robots.kinematics import Kinematics, KinematicsWorkspace
from legplan.robots.model import RobotModel
from legplan.robots.registry import list_robots, load_robot, resolve_robot, robots_dir
from legplan.robots.spec import KinodynamicLimits, Leg, Navigation, RobotSpec, SphereSet, read_spec

__all__ = ["Kinematics", "KinematicsWorkspace", "KinodynamicLimits", "Leg", "Navigation", "RobotModel",
           "RobotSpec", "SphereSet", "list_robots", "load_robot", "read_spec", "resolve_robot",
           "robots_dir"]
