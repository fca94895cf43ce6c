"""Robot models: pinocchio model from the URDF plus robot.yaml, with batch kinematics.

    robot = load_robot("scarab2")
    feet = robot.foot_positions(Q)                  # (n, n_legs, 3)
    J_x = robot.foot_jacobians(Q) @ robot.tangent_map(X)[:, None]   # w.r.t. x = [p, ω, joints]
    c = load_robot("anymal").centroidal             # single-rigid-body model, or None
    reach = leg_reach(robot, base_pos, base_rot, feet_world)      # per-foot IK inside the limits

Names are imported on first use (PEP 562 `__getattr__`): `legplan.robots.navigation` and the
registry load without pinocchio, so navigation commands start fast (issue 19).
"""

from legplan.lazy_exports import lazy_exports

_HOMES = {
    "Centroidal": "centroidal", "Kinematics": "kinematics", "KinematicsWorkspace": "kinematics",
    "KinodynamicLimits": "navigation", "Leg": "spec", "Navigation": "navigation",
    "ReachResult": "legik", "RobotEntry": "registry", "RobotModel": "model", "RobotSpec": "spec",
    "SphereSet": "spec", "joint_efforts": "rigid_body", "leg_reach": "legik", "list_robots": "registry", "load_robot": "registry",
    "read_navigation": "navigation", "read_spec": "spec", "resolve_robot": "registry",
    "robot_search_path": "registry", "shipped_robots_dir": "registry", "survey_robots": "registry",
    "torque_limits": "rigid_body",
}
__all__ = sorted(_HOMES)

__getattr__, __dir__ = lazy_exports(__name__, _HOMES)
