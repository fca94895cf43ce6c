"""Leg reachability: per-foot inverse kinematics over many base poses, inside the joint limits.

The independent check of centroidal plans (issue 14) asks, for every sampled base pose and foot
position, whether the robot's leg can put its foot there within the planning joint limits. A foot
moves only with its own leg's joints, so each foot is a small IK problem of its own:

1. The target goes into the base frame, p = Rᵀ (f − b); the base pose then drops out and every
   configuration keeps the base at the origin.
2. Projected Levenberg–Marquardt on the leg's joints q (min ½|p − foot(q)|² s.t. lower <= q <=
   upper), warm-started from the nominal joints, all samples and legs at once. Per step: joints at
   a limit whose gradient pushes them out are held (their Jacobian columns zeroed), the others take
   dq = (JᵀJ + λI)⁻¹ Jᵀe, and q + dq is clipped to the limits. A step that shrinks the error is
   accepted and divides λ by 3, otherwise it is undone and λ grows 4×. Foot positions and
   Jacobians come from `RobotModel.kinematics` (pinocchio, one pass per iteration over the
   samples that are still iterating).
3. A foot stops when its error is below 1/1000 of the tolerance, when its proposed step is below
   1e-10 rad or an accepted step gains less than 1e-6 of the tolerance (a stationary point, e.g.
   on the limits or the stretched leg), when λ exceeds 1e8, or after `max_iterations`.
4. LM is local and can stop on a joint limit short of a target another start reaches (legs far
   from the nominal stance). Samples with a foot beyond the tolerance are solved again from the
   middle of the limits, then from the 2^k points at 1/4 and 3/4 of each leg joint's range, until
   every foot is reached or the starts run out; each foot keeps its best result.

The result per sample and leg is the remaining error, i.e. the distance to the closest foot position
found inside the limits, and `reachable` = error <= tolerance. "Unreachable" means no start found a
solution: for a target outside the legs' workspace that is exact, near its boundary the multi-start
makes a miss unlikely but does not prove it (the tests compare with a joint grid).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

LAMBDA_INIT = 1e-3     # m^2, initial LM damping
LAMBDA_MAX = 1e8       # damping at which a foot stops
STEP_MIN = 1e-10       # rad, proposed step below which a foot stops
GAIN_MIN = 1e-6        # accepted error decrease, relative to the tolerance, below which a foot stops


@dataclass(frozen=True)
class ReachResult:
    """Per sample and leg (n, n_legs): `error` (m) left by the IK, `reachable` = error <= `tolerance`,
    `limit_margin` (rad) the smallest distance of the leg's joints to their planning limits at the
    solution; `joints` (n, n_joints) the joint angles found (order of `robot.joint_names`, inside
    the limits); `iterations` summed over the starts used."""

    error: np.ndarray
    reachable: np.ndarray
    limit_margin: np.ndarray
    joints: np.ndarray
    tolerance: float
    iterations: int


def leg_reach(robot, base_pos, base_rot, feet_world, tolerance: float = 1e-4,
              max_iterations: int = 60, starts: int | None = None) -> ReachResult:
    """Can each leg put its foot on `feet_world` (n, n_legs, 3) with the base at `base_pos` (n, 3),
    `base_rot` (n, 3, 3) (base-to-world rotations)? See the module docstring for the method;
    `starts` limits the starts (1: the nominal stance only; None: all)."""
    base_pos = np.asarray(base_pos, float)
    base_rot = np.asarray(base_rot, float)
    feet_world = np.asarray(feet_world, float)
    n, n_legs = len(base_pos), robot.n_legs
    if base_pos.shape != (n, 3) or base_rot.shape != (n, 3, 3) or feet_world.shape != (n, n_legs, 3):
        raise ValueError(f"{robot.name}: leg_reach wants base_pos (n, 3), base_rot (n, 3, 3), feet_world "
                         f"(n, {n_legs}, 3); got {base_pos.shape}, {base_rot.shape}, {feet_world.shape}")
    targets = np.einsum("nji,nlj->nli", base_rot, feet_world - base_pos[:, None])
    cols = [np.array(leg.joint_idx) for leg in robot.legs]   # into the joint part of q and v
    seeds = _seeds(robot)[:starts]
    error, joints, iterations = _solve(robot, targets, np.tile(seeds[0], (n, 1)), cols, tolerance, max_iterations)
    for seed in seeds[1:]:
        retry = np.flatnonzero((error > tolerance).any(axis=1))
        if not len(retry):
            break
        e, j, it = _solve(robot, targets[retry], np.tile(seed, (len(retry), 1)), cols, tolerance, max_iterations)
        iterations += it
        for leg, c in enumerate(cols):
            better = e[:, leg] < error[retry, leg]
            joints[np.ix_(retry[better], c)] = j[np.ix_(better, c)]
            error[retry[better], leg] = e[better, leg]
    slack = np.minimum(joints - robot.lower, robot.upper - joints)
    margin = np.stack([slack[:, c].min(axis=1) for c in cols], axis=1)
    return ReachResult(error=error, reachable=error <= tolerance, limit_margin=margin, joints=joints,
                       tolerance=tolerance, iterations=iterations)


def _seeds(robot) -> list[np.ndarray]:
    """Start joints (n_joints,): the nominal stance, the middle of the limits, then the 2^k points at
    1/4 and 3/4 of each leg joint's range (k joints per leg)."""
    k = max(len(leg.joint_idx) for leg in robot.legs)
    fractions = [np.full(robot.n_joints, 0.5)]
    for corner in itertools.product([0.25, 0.75], repeat=k):
        fraction = np.empty(robot.n_joints)
        for leg in robot.legs:
            fraction[list(leg.joint_idx)] = corner[:len(leg.joint_idx)]
        fractions.append(fraction)
    span = robot.upper - robot.lower
    return [robot.q_nominal[7:]] + [robot.lower + f * span for f in fractions]


