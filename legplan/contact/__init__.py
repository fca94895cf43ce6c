"""Contact-mode constraints of whole-body configurations (batched terms) and single-configuration IK.

    mode = ContactMode(stance, footholds, com_margin=0.02, clearance=0.02)
    values, jac = com_terms(robot, X, mode)          # (n, h), (n, h, nx); g <= 0 feasible
    distance = ColumnDistance.of(terrain, collision_reach(robot, mode.clearance))   # exact terrain distance
    result = solve_ik(robot, distance, mode, x0, posture=Posture(x_ref, w))
"""

from legplan.contact.ik import IKResult, Posture, constraint_blocks, solve_ik
from legplan.contact.terms import (ContactMode, collision_terms, com_terms, foot_target_terms,
                                   joint_limit_terms, sphere_margins, stance_foot_terms)

__all__ = ["ContactMode", "IKResult", "Posture", "collision_terms", "com_terms", "constraint_blocks",
           "foot_target_terms", "joint_limit_terms", "solve_ik", "sphere_margins", "stance_foot_terms"]
