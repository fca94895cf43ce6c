"""Gait-free step-sequence generation on a foothold mask (the sequence q_1..q_k of eq. (2)).

The body follows the straight line from start to goal. Each move picks one leg and one foothold by
a score and appends up to three configurations, each found by whole-body IK (`solve_ik`):

1. shift: all stance feet fixed, the CoM moved inside the support polygon of the other legs
   (skipped when it already is there with the margin);
2. lift: the chosen leg off the ground, its foot at an apex above the middle of its swing;
3. touch-down: the foot on its new foothold.

So consecutive configurations differ by one lift, one touch-down, or a body shift, and the CoM of
every configuration lies inside the support polygon of the motion before and after it.

Leg choice (gait-free): legs are tried by decreasing lag, the distance their foot trails the
nominal foot position at the body pose a little ahead on the path; a leg is skipped when the
polygon of the remaining stance legs cannot hold the CoM with the margin. Foothold choice: cells
of the foothold mask inside the leg's workspace at the target pose (sampled from the joint limits,
`_RobotGeometry`), that make progress along the path and keep a distance to the other feet,
ranked by distance to the nominal position. The first leg/foothold whose three IK solves
succeed is taken. When no option of a move succeeds (a dead end), the previous move is taken back
and its next option tried (depth-first, at most `backtracks` times). Nothing assumes a leg count or
a robot: nominal offsets, hips and workspaces come from the robot's model and nominal configuration.

The IK keeps the spheres clear of the exact terrain distance (`legplan.terrain.ColumnDistance`),
and `generate_steps` judges every configuration independently (`legplan.validate.judge`) against
what the generator promises (`GenerateParams.requirements`), so the rows that miss it are named.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field, replace

import numpy as np
import pinocchio as pin

from legplan.contact.ik import Posture, solve_ik
from legplan.contact.terms import ContactMode, collision_reach, com_terms
from legplan.errors import LegplanError
from legplan.geometry.angles import wrap_angle
from legplan.geometry.polygon import support_polygon
from legplan.parameters import Parameters, param
from legplan.robots.sizing import SIZE_SCALED_DEFAULTS, size_scaled
from legplan.terrain.columns import ColumnDistance
from legplan.validate.judge import Requirements, shortfalls

log = logging.getLogger(__name__)


@dataclass
class GenerateParams(Parameters):
    """Parameters of the step-sequence generator (lengths in m, angles in rad).

    `lift_height`, `clearance`, `com_margin` and `reach_slack` left at None default from the
    robot's size (`sized_for`, `legplan.robots.sizing`): SCARAB II's values (5 cm, 2 cm, 1.5 cm,
    1.5 cm at a mean leg length of 0.241 m) times the robot's mean leg length / 0.241 m, rounded to
    0.1 mm; `--param key=value` sets any of them."""

    what = "generator"

    com_margin: float | None = param(None, "[0, inf)",
                                     doc="CoM distance to every support edge during planning (size-scaled)")
    clearance: float | None = param(None, "[0, inf)",
                                    doc="sphere clearance from the terrain (size-scaled; paper Sec. IV: 2 cm)")
    foot_clearance: float = param(0.01, "[0, inf)", doc="swing-foot sphere clearance")
    foot_tolerance: float = param(1e-4, "(0, inf)", doc="stance feet within this of their footholds (IK)")
    judge_tolerance: float = param(1e-6, "[0, inf)",
                                   doc="allowed miss of CoM margin, clearance, joint limits when judged")
    step_radius: float | None = param(None, "(0, inf)",
                                      doc="start footholds' search radius around the nominal positions")
    reach_slack: float | None = param(None, "[0, inf)",
                                      doc="candidate footholds lie this far inside the leg workspace radii (size-scaled)")
    advance: float | None = param(None, "(0, inf)", doc="how far ahead of the body the target pose lies")
    lift_height: float | None = param(None, "[0, inf)",
                                      doc="swing apex above the higher of the two footholds / terrain (size-scaled)")
    min_progress: float = param(0.02, "[0, inf)", doc="a move must bring the foot this much closer along the path")
    foot_separation: float | None = param(None, "(0, inf)",
                                          doc="minimum distance between two footholds (4 foot radii)")
    candidates: int = param(6, "[1, 1000]", doc="footholds tried per leg")
    goal_tolerance: float = param(0.05, "(0, inf)", doc="body distance to the goal that ends the sequence")
    max_moves: int = param(200, "[1, 1000000]")
    backtracks: int = param(20, "[0, 1000000]", doc="moves taken back at dead ends (depth-first over each move's options)")
    restarts: int = param(1, "[0, 1000]", doc="IK retries from a seeded random perturbation")
    restart_noise: float = param(0.05, "[0, inf)", doc="std of that perturbation (m, rad)")
    posture_weights: tuple[float, float, float, float] = (0.3, 1.0, 1.0, 0.05)  # xy, z, rot, joints

    def sized_for(self, robot) -> GenerateParams:
        """These parameters with every size-scaled one left at None set from `robot`'s leg length."""
        sized = {key: size_scaled(key, robot.leg_length) for key in SIZE_SCALED_DEFAULTS
                 if getattr(self, key) is None}
        return replace(self, **sized)

    def requirements(self) -> Requirements:
        """What every generated configuration keeps (the CoM margin is promised for the support of
        the adjacent motions, a subset of the configuration's stance, so it holds for the stance)."""
        return Requirements(foot_slip=self.foot_tolerance, com_margin=self.com_margin, clearance=self.clearance,
                            foot_clearance=self.foot_clearance, tolerance=self.judge_tolerance)


