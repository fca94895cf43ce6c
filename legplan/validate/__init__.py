"""Independent validation of whole-body configurations (pinocchio FK + FCL terrain mesh).

    validator = Validator(robot, terrain)
    checks = validator.check(Q, stance, footholds)   # ConfigChecks, arrays per configuration
    ok = checks.valid(foot_tolerance=1e-3)
"""

from legplan.validate.checks import ConfigChecks, Validator
from legplan.validate.surface import SurfaceMesh

__all__ = ["ConfigChecks", "SurfaceMesh", "Validator"]
