"""The planned motion as the whole-body controller's reference: `Reference(samples, foot_radius, terrain)`.

`samples` are a centroidal plan's 10 ms samples (`legplan.dyn.planner.sample_solution`, stored in
traj.h5 under `/tasks/NNNN/samples`): base position/velocity/acceleration, Euler angles (R = Rz Ry
Rx), world angular velocity/acceleration, feet positions/velocities, contact forces (world) and the
contact schedule. `at(t)` interpolates them linearly at the controller's 400 Hz instants; after the
plan's end it holds the last pose at rest (the settling time of `SimParams`).

The plan's feet are points: on the terrain in stance, above it in swing; the simulated foot is a
sphere of radius r around the foot frame (robot.yaml). The foot frame's reference is the sphere
centre whose sphere touches the planned point: r along the terrain normal n for a point on the
terrain (the sphere touches the ground there), r straight up for a point r or more above it (the
sphere's lowest point on the planned path), and between them the offset turns from n to e_z with
the point's height g above the terrain, along r (n (1 − s) + e_z s)/|…|, s = clip(g / r, 0, 1).
Lifting a swing point along the normal instead would, where the point passes over an edge, take
the normal of the edge's near-vertical face and pull the sphere r back into that face.

The planner keeps a swing foot's point above the terrain, not its sphere, and a swing point may
skim the terrain: a sphere centred r above a point that passes an edge's corner overlaps the corner
by up to r horizontally, and a sphere that skims a surface touches it at the least sag; either
way the foot catches on the terrain and stays behind. So the centre is kept at least
r (1 + sin(π p)) above `TerrainModel.envelope_within(r)` (an upper bound of the map's columns within
r of it: a sphere whose centre is r above it clears every column; p the share of the swing elapsed,
`swing_progress`), a clearance of up to r at mid-swing, raised to it by the larger of s and
sin(π p); at lift-off and touch-down (p and s both 0) nothing changes.

That lift is a function of where the planned point is, so it appears as abruptly as the point
reaches an edge: a swing point that moves fast towards a step and passes close to its corner asks
for a lift of up to the sphere's radius and more within one sample, on top of the plan's own rise,
which the swing leg (within its torque limits) cannot follow, and the sphere strikes the step's
face. So the lift is anticipated: within each swing, the centre at time t is raised to at least
z(τ) − `lift_rate` (τ − t) for every later sample τ of the swing that is lifted (z its lifted
height): where it must be over an edge, the foot arrives from below at `lift_rate` at most instead
of jumping there. Only later lifted samples count, so the plan's own vertical motion stays as
planned elsewhere (its touch-down is not delayed), and the foot is never lower than before.
The foot frame's reference velocity is the planned point's plus the rate of that offset, and its
acceleration the finite difference of the velocity (the samples hold no foot accelerations).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from legplan.dyn.euler import rotation


@dataclass(frozen=True)
class RefPoint:
    """The reference at one instant (world frame): base `pos`, `vel`, `acc`, `rot` (3, 3), `omega`,
    `omega_dot`; per leg `feet_pos`, `feet_vel`, `feet_acc` (of the foot frame, i.e. sphere centre),
    `forces` (planned contact forces, N), `contact` (bool), `normal` (unit terrain normal under
    each foot), `swing_progress` (share of each foot's swing elapsed: 0 at lift-off, 1 at touch-down
    and in stance)."""

    pos: np.ndarray
    vel: np.ndarray
    acc: np.ndarray
    rot: np.ndarray
    omega: np.ndarray
    omega_dot: np.ndarray
    feet_pos: np.ndarray
    feet_vel: np.ndarray
    feet_acc: np.ndarray
    forces: np.ndarray
    contact: np.ndarray
    normal: np.ndarray
    swing_progress: np.ndarray


def foot_centres(feet, foot_radius, terrain, normal, progress=None, t=None, lift_rate=None) -> np.ndarray:
    """The foot spheres' centres (n, legs, 3) for the planned foot points `feet` (n, legs, 3), radii
    `foot_radius` (legs,), on `terrain` (a `TerrainModel`) whose unit normal under each point is
    `normal` (n, legs, 3): the offset of the module docstring, and a point above the terrain or in
    its swing (`progress` (n, legs), `swing_progress`; None: no swing clearance) lifted with its
    sphere over the map's columns; with the samples' times `t` (n,) and `lift_rate` (m/s), that lift
    anticipated (`anticipated`) within each swing (module docstring)."""
    n, legs, _ = feet.shape
    x, y = feet[..., 0].ravel(), feet[..., 1].ravel()
    radius = np.asarray(foot_radius, float)[None, :]
    share = np.clip((feet[..., 2] - terrain.height(x, y).reshape(n, legs)) / radius, 0.0, 1.0)
    offset = (1.0 - share[..., None]) * normal + share[..., None] * np.array([0.0, 0.0, 1.0])
    centres = feet + radius[..., None] * offset / np.linalg.norm(offset, axis=-1, keepdims=True)
    bump = np.zeros((n, legs)) if progress is None else np.sin(np.pi * np.clip(progress, 0.0, 1.0))
    for leg, r in enumerate(np.asarray(foot_radius, float)):
        over = terrain.envelope_within(float(r))(centres[:, leg, 0], centres[:, leg, 1]) + r * (1.0 + bump[:, leg])
        weight = np.maximum(share[:, leg], bump[:, leg])
        lift = weight * np.maximum(over - centres[:, leg, 2], 0.0)
        centres[:, leg, 2] += lift
        if t is not None and lift_rate is not None and progress is not None:
            for run in _runs(np.flatnonzero(progress[:, leg] < 1.0)):
                centres[run, leg, 2] = anticipated(np.asarray(t, float)[run], centres[run, leg, 2],
                                                   lift[run] > 0.0, lift_rate)
    return centres


def anticipated(t, z, lifted, rate: float) -> np.ndarray:
    """Heights `z` at the times `t` raised so that they rise at most at `rate` towards every later
    sample flagged `lifted`: max(z(t), max over τ ≥ t lifted of z(τ) − rate (τ − t)) (module docstring)."""
    t, z = np.asarray(t, float), np.asarray(z, float)
    later = (t[None, :] >= t[:, None]) & np.asarray(lifted, bool)[None, :]
    ahead = np.where(later, z[None, :] - rate * (t[None, :] - t[:, None]), -np.inf)
    return np.maximum(z, ahead.max(axis=1, initial=-np.inf))


def _runs(indices: np.ndarray) -> list[np.ndarray]:
    """Consecutive runs of sorted sample indices."""
    return np.split(indices, np.flatnonzero(np.diff(indices) > 1) + 1) if len(indices) else []


def swing_progress(t, contact) -> np.ndarray:
    """Per sample and leg (n, legs): the share of the foot's swing elapsed at t, 0 at its lift-off
    (the last stance sample before it) and 1 at its touch-down; 1 in stance."""
    progress = np.ones(contact.shape)
    for leg in range(contact.shape[1]):
        for run in _runs(np.flatnonzero(~contact[:, leg])):
            start, end = max(run[0] - 1, 0), min(run[-1] + 1, len(t) - 1)
            progress[run, leg] = (t[run] - t[start]) / max(t[end] - t[start], 1e-9)
    return progress


LIFT_RATE = 2.0
"""m/s: default `lift_rate` of a `Reference` (`SimParams.lift_rate`)."""


class Reference:
    """Linear interpolation of the plan's samples (module docstring); `lift_rate` (m/s) bounds the
    rate of the swing feet's lift over the terrain (None: unbounded)."""

    def __init__(self, samples: dict, foot_radius, terrain, lift_rate: float | None = LIFT_RATE):
        t = np.asarray(samples["t"], float)
        if t.ndim != 1 or len(t) < 2 or not np.all(np.diff(t) > 0):
            raise ValueError("samples: t must hold at least two increasing times")
        self.t = t
        self.duration = float(t[-1] - t[0])
        feet = np.asarray(samples["feet_pos"], float)
        n, legs, _ = feet.shape
        normal = terrain.basis(feet[..., 0].ravel(), feet[..., 1].ravel())[0].reshape(n, legs, 3)
        contact = np.asarray(samples["contact"], bool)
        centres = foot_centres(feet, foot_radius, terrain, normal, swing_progress(t, contact), t, lift_rate)
        feet_vel = np.asarray(samples["feet_vel"], float) + np.gradient(centres - feet, t, axis=0)
        self._arrays = {
            "pos": np.asarray(samples["base_pos"], float), "vel": np.asarray(samples["base_vel"], float),
            "acc": np.asarray(samples["base_acc"], float), "euler": np.asarray(samples["base_euler"], float),
            "omega": np.asarray(samples["base_ang_vel"], float),
            "omega_dot": np.asarray(samples["base_ang_acc"], float),
            "feet_pos": centres,
            "feet_vel": feet_vel, "feet_acc": np.gradient(feet_vel, t, axis=0),
            "forces": np.asarray(samples["forces"], float), "normal": normal}
        self._contact = np.asarray(samples["contact"], bool)
        self._arrays["swing_progress"] = swing_progress(t, self._contact)
        for name, value in self._arrays.items():
            if len(value) != n or not np.all(np.isfinite(value)):
                raise ValueError(f"samples: {name} must have {n} finite rows")
        self._rest = ("vel", "acc", "omega", "omega_dot", "feet_vel", "feet_acc")

    def at(self, t: float) -> RefPoint:
        """The reference at time t (s, the plan's clock)."""
        u = np.interp(t, self.t, np.arange(len(self.t)))
        i = min(int(u), len(self.t) - 2)
        w = u - i
        value = {name: (1 - w) * a[i] + w * a[i + 1] for name, a in self._arrays.items()}
        contact = self._contact[min(int(round(u)), len(self.t) - 1)]
        if t >= self.t[-1]:
            value.update({name: np.zeros_like(value[name]) for name in self._rest})
            contact = np.ones_like(contact)
        normal = value.pop("normal")
        normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
        rot = rotation(value.pop("euler")[None])[0]
        return RefPoint(rot=rot, contact=contact, normal=normal, **value)
