"""Whole-body tracking controller: task-space inverse dynamics as one QP per 400 Hz tick.

The paper executes its plans with Bellicoso et al.'s whole-body controller at 400 Hz (Sec. III-B),
which tracks the base and end-effector trajectories with the planned contact forces through a
hierarchy of QPs. This is the simple, single-QP form of that idea (weighted instead of strictly
prioritised tasks; no slip state machine). Unknowns x = [v̇ (nv), f (3 per stance foot)], pinocchio's
floating-base model (free-flyer v = [v_lin, ω] in the base frame, then the joints):

    minimise   Σ_tasks w ‖J v̇ + J̇v − a*‖²  +  w_f ‖f − f_plan‖²  +  w_reg ‖v̇‖²
    subject to M_b v̇ + h_b = J_c,bᵀ f                 (floating-base rows of the dynamics)
               J_c v̇ + J̇_c v = −k_c v_c               (stance feet do not accelerate; slip damped)
               −τ_max ≤ M_j v̇ + h_j − J_c,jᵀ f ≤ τ_max   (joint torques within the URDF limits)
               f_min ≤ f·n ≤ f_max, d_k·f ≤ μ cos(π/8) f·n (8-facet pyramid inscribed in the cone)

Tasks (world frame, references from `legplan.sim.reference`): base position a* = a_plan +
Kp (p_plan − p) + Kd (v_plan − v); base orientation a* = ω̇_plan + Kp log(R_plan Rᵀ) + Kd (ω_plan −
ω); each swing foot a* = a_plan + Kp (p_plan − p) + Kd (v_plan − v). A foot is in stance when the
plan says so and it touches the terrain (the simulator's contact state, as a robot's contact
sensing); a foot planned in stance that has not touched down yet moves at rest towards a point
`search_depth` below its planned foothold (late touchdown) instead of pushing on air. The torques are τ = M_j v̇ + h_j − J_c,jᵀ f at the optimum.

Footholds follow the base's velocity error (capture point, Pratt et al. 2006; Raibert's foot
placement): a plan is executed open loop, and on a support line or a point the base is an inverted
pendulum whose velocity error grows as e^{t/τ}, τ = √(h/g) (h the nominal base height), which only
where the feet land can correct. Each swing foot's target moves horizontally by
`step_feedback` · τ (v − v_plan), clipped to the range of motion's half-widths, phased in over the
swing (`RefPoint.swing_progress`: none at lift-off, all of it at touch-down and for a late foot);
the time constant makes the correction scale with the robot's size.

Joint velocity limits v_max (URDF `velocity`): the joint rates one `velocity_horizon` ahead stay
inside them, −v_max ≤ v_j + T v̇_j ≤ v_max (a joint already beyond its limit is braked back at
(|v_j| − v_max)/T). Joint damping d (URDF `<dynamics damping>`) is compensated, τ += d v_j, and the
joints' armature is on the diagonal of the model's mass matrix, as in the simulator. The joints'
Coulomb friction (URDF `<dynamics friction>`, MuJoCo's friction loss) is not compensated: its sign
flips with the joint rate, and it acts on the controller as a disturbance.

The QP is small (18 + 3 n_c unknowns) and dense, solved by proxsuite's ProxQP (dense backend), cold
started each tick; BENCHMARKS.md (sim) compares it with OSQP on the same QPs. ProxQP's solution of
the same arrays differs in its last bits from call to call (its vectorized loops depend on where the
arrays lie in memory), and a simulation amplifies one bit into a different run. So its solution is
rounded to `QP_RESOLUTION_DECIMALS` (accelerations in m/s² and rad/s², forces in N): far below what changes a
torque command, far above ProxQP's last bits; the same inputs then give the same run.

Fallback when the QP is not solved (infeasible: the torque limits cannot hold the stance feet still
and meet the velocity limits; or out of its iterations, `QP_MAX_OUTER` × `QP_MAX_INNER`: a
controller's tick is bounded in time), counted in `qp_failures`: the relaxed QP, in
which the stance feet's zero-acceleration equalities become tasks of weight `w_contact` and the
velocity-limit rows are dropped. It is always feasible (zero joint torques with any force in the
cones satisfy it), so it fails only numerically; then the last torques are held for the tick
(counted in `qp_held`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin
import proxsuite

from legplan.dyn.capture import capture_step

LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
FACETS = [(np.cos(a), np.sin(a)) for a in np.arange(8) * np.pi / 4]
"""Directions of the friction pyramid's facets in the tangent plane: an octagon inscribed in the cone."""


