"""Independent validation of whole-body configurations (pinocchio FK + FCL terrain mesh).

    validator = Validator(robot, terrain)
    checks = validator.check(Q, stance, footholds)   # ConfigChecks, arrays per configuration
    ok = checks.valid(foot_tolerance=1e-3)

and of centroidal trajectories (issue 14; Newton-Euler, forces, terrain, range of motion, leg IK):

    check = check_trajectory(samples, robot.centroidal, terrain, robot)   # CentroidalCheck
    check.worst, check.passed, check.as_dict()
"""


import importlib

# Each name from its module on first access (PEP 562): the trajectory check does not import FCL.
_WHERE = {"CentroidalCheck": "trajectory", "CheckTolerances": "trajectory", "check_trajectory": "trajectory",
          "ConfigChecks": "checks", "Validator": "checks", "SurfaceMesh": "surface"}

__all__ = ["CentroidalCheck", "CheckTolerances", "ConfigChecks", "SurfaceMesh", "Validator", "check_trajectory"]


def __getattr__(name):
    if name not in _WHERE:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"legplan.validate.{_WHERE[name]}"), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted({*globals(), *__all__})