@dataclass
class GeneratedSequence:
    q: np.ndarray  # (k, nq)
    stance: np.ndarray  # (k, L)
    footholds: np.ndarray  # (k, L, 3), NaN for swing legs
    success: bool
    reason: str
    moves: list[dict] = field(default_factory=list)
    shortfalls: dict[str, np.ndarray] = field(default_factory=dict)  # per row, `legplan.validate.judge`


class GenerationError(RuntimeError):
    """The start configuration cannot be built (no foothold under a nominal foot, IK failure)."""


@dataclass
class _RobotGeometry:
    """Robot-derived nominal geometry in the body frame (from q_nominal) and each leg's workspace.

    The workspace of a leg is the set of horizontal foot offsets from its hip it reaches with the
    foot `body_height` below the base (within `band`), sampled over the joint limits and stored in
    polar form: per bearing bin (`bin_width` rad) the smallest and largest hip-to-foot distance,
    over the half plane on the outer side of the hip (toward the nominal foot). This assumes the workspace is star-shaped around the hip along each bearing (true for the usual
    yaw-hip, pitch-pitch legs) and nothing else about the robot.
    """

    foot_offsets: np.ndarray  # (L, 3) nominal feet relative to the base, body frame
    hip_offsets: np.ndarray  # (L, 3)
    body_height: float  # base height above the mean nominal foot height
    radius_min: np.ndarray  # (L, B) per bearing bin, NaN where no sample fell
    radius_max: np.ndarray  # (L, B)
    bin_width: float

    @classmethod
    def of(cls, robot, rng: np.random.Generator, samples: int = 6000, band: float = 0.01,
           bin_width: float = math.radians(3.0)) -> _RobotGeometry:
        model, data = robot.model, robot.model.createData()
        q = np.asarray(robot.q_nominal, float)
        pin.framesForwardKinematics(model, data, q)
        base = pin.XYZQUATToSE3(q[:7])
        feet = np.array([data.oMf[leg.foot_frame_id].translation for leg in robot.legs])
        hips = np.array([data.oMi[model.getJointId(leg.joint_names[0])].translation for leg in robot.legs])
        to_body = base.rotation.T
        foot_offsets = (feet - base.translation) @ to_body.T
        hip_offsets = (hips - base.translation) @ to_body.T
        body_height = float(base.translation[2] - feet[:, 2].mean())
        Q = np.repeat(q[None], samples, axis=0)
        Q[:, 7:] = rng.uniform(robot.lower, robot.upper, size=(samples, robot.n_joints))
        offsets = (robot.foot_positions(Q) - base.translation) @ to_body.T  # (n, L, 3)
        bins = int(math.ceil(2 * math.pi / bin_width))
        radius_min = np.full((len(robot.legs), bins), np.nan)
        radius_max = np.full((len(robot.legs), bins), np.nan)
        for i in range(len(robot.legs)):
            rel = offsets[:, i] - hip_offsets[i]
            outward = foot_offsets[i, :2] - hip_offsets[i, :2]
            rel = rel[(np.abs(offsets[:, i, 2] + body_height) <= band) & (rel[:, :2] @ outward > 0)]
            radius = np.hypot(rel[:, 0], rel[:, 1])
            which = _bearing_bin(rel, bin_width, bins)
            for b in np.unique(which):
                radius_min[i, b] = radius[which == b].min()
                radius_max[i, b] = radius[which == b].max()
        return cls(foot_offsets, hip_offsets, body_height, radius_min, radius_max, bin_width)

    def reachable(self, leg: int, relative: np.ndarray, slack: float) -> np.ndarray:
        """(n,) True where the horizontal offsets `relative` (n, 2) from the hip (body frame) lie
        inside the leg's workspace with `slack` (m) to its inner and outer radius; a bearing bin
        counts only when both neighbouring bins were reached too (away from the coxa limits), and
        its outer radius is the largest of the three (the samples are sparse)."""
        bins = self.radius_min.shape[1]
        which = _bearing_bin(relative, self.bin_width, bins)
        radius = np.hypot(relative[:, 0], relative[:, 1])
        hi = np.fmax(np.fmax(self.radius_max[leg], np.roll(self.radius_max[leg], 1)),
                     np.roll(self.radius_max[leg], -1))
        lo = self.radius_min[leg]
        known = ~np.isnan(self.radius_min[leg])
        known &= np.roll(known, 1) & np.roll(known, -1)
        return known[which] & (radius >= lo[which] + slack) & (radius <= hi[which] - slack)