@dataclass(frozen=True)
class Gains:
    """Feedback gains (1/s², 1/s) and task weights of the controller (module docstring).

    Acceleration-level gains give the same closed-loop dynamics whatever the robot's mass; what
    differs between robots is how the tasks compete in the QP. In a trot the two diagonal stance
    feet cannot produce a moment about the line through them, so the base position, its
    orientation and the swing legs (whose reaction turns the base about that line, the more the
    heavier the legs are against the trunk) cannot all be tracked at once. The base position
    outweighs the orientation (a base that drifts sideways off its support line falls, a small
    roll is harmless), but not so far that the orientation is given up entirely on a robot with
    heavy legs. The swing feet are stiff (natural frequency √swing_kp, about critically damped):
    a plan passes an edge with its swing foot a few millimetres clear, and a foot that lags or
    sags under its path by more strikes the edge and catches on it. BENCHMARKS.md (robots, sim)
    holds the runs behind these values."""

    base_kp: float = 400.0
    base_kd: float = 40.0
    rot_kp: float = 200.0
    rot_kd: float = 30.0
    swing_kp: float = 1500.0
    swing_kd: float = 80.0
    slip_kd: float = 20.0         # 1/s, damping of a stance foot's velocity
    w_base: float = 30.0
    w_rot: float = 1.0
    w_swing: float = 1.0
    w_force: float = 1e-5         # per N², against (m/s²)² of the motion tasks
    w_reg: float = 1e-6
    f_min: float = 1.0            # N, smallest normal force of a stance foot
    f_max: float = 1000.0         # N, robot.yaml's max_normal_force
    search_depth: float = 0.03    # m, below the planned foothold a late foot reaches for
    velocity_horizon: float = 0.01   # s, T of the joint velocity limit rows
    w_contact: float = 1e4        # weight of the stance feet's zero acceleration in the relaxed QP
    step_feedback: float = 1.0    # × the capture-point shift of the swing feet's footholds (0: none)


QP_EPS_ABS = 1e-6
"""ProxQP's absolute tolerance on the primal and dual residuals."""
QP_EPS_PRIMAL_INF = 1e-9
"""ProxQP's tolerance of its primal infeasibility certificate. Its default (1e-4) declares these QPs
(forces in N next to accelerations, weights 1e-6 to 1e4) infeasible after two iterations when they
are not: the same QPs, even the relaxed one that is feasible by construction, solve in a few
iterations with residuals near 1e-11 at this tolerance."""

QP_MAX_OUTER = 20
"""ProxQP's outer (proximal) iterations of one tick's QP, at most (its `max_iter`; default 10,000)."""
QP_MAX_INNER = 100
"""ProxQP's inner iterations per outer one, at most (its `max_iter_in`; default 1,500). The tick's QPs
solve in a few iterations; a reference far off (accelerations or forces many orders beyond the
robot's) makes ProxQP spend thousands of iterations on every tick within its defaults, so a run of
seconds takes hours. A 400 Hz controller has 2.5 ms a tick: at these bounds the QP is counted as failed and
the fallback takes over (module docstring)."""


QP_RESOLUTION_DECIMALS = 6
"""The QP's solution is rounded to 10^-6 (m/s², rad/s², N): module docstring."""


def solve_qp(qp: QP):
    """ProxQP (dense) on `qp`, cold started: (its x rounded to `QP_RESOLUTION_DECIMALS`, its status)."""
    solver = proxsuite.proxqp.dense.QP(len(qp.g), len(qp.b), len(qp.l))
    solver.settings.eps_abs = QP_EPS_ABS
    solver.settings.eps_primal_inf = QP_EPS_PRIMAL_INF
    solver.settings.max_iter, solver.settings.max_iter_in = QP_MAX_OUTER, QP_MAX_INNER
    solver.settings.verbose = False
    solver.init(qp.H, qp.g, qp.A, qp.b, qp.C, qp.l, qp.u)
    solver.solve()
    return np.round(solver.results.x, QP_RESOLUTION_DECIMALS), solver.results.info.status


