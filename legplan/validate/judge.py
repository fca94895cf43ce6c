"""Whether configurations keep every constraint a planner promises, judged independently.

The constraints of the Bézier paper Sec. II-B (stance feet on their footholds eq. (4a), CoM above
the support polygon, spheres clear of the terrain eq. (4b)) plus the joint limits, each judged
with a stated tolerance. The shortfall of a constraint is by how much it is missed, minus its
tolerance: ≤ 0 means kept (negative: the slack), > 0 failed.

  foot_slip     largest stance-foot distance from its foothold − ε (ε is the bound itself, eq. (11b))
  com_margin    `com_margin` − CoM distance inside the polygon of the stance footholds − tolerance
  clearance     largest (required clearance − (terrain distance − radius)) over the spheres − tolerance:
                `clearance` for every sphere but the feet; `foot_clearance` for swing-foot spheres, on
                a path ramped down near its two ends by `legplan.contact.terms.swing_foot_margin`
                (relax_radius > 0); stance-foot spheres are exempt (they touch their footholds)
  joint_limits  largest excursion beyond a joint limit − tolerance

Kinematics come from pinocchio and the terrain distance from the exact FCL surface distance of
`Validator` (`legplan.validate.surface`); of the planners' code only the definition of the ramp is
shared, since it is part of what is required.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from legplan.contact.terms import nearest_end, swing_foot_margin

CONSTRAINTS = {"foot_slip": "m", "com_margin": "m", "clearance": "m", "joint_limits": "rad"}


@dataclass(frozen=True)
class Requirements:
    """What is required (m) and the tolerance (m | rad) of com_margin, clearance and joint_limits."""

    foot_slip: float = 1e-3
    com_margin: float = 0.0
    clearance: float = 0.02
    foot_clearance: float = 0.02
    relax_radius: float = 0.0  # swing-foot ramp around a path's ends (0: no ramp)
    tolerance: float = 0.0

    def tolerances(self) -> dict[str, float]:
        """Tolerance per constraint (the slip bound ε is the requirement itself)."""
        return {name: (0.0 if name == "foot_slip" else self.tolerance) for name in CONSTRAINTS}

    def as_dict(self) -> dict:
        return dataclasses.asdict(self)


def shortfalls(validator, Q, stance, footholds, requirements: Requirements, *, path: bool = False):
    """Per-configuration shortfalls {constraint: (n,)} of configurations Q (n, nq) and the validator's
    `ConfigChecks`. `stance` (n, L) or (L,), `footholds` (n, L, 3) or (L, 3) (NaN for swing legs).
    With `path`, Q is a path in order and the swing-foot ramp is measured from its first and last
    configuration."""
    req = requirements
    Q = np.atleast_2d(np.asarray(Q, float))
    n = len(Q)
    stance = np.broadcast_to(np.asarray(stance, bool), (n, validator.robot.n_legs))
    checks = validator.check(Q, stance, footholds)
    tolerance = req.tolerances()
    slip = np.nan_to_num(checks.foot_slip, nan=0.0).max(axis=1, initial=0.0)
    out = {"foot_slip": slip - req.foot_slip,
           "com_margin": req.com_margin - checks.com_margin - tolerance["com_margin"],
           "clearance": _clearance(validator, checks.sphere_centres, stance, req, path) - tolerance["clearance"],
           "joint_limits": checks.joint_excess.max(axis=1, initial=0.0) - tolerance["joint_limits"]}
    return out, checks


def _clearance(validator, centres, stance, req: Requirements, path: bool) -> np.ndarray:
    """Largest (required clearance − clearance) per configuration; FCL only where the surface bounds
    leave a sphere a candidate for the largest (see `Validator._clearance`)."""
    spheres = validator.robot.spheres
    legs = np.asarray(spheres.leg_index)
    radii = np.asarray(spheres.radii, float)
    is_foot = np.asarray(spheres.is_foot, bool) & (legs >= 0)
    on_stance = np.where(legs >= 0, stance[:, np.maximum(legs, 0)], False)
    swing_foot = is_foot & ~on_stance
    required = np.where(swing_foot, req.foot_clearance, req.clearance)
    if path and req.relax_radius > 0:
        ramp, _ = swing_foot_margin(nearest_end(centres, centres[[0, -1]]), radii, req.foot_clearance,
                                    req.foot_slip, req.relax_radius)
        required = np.where(swing_foot, ramp, required)
    exempt = is_foot & on_stance
    lb, ub, exact = (b.reshape(exempt.shape) for b in validator.surface.distance_bounds(centres.reshape(-1, 3)))
    need = required + radii
    high = np.where(exempt, -np.inf, need - lb)
    low = np.where(exempt, -np.inf, need - ub)
    todo = ~exempt & ~exact & (high > low.max(axis=1, initial=-np.inf)[:, None])
    value = low.copy()
    value[exact] = high[exact]
    if todo.any():
        value[todo] = need[todo] - validator.surface.fcl_distance(centres[todo])
    return value.max(axis=1, initial=-np.inf)


def failures(worst: dict[str, float], requirements: Requirements) -> list[str]:
    """'name short by x beyond its tolerance t' for every constraint whose worst shortfall is > 0."""
    tolerance = requirements.tolerances()
    out = []
    for name, value in worst.items():
        if value > 0:
            scale, unit = (1e3, "mm") if CONSTRAINTS[name] == "m" else (1e3, "mrad")
            out.append(f"{name} short by {value * scale:.3g} {unit} "
                       f"beyond its tolerance {tolerance[name] * scale:g} {unit}")
    return out


def row_failures(per_row: dict[str, np.ndarray], requirements: Requirements) -> list[str]:
    """'row i: ...' (0-based) for every configuration that misses a constraint (see `failures`)."""
    rows = np.flatnonzero(np.any([np.asarray(v) > 0 for v in per_row.values()], axis=0))
    return [f"row {i}: " + "; ".join(failures({k: float(v[i]) for k, v in per_row.items()}, requirements))
            for i in rows]
