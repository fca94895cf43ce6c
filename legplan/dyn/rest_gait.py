"""The gait of the rest of a motion: what a replan keeps of a plan's phases from a time t on, and what
a pushed replan changes in them (issue 39 item 3; `legplan.dyn.replan` poses the rest's problem).

Every function takes a `Gait` and returns a new one on the rest's own time axis (0 = the replan
time): `remaining_gait` cuts the phases before t and holds the feet in the air at t,
`early_touchdown` and `grounded_flights` are a recovering replan's edits (feet down sooner, no
flight), `gait_stride` and `insert_strides` find one stride of a gait and repeat it (a pushed base
that needs more steps to stop). The goal, the order of the feet's steps and, but for inserted
strides, the motion's end stay those of the plan.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from legplan.dyn.gait import Gait

AIRBORNE_HOLD = 0.02
"""s: the stance a foot in the air at the replan time holds at its measured position before the rest
of its swing (at most half of what is left of the current phase)."""
PHASE_END = 1e-3  # s: a phase with less than this left at the replan time is taken as over
EPS = 1e-9  # s: times closer than this are equal


def gait_stride(gait: Gait) -> Gait | None:
    """One stride of `gait`: the shortest run of p phases that the phases between its first and last
    (the Stands) repeat at once, stance and durations (a gait of two strides or more, `make_gait`);
    None when there is none."""
    stance, durations = gait.stance[1:-1], gait.durations[1:-1]
    for p in range(1, len(durations) // 2 + 1):
        for a in range(len(durations) - 2 * p + 1):
            if (np.array_equal(stance[a:a + p], stance[a + p:a + 2 * p])
                    and np.allclose(durations[a:a + p], durations[a + p:a + 2 * p], rtol=0.0, atol=EPS)):
                return Gait(gait.name, durations[a:a + p].copy(), stance[a:a + p].copy())
    return None


@dataclass(frozen=True)
class Insertion:
    """Strides inserted into the rest of a motion (`insert_strides`): from `at` (s, the rest's
    clock) `count` strides of `period` s; what follows is the previous plan `count`·`period` later."""

    at: float
    period: float
    count: int

    @property
    def length(self) -> float:
        return self.count * self.period

    def previous_time(self, times: np.ndarray) -> np.ndarray:
        """The time on the rest's previous clock (without the strides) each time of the rest stands
        for: itself before `at`, in the strides the stride before them (one stride repeated), after
        them itself less `length`."""
        times = np.asarray(times, float)
        inside = (times >= self.at) & (times < self.at + self.length)
        repeat = self.at - self.period + np.mod(times - self.at, self.period)
        return np.where(times < self.at, times, np.where(inside, repeat, times - self.length))


def insert_strides(gait: Gait, stride: Gait, count: int, first: int = 1) -> tuple[Gait, Insertion | None]:
    """`gait` (a rest, t at 0) with `count` strides `stride` inserted before its last phase at or
    after `first` that starts a stride — its stance `stride`'s first, the phase before it
    `stride`'s last — so that the feet's order of steps goes on; unchanged (None) without such a
    phase or with `count` 0."""
    at = [k for k in range(max(first, 1), len(gait.durations))
          if np.array_equal(gait.stance[k], stride.stance[0]) and np.array_equal(gait.stance[k - 1], stride.stance[-1])]
    if count < 1 or not at:
        return gait, None
    k = at[-1]
    durations = np.concatenate([gait.durations[:k]] + [stride.durations] * count + [gait.durations[k:]])
    stance = np.vstack([gait.stance[:k]] + [stride.stance] * count + [gait.stance[k:]])
    return (Gait(gait.name, durations, stance),
            Insertion(float(gait.durations[:k].sum()), stride.duration, count))


def early_touchdown(gait: Gait, airborne: np.ndarray, swing: float) -> Gait:
    """`gait` (a `remaining_gait`, t at 0) with every foot in the air at t (`airborne`) landing at
    `swing` s, if it lands later as planned, and standing from there to its planned touchdown (its
    next stance then goes on as planned): the phase holding `swing` is split there. A pushed base
    whose capture point leaves the stance feet's support (a walk's diagonal pair while the third
    foot swings) tips over within the rest of a planned swing; a foot on the ground sooner
    widens the support it can stop on (capture point, Pratt et al. 2006), and its foothold is the
    replan's to choose. The total duration, the goal and every later lift-off are unchanged."""
    ends = np.cumsum(gait.durations)
    late = []
    for leg in np.flatnonzero(airborne):
        later = np.flatnonzero(gait.stance[1:, leg]) + 1  # phase 0 is the hold at its measured position
        if not later.size or ends[later[0] - 1] > swing + EPS:
            late.append(leg)
    if not late:
        return gait
    k = int(np.searchsorted(ends, swing, side="right"))
    durations, stance = gait.durations.copy(), gait.stance.copy()
    start = ends[k] - durations[k]
    if swing - start > PHASE_END and ends[k] - swing > PHASE_END:  # split the phase at `swing`
        durations = np.concatenate([durations[:k], [swing - start, ends[k] - swing], durations[k + 1:]])
        stance = np.vstack([stance[:k + 1], stance[k:]])
        k += 1
    elif ends[k] - swing <= PHASE_END:
        k += 1
    for leg in late:
        lands = k + int(np.argmax(stance[k:, leg])) if stance[k:, leg].any() else len(durations)
        stance[k:lands, leg] = True
    return Gait(gait.name, durations, stance)


