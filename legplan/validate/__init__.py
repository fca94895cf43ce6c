"""Independent validation of whole-body configurations (pinocchio FK + FCL terrain mesh).

    validator = Validator(robot, terrain)
    checks = validator.check(Q, stance, footholds)   # ConfigChecks, arrays per configuration
    ok = checks.valid(foot_tolerance=1e-3)

and of centroidal trajectories (issue 14; Newton-Euler, forces, terrain, range of motion, leg IK):

    check = check_trajectory(samples, robot.centroidal, terrain, robot)   # CentroidalCheck
    check.worst, check.passed, check.as_dict()
"""

from legplan.lazy_exports import lazy_exports

# Each name from its module on first access: the trajectory check does not import FCL.
_HOMES = {"CentroidalCheck": "trajectory", "CheckTolerances": "trajectory", "check_trajectory": "trajectory",
          "ConfigChecks": "checks", "Validator": "checks", "SurfaceMesh": "surface"}
__all__ = sorted(_HOMES)
__getattr__, __dir__ = lazy_exports(__name__, _HOMES)
