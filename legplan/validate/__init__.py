"""Independent validation of whole-body configurations (pinocchio FK + FCL terrain mesh).

    validator = Validator(robot, terrain)
    checks = validator.check(Q, stance, footholds)   # ConfigChecks, arrays per configuration
    ok = checks.valid(foot_tolerance=1e-3)

and of centroidal trajectories (issue 14; Newton-Euler, forces, terrain, range of motion, leg IK):

    check = check_trajectory(samples, robot.centroidal, terrain, robot)   # CentroidalCheck
    check.worst, check.passed, check.as_dict()
"""

from legplan.validate.trajectory import CentroidalCheck, CheckTolerances, check_trajectory
from legplan.validate.checks import ConfigChecks, Validator
from legplan.validate.surface import SurfaceMesh

__all__ = ["CentroidalCheck", "CheckTolerances", "ConfigChecks", "SurfaceMesh", "Validator", "check_trajectory"]