def _solve(robot, targets, start, cols, tolerance, max_iterations):
    """Projected LM from joints `start` (m, n_joints) towards base-frame `targets` (m, n_legs, 3):
    foot errors (m, n_legs) (m), joints (m, n_joints), iterations."""
    m, n_legs = targets.shape[:2]
    lower, upper = robot.lower, robot.upper
    Q = np.zeros((m, robot.nq))
    Q[:, 6] = 1.0                                            # base at the origin, identity quaternion
    Q[:, 7:] = start
    lam = np.full((m, n_legs), LAMBDA_INIT)
    done = np.zeros((m, n_legs), bool)
    error, jac = _evaluate(robot, Q, targets, cols)
    iterations = 0
    while iterations < max_iterations and not done.all():
        iterations += 1
        rows = np.flatnonzero(~done.all(axis=1))
        trial = Q[rows]
        stalled = np.zeros((len(rows), n_legs), bool)
        for leg, c in enumerate(cols):
            move = ~done[rows, leg]
            feet = rows[move]
            q = Q[np.ix_(feet, 7 + c)]
            q_new = _step(q, error[feet, leg], jac[leg][feet], lam[feet, leg], lower[c], upper[c])
            trial[np.ix_(move, 7 + c)] = q_new
            stalled[move, leg] = np.abs(q_new - q).max(axis=1, initial=0.0) < STEP_MIN
        new_error, new_jac = _evaluate(robot, trial, targets[rows], cols)
        new_distance, old_distance = np.linalg.norm(new_error, axis=2), np.linalg.norm(error[rows], axis=2)
        better = (new_distance < old_distance) & ~done[rows]
        stalled |= better & (old_distance - new_distance < GAIN_MIN * tolerance)
        for leg, c in enumerate(cols):
            keep = better[:, leg]
            Q[np.ix_(rows[keep], 7 + c)] = trial[np.ix_(keep, 7 + c)]
            jac[leg][rows[keep]] = new_jac[leg][keep]
        error[rows] = np.where(better[..., None], new_error, error[rows])
        lam[rows] = np.where(better, lam[rows] / 3.0, lam[rows] * 4.0)
        done[rows] |= stalled
        done |= (np.linalg.norm(error, axis=2) < 1e-3 * tolerance) | (lam > LAMBDA_MAX)
    return np.linalg.norm(error, axis=2), Q[:, 7:].copy(), iterations


def _evaluate(robot, Q, targets, cols):
    """Foot errors (m, n_legs, 3) = target - foot, and per leg the foot Jacobian (m, 3, k) w.r.t.
    the leg's joints."""
    feet, jacobians = robot.feet(Q)
    return targets - feet, [jacobians[:, leg][..., 6 + c] for leg, c in enumerate(cols)]


def _step(q, e, J, lam, lower, upper):
    """One projected LM step for m feet: q (m, k), e (m, 3), J (m, 3, k), lam (m,) -> clipped q + dq."""
    g = np.einsum("mik,mi->mk", J, e)                        # descent direction of ½|e|² is +g
    held = ((q <= lower) & (g < 0)) | ((q >= upper) & (g > 0))
    Jf = J * ~held[:, None, :]
    A = np.einsum("mik,mil->mkl", Jf, Jf) + lam[:, None, None] * np.eye(q.shape[1])
    dq = np.linalg.solve(A, np.einsum("mik,mi->mk", Jf, e)[..., None])[..., 0]
    return np.clip(q + dq, lower, upper)