def grounded_flights(gait: Gait) -> Gait:
    """`gait` (a rest, t at 0) with every phase after its first in which no foot stands (a flying
    trot's flight) standing on every foot instead, durations unchanged: the feet landing at its
    start land at once and those lifting at its end stand until then. A pushed base in flight has
    no force to stop it with, and a landing pair that touches down while the other pair still
    stands gives the capture point (Pratt et al. 2006) the whole support polygon; the plan's goal,
    end and order of steps are unchanged, its swings shorter by the flights. The first phase is the
    one under way (or the hold of a foot in the air, already standing)."""
    stance = gait.stance.copy()
    flight = ~stance.any(axis=1)
    flight[0] = False
    if not flight.any():
        return gait
    stance[flight] = True
    return Gait(gait.name, gait.durations.copy(), stance)


def remaining_gait(gait: Gait, t: float, hold: float = AIRBORNE_HOLD, lifted: np.ndarray | None = None,
                   late_swing: float = 0.0) -> tuple[Gait, np.ndarray]:
    """The phases of `gait` after t on a time axis starting at t, and which feet are in the air at t
    (those get a first stance of `hold`, at most half of what is left of the current phase).

    `lifted` (legs,) marks feet the plan has in stance at t that stand above the terrain (a late
    touchdown, `lifted_feet`): they are in the air at t too, held, then swing down for `late_swing`
    s and stand from there on as planned (the phase under way split there); with less than that
    left of the phase under way they swing through it. A foot in the air cannot push: taken as
    standing, the replan would stand it on the terrain at once, away from where it is, and count
    on its force."""
    ends = np.cumsum(gait.durations)
    if not 0.0 <= t < ends[-1] - PHASE_END:
        raise ValueError(f"replan time {t:g} s outside the plan [0, {ends[-1]:g}) s")
    k = int(np.searchsorted(ends, t + PHASE_END, side="right"))
    durations = np.concatenate([[ends[k] - t], gait.durations[k + 1:]])
    stance = gait.stance[k:].copy()
    late = np.zeros(stance.shape[1], bool) if lifted is None else np.asarray(lifted, bool) & stance[0]
    airborne = ~stance[0] | late
    if airborne.any():
        first = min(hold, 0.5 * durations[0])
        durations = np.concatenate([[first, durations[0] - first], durations[1:]])
        stance = np.vstack([np.ones((1, stance.shape[1]), bool), stance])
    if late.any():
        if durations[1] - late_swing > PHASE_END and late_swing > PHASE_END:  # lands within the phase
            durations = np.concatenate([durations[:1], [late_swing, durations[1] - late_swing], durations[2:]])
            stance = np.vstack([stance[:2], stance[1:]])
        stance[1, late] = False
    return Gait(gait.name, durations, stance), airborne