def _bearing_bin(relative: np.ndarray, bin_width: float, bins: int) -> np.ndarray:
    angle = np.arctan2(relative[:, 1], relative[:, 0]) % (2 * math.pi)
    return np.minimum((angle / bin_width).astype(int), bins - 1)


def _rot_z(yaw: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


class StepGenerator:
    """Plans a step sequence for `robot` on `terrain` (needs `height`, `grid`, `foothold`)."""

    def __init__(self, robot, terrain, params: GenerateParams = GenerateParams(), seed: int = 0):
        self.robot = robot
        self.terrain = terrain
        self.params = params = params.sized_for(robot)
        self.rng = np.random.default_rng(seed)
        self.distance = ColumnDistance.of(terrain, collision_reach(robot, max(params.clearance, params.foot_clearance)))
        self.geometry = _RobotGeometry.of(robot, self.rng)
        spread = np.linalg.norm(self.geometry.foot_offsets[:, :2] - self.geometry.hip_offsets[:, :2], axis=1)
        self.step_radius = params.step_radius or 0.6 * float(spread.mean())
        self.advance = params.advance or 0.5 * self.step_radius
        self._cells = self._foothold_cells()
        self._body_target: np.ndarray | None = None
        foot_radius = np.asarray(robot.spheres.radii)[np.asarray(robot.spheres.is_foot, bool)]
        self.separation = params.foot_separation or 4.0 * float(foot_radius.max(initial=0.01))

    # --- terrain ------------------------------------------------------------------------------
    def _foothold_cells(self) -> np.ndarray:
        """Foothold mask cell centres (m, 3)."""
        t = self.terrain
        iy, ix = np.nonzero(t.foothold)
        xy = np.asarray(t.grid.origin, float) + t.grid.resolution * np.stack([ix, iy], axis=1)
        return np.column_stack([xy, t.height[iy, ix]])

    def _nearest_foothold(self, point: np.ndarray, radius: float) -> np.ndarray | None:
        d = np.linalg.norm(self._cells[:, :2] - point[:2], axis=1)
        i = int(np.argmin(d)) if len(d) else -1
        return None if i < 0 or d[i] > radius else self._cells[i].copy()

    # --- poses --------------------------------------------------------------------------------
    def _pose(self, s: float):
        s = min(max(s, 0.0), 1.0)
        xy = self.start[:2] + s * (self.goal[:2] - self.start[:2])
        yaw = self.start[2] + s * wrap_angle(self.goal[2] - self.start[2])
        return xy, yaw

    def _nominal_feet(self, xy, yaw) -> np.ndarray:
        return np.r_[xy, 0.0] + self.geometry.foot_offsets @ _rot_z(yaw).T

    def _progress(self, xy) -> float:
        d = self.goal[:2] - self.start[:2]
        length2 = float(d @ d)
        return float((np.asarray(xy)[:2] - self.start[:2]) @ d / length2) if length2 > 0 else 1.0

    def _posture(self, footholds: np.ndarray, stance: np.ndarray, yaw: float) -> Posture:
        """Regularisation toward the target body position on the path (or, before the first move,
        the position the stance footholds imply), nominal height above them, and yaw."""
        robot, geo = self.robot, self.geometry
        R = _rot_z(yaw)
        implied = (footholds - geo.foot_offsets @ R.T)[stance, :2].mean(axis=0)
        ref = np.array(robot.to_vector(robot.q_nominal[None])[0], float)
        ref[:2] = implied if self._body_target is None else self._body_target
        ref[2] = footholds[stance, 2].mean() + geo.body_height
        ref[3:6] = pin.log3(R)
        w_xy, w_z, w_rot, w_joint = self.params.posture_weights
        weights = np.full(len(ref), w_joint)
        weights[:2], weights[2], weights[3:6] = w_xy, w_z, w_rot
        return Posture(ref, weights)

    def _mode(self, stance, footholds, support) -> ContactMode:
        p = self.params
        return ContactMode(stance=stance, footholds=footholds, support=support, com_margin=p.com_margin,
                           clearance=p.clearance, foot_clearance=p.foot_clearance)

    # --- planning -----------------------------------------------------------------------------
    def start_configuration(self):
        """All legs on the footholds nearest their nominal positions at the start pose."""
        xy, yaw = self._pose(0.0)
        nominal = self._nominal_feet(xy, yaw)
        footholds = np.empty_like(nominal)
        for i, point in enumerate(nominal):
            cell = self._nearest_foothold(point, self.step_radius)
            if cell is None:
                raise GenerationError(f"no foothold within {self.step_radius:.3f} m of the nominal position "
                                      f"of leg {self.robot.legs[i].name} at the start pose")
            footholds[i] = cell
        stance = np.ones(len(nominal), bool)
        posture = self._posture(footholds, stance, yaw)
        result = solve_ik(self.robot, self.distance, self._mode(stance, footholds, stance),
                          posture.reference, posture=posture, foot_tolerance=self.params.foot_tolerance)
        if not result.success:
            raise GenerationError(f"IK failed for the start configuration: {result.reason}")
        return result.x, stance, footholds

    def placement_problem(self, name: str, pose) -> str | None:
        """Why pose (x, y, yaw) `name` cannot be planned from or to: its base or a nominal foot off
        the map, or a non-finite value; None when it lies on the map."""
        pose = np.asarray(pose, float)
        if pose.shape != (3,) or not np.isfinite(pose).all():
            return f"{name} pose must be 3 finite numbers (x, y, yaw), got {pose.tolist()}"
        points = np.vstack([pose[:2], self._nominal_feet(pose[:2], pose[2])[:, :2]])
        label = f"{name} pose ({', '.join(f'{v:g}' for v in pose)}):"
        names = [f"{label} base", *(f"{label} nominal foot {leg.name}" for leg in self.robot.legs)]
        return self.terrain.grid.outside_problem(points, names)

    def plan(self, start, goal, progress=None) -> GeneratedSequence:
        """Plan from start (x, y, yaw) to goal (x, y, yaw); a pose off the map is a `LegplanError`
        (bad input, before any work)."""
        for name, pose in (("start", start), ("goal", goal)):
            problem = self.placement_problem(name, pose)
            if problem is not None:
                raise LegplanError(problem)
        self.start = np.asarray(start, float)
        self.goal = np.asarray(goal, float)
        x, stance, footholds = self.start_configuration()
        configs = [(x, stance.copy(), footholds.copy())]
        moves: list[dict] = []
        undo: list[tuple] = []  # per move made: (configurations before it, its option, options banned before it)
        banned: set = set()  # options that led to a dead end from the current configuration
        backtracks = 0
        reason = f"reached max_moves = {self.params.max_moves} before the goal"
        while len(moves) < self.params.max_moves:
            if self._at_goal(x, stance, footholds):
                reason = ""
                break
            outcome = self._move(x, stance, footholds, len(moves), banned)
            if isinstance(outcome, str):
                if not undo or backtracks >= self.params.backtracks:
                    reason = outcome
                    break
                # dead end: take back the last move and try the next option where it was made
                count, option, banned = undo.pop()
                banned.add(option)
                del configs[count:]
                moves.pop()
                backtracks += 1
                x, stance, footholds = (np.array(v, copy=True) for v in configs[-1])
                log.info("dead end (%s); move %d taken back", outcome, len(moves))
                continue
            new_configs, action, leg, cell = outcome
            undo.append((len(configs), _option(action, leg, cell), banned))
            banned = set()
            move = len(moves)
            configs.extend(new_configs)
            x, stance, footholds = (np.array(v, copy=True) for v in new_configs[-1])
            moves.append({"move": move, "action": action, "leg": self.robot.legs[leg].name,
                          "foothold": None if cell is None else cell.tolist(),
                          "configurations": len(new_configs)})
            log.info("move %d: %s leg %s (%d configurations)", move, action, self.robot.legs[leg].name,
                     len(configs))
            if progress is not None:
                progress(self._percent(x), 100, f"move {move}: {action} {self.robot.legs[leg].name}")
        if progress is not None:
            progress(100 if not reason else self._percent(x), 100,
                     f"{len(moves)} moves, {'at the goal' if not reason else 'stopped'}")
        X = np.array([c[0] for c in configs])
        st = np.array([c[1] for c in configs])
        fh = np.array([c[2] for c in configs])
        fh[~st] = np.nan
        return GeneratedSequence(self.robot.from_vector(X), st, fh, success=not reason, reason=reason,
                                 moves=moves)

    def _percent(self, x) -> int:
        """Progress along the path in whole percent (the count the progress callback shows)."""
        return int(100 * min(max(self._progress(x[:2]), 0.0), 1.0))

    def _at_goal(self, x, stance, footholds) -> bool:
        """Body within `goal_tolerance` of the goal, all legs down, none trailing its goal position."""
        if not stance.all() or np.linalg.norm(x[:2] - self.goal[:2]) > self.params.goal_tolerance:
            return False
        xy, yaw = self._pose(1.0)
        return bool(np.all(self._lags(footholds, xy, yaw) < self.params.min_progress + self.step_radius / 2))

    def _lags(self, footholds, xy, yaw) -> np.ndarray:
        return (self._nominal_feet(xy, yaw)[:, :2] - footholds[:, :2]) @ self._direction

    @property
    def _direction(self) -> np.ndarray:
        d = self.goal[:2] - self.start[:2]
        return d / max(float(np.linalg.norm(d)), 1e-12)

    @property
    def _length(self) -> float:
        return float(np.linalg.norm(self.goal[:2] - self.start[:2]))

    def _move(self, x, stance, footholds, move: int, banned=frozenset()):
        """One action: land a lifted leg, step a stance leg, or lift a trailing leg and keep it up
        (when all legs stand and it has no reachable foothold yet, or when nothing else works),
        skipping the `banned` options (`_option` keys). Returns (configurations, action, leg,
        foothold) or a reason."""
        p, names = self.params, [leg.name for leg in self.robot.legs]
        s_target = min(1.0, self._progress(x[:2]) + self.advance / max(self._length, 1e-9))
        xy, yaw = self._pose(s_target)
        nominal = self._nominal_feet(xy, yaw)
        lags = self._lags(footholds, xy, yaw)
        self._body_target = xy
        failures = []
        for leg in np.flatnonzero(~stance):  # land lifted legs first: more support
            candidates = self._candidates(leg, stance, footholds, nominal[leg], xy, yaw)
            if not len(candidates):
                failures.append(f"no reachable foothold for lifted leg {names[leg]}")
            for cell in (c for c in candidates if _option("land", leg, c) not in banned):
                configs, why = self._land(x, stance, footholds, leg, cell, yaw)
                if configs is not None:
                    return configs, "land", leg, cell
                failures.append(f"land {names[leg]}: {why}")
        order = [leg for leg in np.argsort(-lags, kind="stable") if stance[leg]]
        for leg in order:
            if lags[leg] < p.min_progress:
                failures.append(f"{names[leg]}: {lags[leg] * 1e3:.0f} mm behind, nothing to gain")
                continue
            support = stance.copy()
            support[leg] = False
            if not self._support_ok(footholds[support]):
                failures.append(f"{names[leg]}: the other stance legs cannot hold the CoM")
                continue
            candidates = self._candidates(leg, stance, footholds, nominal[leg], xy, yaw)
            if not len(candidates) and stance.all() and _option("lift", leg) not in banned:
                configs, why = self._park(x, stance, footholds, leg, yaw)  # holds the body back: lift it
                if configs is not None:
                    return configs, "lift", leg, None
                failures.append(f"lift {names[leg]} (no reachable foothold): {why}")
            elif not len(candidates):
                failures.append(f"no reachable foothold for leg {names[leg]} at move {move}")
            for cell in (c for c in candidates if _option("step", leg, c) not in banned):
                configs, why = self._step(x, stance, footholds, leg, cell, yaw)
                if configs is not None:
                    return configs, "step", leg, cell
                failures.append(f"step {names[leg]} to {np.round(cell, 3).tolist()}: {why}")
        if _option("shift", int(np.flatnonzero(stance)[0])) not in banned:
            configs, why = self._advance_body(x, stance, footholds, yaw)
            if configs is not None:
                return configs, "shift", int(np.flatnonzero(stance)[0]), None
            failures.append(f"body shift: {why}")
        for leg in order:  # nothing moved: lift the most trailing leg that can be spared
            support = stance.copy()
            support[leg] = False
            if (lags[leg] < p.min_progress or not self._support_ok(footholds[support])
                    or _option("lift", leg) in banned):
                continue
            configs, why = self._park(x, stance, footholds, leg, yaw)
            if configs is not None:
                return configs, "lift", leg, None
            failures.append(f"lift {names[leg]}: {why}")
        return f"move {move}: no leg can move (" + "; ".join(failures[:8]) + ")"

    def _support_ok(self, points) -> bool:
        if len(points) < 3:
            return False
        try:
            poly = support_polygon(points)
        except ValueError:
            return False
        return bool(poly.signed_distance(poly.vertices.mean(axis=0)[None])[0] >= self.params.com_margin)

    def _candidates(self, leg, stance, footholds, nominal, xy, yaw) -> np.ndarray:
        """Foothold cells for `leg`: inside its workspace at the pose (xy, yaw), ahead of its last
        foothold, apart from the other stance feet; nearest to `nominal` first."""
        p, geo = self.params, self.geometry
        cells = self._cells
        gain = (cells[:, :2] - footholds[leg, :2]) @ self._direction >= p.min_progress
        others = footholds[stance & (np.arange(len(stance)) != leg)]
        apart = np.all(np.linalg.norm(cells[:, None, :2] - others[None, :, :2], axis=2) >= self.separation,
                       axis=1)
        hip = np.r_[xy, 0.0] + geo.hip_offsets[leg] @ _rot_z(yaw).T
        relative = (cells[:, :2] - hip[:2]) @ _rot_z(yaw)[:2, :2]  # world -> body frame
        ok = gain & apart & geo.reachable(leg, relative, p.reach_slack)
        chosen = cells[ok]
        order = np.argsort(np.linalg.norm(chosen[:, :2] - nominal[:2], axis=1), kind="stable")
        return chosen[order[:p.candidates]]

    def _shift(self, x, stance, footholds, support, lifted_targets, yaw):
        """Body shift (stance feet fixed) putting the CoM inside the `support` polygon, if needed."""
        mode = self._mode(stance, footholds, support)
        if com_terms(self.robot, x[None], mode)[0].max() <= 0:
            return x, None, ""
        res = self._solve(mode, x, self._posture(footholds, stance, yaw), lifted_targets)
        if not res.success:
            return None, None, f"body shift IK failed ({res.reason})"
        return res.x, (res.x, stance.copy(), footholds.copy()), ""

    def _solve(self, mode, x, posture, soft=None, targets=None):
        """IK from x; on failure once more from a seeded random perturbation of x (local minima)."""
        res = solve_ik(self.robot, self.distance, mode, x, posture=posture, targets=targets,
                       soft_targets=soft, foot_tolerance=self.params.foot_tolerance)
        for _ in range(self.params.restarts):
            if res.success:
                break
            start = x + self.rng.normal(scale=self.params.restart_noise, size=x.shape)
            res = solve_ik(self.robot, self.distance, mode, start, posture=posture, targets=targets,
                           soft_targets=soft, foot_tolerance=self.params.foot_tolerance)
        return res

    def _raised(self, stance, footholds, yaw) -> dict[int, np.ndarray]:
        """Soft targets of lifted legs: their nominal position `lift_height` above the stance feet."""
        ref = self._posture(footholds, stance, yaw).reference
        base = np.r_[ref[:2], ref[2] - self.geometry.body_height]
        feet = base + self.geometry.foot_offsets @ _rot_z(yaw).T
        feet[:, 2] += self.params.lift_height
        return {int(leg): feet[leg] for leg in np.flatnonzero(~stance)}

    def _step(self, x, stance, footholds, leg, cell, yaw):
        """Shift, lift and touch-down configurations moving `leg` to `cell`, or (None, reason)."""
        new = footholds.copy()
        new[leg] = cell
        apex = 0.5 * (footholds[leg] + cell)
        apex[2] = max(footholds[leg, 2], cell[2], self._max_height_between(footholds[leg], cell)) \
            + self.params.lift_height
        configs, why = self._lift(x, stance, footholds, leg, new, apex, yaw)
        if configs is None:
            return None, why
        support = configs[-1][1]
        res = self._solve(self._mode(stance, new, support), configs[-1][0], self._posture(new, stance, yaw),
                          self._raised(stance, new, yaw))
        if not res.success:
            return None, f"touch-down IK failed ({res.reason})"
        configs.append((res.x, stance.copy(), new))
        return configs, ""

    def _lift(self, x, stance, footholds, leg, planned, target, yaw):
        """Shift (if the CoM must move) and lift `leg` with its foot at `target`, the posture aiming
        at the `planned` footholds: the configurations, or (None, reason)."""
        support = stance.copy()
        support[leg] = False
        configs = []
        x, shift, why = self._shift(x, stance, footholds, support, self._raised(stance, footholds, yaw), yaw)
        if x is None:
            return None, why
        if shift is not None:
            configs.append(shift)
        res = self._solve(self._mode(support, footholds, support), x, self._posture(planned, support, yaw),
                          self._raised(support, planned, yaw), {int(leg): target})
        if not res.success:
            return None, f"lift IK failed ({res.reason})"
        configs.append((res.x, support, footholds.copy()))
        return configs, ""

    def _advance_body(self, x, stance, footholds, yaw):
        """Body shift toward the target pose with every stance foot fixed (progress or a reason)."""
        res = self._solve(self._mode(stance, footholds, stance), x, self._posture(footholds, stance, yaw),
                          self._raised(stance, footholds, yaw))
        if not res.success:
            return None, f"IK failed ({res.reason})"
        gained = (res.x[:2] - x[:2]) @ self._direction
        if gained < self.params.min_progress / 2:
            return None, f"body gains only {gained * 1e3:.0f} mm"
        return [(res.x, stance.copy(), footholds.copy())], ""

    def _land(self, x, stance, footholds, leg, cell, yaw):
        """Touch-down of a lifted leg on `cell` (the support of the motion is the current stance)."""
        after = stance.copy()
        after[leg] = True
        new = footholds.copy()
        new[leg] = cell
        res = self._solve(self._mode(after, new, stance), x, self._posture(new, after, yaw),
                          self._raised(after, new, yaw))
        if not res.success:
            return None, f"touch-down IK failed ({res.reason})"
        return [(res.x, after, new)], ""

    def _park(self, x, stance, footholds, leg, yaw):
        """Shift, then lift `leg` above its foothold and keep it up (no foothold within reach)."""
        target = footholds[leg] + [0.0, 0.0, self.params.lift_height]
        return self._lift(x, stance, footholds, leg, footholds, target, yaw)

    def _max_height_between(self, a, b, samples: int = 20) -> float:
        t = np.linspace(0.0, 1.0, samples)[:, None]
        pts = a[None, :2] * (1 - t) + b[None, :2] * t
        return float(np.max(self.terrain.height_at(pts, method="nearest")))


def _option(action: str, leg, cell=None) -> tuple:
    """Key of one option of `StepGenerator._move`: action, leg and foothold (rounded to µm)."""
    return action, int(leg), None if cell is None else tuple(np.round(cell, 6).tolist())


def generate_steps(robot, terrain, start, goal, *, params: GenerateParams = GenerateParams(), seed: int = 0,
                   validator, progress=None):
    """Plan, then judge every configuration with the independent `validator` against
    `params.sized_for(robot).requirements()` (per-row shortfalls in `GeneratedSequence.shortfalls`).

    Returns (StepSequence, GeneratedSequence, ConfigChecks); raises `GenerationError` when not even
    the start configuration exists.
    """
    from legplan.stepseq.robotinfo import robot_reference, robot_sha256
    from legplan.stepseq.sequence import StepSequence

    params = params.sized_for(robot)
    generated = StepGenerator(robot, terrain, params, seed).plan(start, goal, progress)
    seq = StepSequence(q=generated.q, stance=generated.stance, footholds=generated.footholds,
                       robot=robot_reference(robot), robot_sha256=robot_sha256(robot),
                       leg_names=[leg.name for leg in robot.legs], joint_names=robot.joint_names)
    generated.shortfalls, checks = shortfalls(validator, seq.q, seq.stance, seq.footholds, params.requirements())
    return seq, generated, checks
