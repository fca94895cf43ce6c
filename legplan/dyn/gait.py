"""Quadruped phase schedules: which feet touch the ground when (TOWR's quadruped gait generator).

A gait is a sequence of whole-body phases (duration, stance flags per leg). As in TOWR's generator
(the reference of the TOWR-costs paper's experiments), a motion of N strides is

    Stand, stride × (N − 1), closing stride, Stand,

with every duration scaled so that the phases add up to the motion's duration T. Strides, with the
unscaled durations TOWR uses (s):

* ``walk`` — the overlapping walk (TOWR "Walk2"): three-leg 0.25, lateral pair 0.13, three-leg 0.25,
  diagonal 0.13, mirrored; the closing stride drops the last diagonal transition. 4 footsteps per
  stride, so N = 4 gives 16 footsteps.
* ``trot`` — the flying trot (TOWR "Run2"): diagonal pair 0.4, flight 0.1, other pair 0.4, flight
  0.1; the closing stride is one diagonal stance of 0.4. N = 4 gives 14 footsteps, N = 2 gives 6.

Stand is 0.3 s of four-leg support. Legs are ordered lf, rf, lh, rh (the centroidal model's order).

A slow trot (`line_support`): scaled to a long duration, TOWR's trot stands on each diagonal pair
for longer than a robot can balance on the line between two feet (about the base's inverted-pendulum
time √(h/g): deviations grow as e^{t/√(h/g)} while no moment can be exerted about that line). With
`line_support` (s) shorter than the scaled pair, every pair lasts `line_support` and the rest of its
half stride (the pair's excess and the flight) becomes four-leg support: the slow trot with
overlapping pairs, pair, all four, other pair, all four; the closing pair's excess joins the last
Stand. Each diagonal pair still swings together; a trot scaled to pairs within the bound is
unchanged.
Each foot's schedule merges consecutive phases with the same contact state (`foot_phases`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

LEGS = ("lf", "rf", "lh", "rh")
GAITS = ("walk", "trot")


def _state(*stance: str) -> tuple[bool, ...]:
    return tuple(leg in stance for leg in LEGS)


_ALL = _state(*LEGS)
_FLIGHT = _state()
_STAND = [(0.3, _ALL)]
_WALK = [(0.25, _state("lf", "rf", "rh")), (0.13, _state("rf", "rh")), (0.25, _state("lh", "rh", "rf")),
         (0.13, _state("lh", "rf")), (0.25, _state("lh", "lf", "rf")), (0.13, _state("lh", "lf")),
         (0.25, _state("lh", "rh", "lf")), (0.13, _state("rh", "lf"))]
_TROT = [(0.4, _state("rh", "lf")), (0.1, _FLIGHT), (0.4, _state("lh", "rf")), (0.1, _FLIGHT)]
_STRIDES = {"walk": (_WALK, _WALK[:-1]), "trot": (_TROT, _TROT[:1])}


@dataclass(frozen=True)
class FootPhase:
    """One phase of one foot: [t0, t1] in stance or in swing."""

    t0: float
    t1: float
    stance: bool

    @property
    def duration(self) -> float:
        return self.t1 - self.t0


@dataclass(frozen=True)
class Gait:
    """A whole-body phase schedule: `durations` (P,) in seconds and `stance` (P, legs) flags."""

    name: str
    durations: np.ndarray
    stance: np.ndarray

    @property
    def duration(self) -> float:
        return float(self.durations.sum())

    def foot_phases(self, leg: int) -> list[FootPhase]:
        """The phases of one foot, consecutive equal contact states merged."""
        out: list[FootPhase] = []
        t = 0.0
        for d, s in zip(self.durations, self.stance[:, leg]):
            if out and out[-1].stance == bool(s):
                out[-1] = FootPhase(out[-1].t0, t + d, bool(s))
            else:
                out.append(FootPhase(t, t + d, bool(s)))
            t += d
        return out

    def contact(self, times) -> np.ndarray:
        """(n, legs) stance flags at `times` (a time on a phase boundary belongs to the later phase)."""
        ends = np.cumsum(self.durations)
        idx = np.clip(np.searchsorted(ends, np.asarray(times, float), side="right"), 0, len(ends) - 1)
        return self.stance[idx]

    @property
    def footsteps(self) -> int:
        """Number of swing phases over all feet (each ends in a touchdown)."""
        return sum(not p.stance for leg in range(self.stance.shape[1]) for p in self.foot_phases(leg))


def make_gait(name: str, strides: int, duration: float, line_support: float | None = None) -> Gait:
    """Stand, (strides − 1) strides, the closing stride, Stand; durations scaled to `duration`; a
    trot's diagonal pairs at most `line_support` seconds long (module docstring; None: as scaled)."""
    if name not in _STRIDES:
        raise ValueError(f"unknown gait {name!r} (known: {', '.join(GAITS)})")
    if strides < 1 or not duration > 0:
        raise ValueError("need strides ≥ 1 and duration > 0")
    if line_support is not None and not line_support > 0:
        raise ValueError("need line_support > 0")
    stride, closing = _STRIDES[name]
    phases = _STAND + stride * (strides - 1) + closing + _STAND
    durations = np.array([d for d, _ in phases]) * (duration / sum(d for d, _ in phases))
    stance = np.array([s for _, s in phases], bool)
    if name == "trot" and line_support is not None:
        durations, stance = _overlapping_pairs(durations, stance, line_support)
    return Gait(name, durations, stance)


def _overlapping_pairs(durations: np.ndarray, stance: np.ndarray, longest: float):
    """A scaled trot whose pairs last longer than `longest` (s) as the slow trot of the module
    docstring: each pair cut to `longest`, its excess and the flight after it four-leg support (the
    closing pair's excess added to the last Stand); unchanged when every pair is within it."""
    pairs = stance.sum(axis=1) == 2
    if durations[pairs].max(initial=0.0) <= longest:
        return durations, stance
    durations, stance = durations.copy(), stance.copy()
    flights = stance.sum(axis=1) == 0
    stance[flights] = True
    excess = np.where(pairs, durations - longest, 0.0)
    durations[pairs] = longest
    after = np.flatnonzero(pairs) + 1          # each pair's next phase: a flight made four-leg, or the last Stand
    np.add.at(durations, after, excess[pairs])
    merged_d, merged_s = [durations[0]], [stance[0]]
    for d, s in zip(durations[1:], stance[1:]):   # a four-leg phase after a four-leg phase: one phase
        if s.all() and merged_s[-1].all():
            merged_d[-1] += d
        else:
            merged_d.append(d)
            merged_s.append(s)
    return np.array(merged_d), np.array(merged_s)