@dataclass
class QP:
    """One tick's QP in proxsuite's dense form: min ½xᵀHx + gᵀx, A x = b, l <= C x <= u."""

    H: np.ndarray
    g: np.ndarray
    A: np.ndarray
    b: np.ndarray
    C: np.ndarray
    l: np.ndarray
    u: np.ndarray


class WholeBodyController:
    """Task-space inverse dynamics of `robot` (a `RobotModel`) with joint torque limits `effort`
    (n_joints,) and friction `mu`; optional per joint `velocity_limit` (rad/s, inf: none), `damping`
    (N m s/rad) and `armature` (kg m²). `torques(q, v, ref, touching)` gives the joint torques
    (pinocchio order); `qp_failures` and `qp_held` count the fallbacks (module docstring)."""

    def __init__(self, robot, effort, mu: float, gains: Gains = Gains(), velocity_limit=None, damping=None,
                 armature=None):
        self.model = pin.Model(robot.model)
        n = self.model.nv - 6
        if armature is not None:
            self.model.armature[6:] = armature
        self.data = self.model.createData()
        self.base_frame = next(i for i, f in enumerate(self.model.frames)   # the root link's body frame
                               if f.parentJoint == 1 and f.type == pin.FrameType.BODY)
        self.feet = [leg.foot_frame_id for leg in robot.legs]
        self.effort = np.asarray(effort, float)
        self.velocity_limit = np.full(n, np.inf) if velocity_limit is None else np.asarray(velocity_limit, float)
        self.damping = np.zeros(n) if damping is None else np.asarray(damping, float)
        self.mu = float(mu) * np.cos(np.pi / len(FACETS))
        self.gains = gains
        body = robot.centroidal   # none: no nominal height, so no foothold shift
        self.time_constant = 0.0 if body is None else float(np.sqrt(body.base_height / 9.81))
        self.step_limit = np.zeros(3) if body is None else np.r_[np.asarray(body.range_of_motion, float)[:2], 0.0]
        self.qp_failures = 0
        self.qp_held = 0
        self._last = np.zeros(n)

    def build(self, q, v, ref, touching, relaxed: bool = False) -> QP:
        """The QP of the module docstring at state (q, v), reference `ref` (a `RefPoint`) and the
        feet that touch the terrain now, `touching` (n_legs,) bool; `relaxed`: the fallback QP."""
        model, data, k = self.model, self.data, self.gains
        nv = model.nv
        pin.computeAllTerms(model, data, q, v)
        pin.forwardKinematics(model, data, q, v, np.zeros(nv))
        pin.updateFramePlacements(model, data)
        M = np.triu(data.M) + np.triu(data.M, 1).T
        h = data.nle
        stance = np.flatnonzero(ref.contact & touching)
        nf = 3 * len(stance)
        rows, targets, weights = [], [], []

        base = data.oMf[self.base_frame]
        J = pin.getFrameJacobian(model, data, self.base_frame, LWA)
        vel = pin.getFrameVelocity(model, data, self.base_frame, LWA)
        drift = pin.getFrameClassicalAcceleration(model, data, self.base_frame, LWA)
        a_lin = ref.acc + k.base_kp * (ref.pos - base.translation) + k.base_kd * (ref.vel - vel.linear)
        a_ang = (ref.omega_dot + k.rot_kp * pin.log3(ref.rot @ base.rotation.T)
                 + k.rot_kd * (ref.omega - vel.angular))
        rows += [J[:3], J[3:]]
        targets += [a_lin - drift.linear, a_ang - drift.angular]
        weights += [np.full(3, k.w_base), np.full(3, k.w_rot)]

        step = self.step(vel.linear, ref.vel)
        contact_J, contact_rhs = [], []
        for leg, frame in enumerate(self.feet):
            Jf = pin.getFrameJacobian(model, data, frame, LWA)[:3]
            vf = pin.getFrameVelocity(model, data, frame, LWA).linear
            df = pin.getFrameClassicalAcceleration(model, data, frame, LWA).linear
            if leg in stance:
                contact_J.append(Jf)
                contact_rhs.append(-df - k.slip_kd * vf)
                if relaxed:
                    rows.append(Jf)
                    targets.append(contact_rhs[-1])
                    weights.append(np.full(3, k.w_contact))
            else:
                p = data.oMf[frame].translation
                if ref.contact[leg]:   # late touchdown: reach down for the terrain at rest
                    a = k.swing_kp * (ref.feet_pos[leg] + step - k.search_depth * ref.normal[leg] - p) - k.swing_kd * vf
                else:
                    a = (ref.feet_acc[leg] + k.swing_kp * (ref.feet_pos[leg] + ref.swing_progress[leg] * step - p)
                         + k.swing_kd * (ref.feet_vel[leg] - vf))
                rows.append(Jf)
                targets.append(a - df)
                weights.append(np.full(3, k.w_swing))

        n = nv + nf
        task = np.vstack(rows)
        w = np.concatenate(weights)
        H = np.zeros((n, n))
        g = np.zeros(n)
        H[:nv, :nv] = task.T @ (w[:, None] * task) + k.w_reg * np.eye(nv)
        g[:nv] = -task.T @ (w * np.concatenate(targets))
        if nf:
            H[nv:, nv:] = k.w_force * np.eye(nf)
            g[nv:] = -k.w_force * ref.forces[stance].ravel()
        Jc = np.vstack(contact_J) if nf else np.zeros((0, nv))

        equalities = 0 if relaxed else nf
        A = np.zeros((6 + equalities, n))
        A[:6, :nv] = M[:6]
        A[:6, nv:] = -Jc[:, :6].T
        A[6:, :nv] = Jc[:equalities]
        b = np.concatenate([-h[:6]] + ([] if relaxed else contact_rhs))

        joints = nv - 6
        tau_bias = h[6:] + self.damping * v[6:]
        limited = np.array([], int) if relaxed else np.flatnonzero(np.isfinite(self.velocity_limit))
        speed_rows = np.zeros((len(limited), n))
        speed_rows[np.arange(len(limited)), 6 + limited] = k.velocity_horizon
        vmax, vj = self.velocity_limit[limited], v[6:][limited]
        facets = len(FACETS) + 1
        C = np.zeros((joints + facets * len(stance), n))
        C[:joints, :nv] = M[6:]
        C[:joints, nv:] = -Jc[:, 6:].T
        l = np.concatenate([-self.effort - tau_bias, np.full(facets * len(stance), -np.inf)])
        u = np.concatenate([self.effort - tau_bias, np.zeros(facets * len(stance))])
        for i, leg in enumerate(stance):
            normal = ref.normal[leg]
            t1 = np.array([normal[2], 0.0, -normal[0]]) / np.hypot(normal[2], normal[0])   # ŷ × n
            t2 = np.array([normal[1] * t1[2] - normal[2] * t1[1], normal[2] * t1[0] - normal[0] * t1[2],
                           normal[0] * t1[1] - normal[1] * t1[0]])                    # n × t1
            r, c = nv - 6 + facets * i, nv + 3 * i
            C[r, c:c + 3] = normal
            l[r], u[r] = k.f_min, k.f_max
            for j, (ct, st) in enumerate(FACETS):
                C[r + 1 + j, c:c + 3] = ct * t1 + st * t2 - self.mu * normal
        C = np.vstack([C, speed_rows])
        l = np.concatenate([l, -vmax - vj])
        u = np.concatenate([u, vmax - vj])
        return QP(H, g, A, b, C, l, u)

    def step(self, velocity, planned_velocity) -> np.ndarray:
        """The shift (3,) of a swing foot's foothold (module docstring): `step_feedback` × √(h/g) ×
        the horizontal base velocity error, each axis inside the range of motion's half-width."""
        error = np.asarray(velocity, float) - np.asarray(planned_velocity, float)
        return capture_step(error, self.time_constant, self.step_limit, self.gains.step_feedback)

    @staticmethod
    def _solve(qp: QP):
        x, status = solve_qp(qp)
        return x if status == proxsuite.proxqp.QPSolverOutput.PROXQP_SOLVED else None

    def torques(self, q, v, ref, touching) -> np.ndarray:
        """Joint torques (n_joints,) for state (q, v) (pinocchio convention), `ref` and `touching`;
        the fallbacks of the module docstring when the QP is not solved."""
        qp = self.build(q, v, ref, touching)
        x = self._solve(qp)
        if x is None:
            self.qp_failures += 1
            qp = self.build(q, v, ref, touching, relaxed=True)
            x = self._solve(qp)
            if x is None:
                self.qp_held += 1
                return self._last
        joints = self.model.nv - 6
        tau = qp.C[:joints] @ x + self.data.nle[6:] + self.damping * v[6:]
        self._last = np.clip(tau, -self.effort, self.effort)
        return self._last
