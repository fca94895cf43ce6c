"""The verdict a report opens with: per artefact, how many items succeeded, the headline numbers
of its kind (from `/summary`, or medians over items) and the reasons of the failed items."""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass

import numpy as np

from legplan.report.items import read_items

# kind -> (noun of an item, verb of success, [(summary row, label, scale, shown units)])
HEADLINES: dict[str, tuple[str, str, list[tuple[str, str, float, str]]]] = {
    "motion": ("steps", "succeeded", [("worst_violation", "worst slip", 1e3, "mm"),
                                      ("median_time", "median time", 1.0, "s")]),
    "nav": ("queries", "solved", [("median_effort", "median effort", 1.0, "m²/s³"),
                                  ("median_duration", "median duration", 1.0, "s"),
                                  ("median_planning_time", "median planning time", 1.0, "s")]),
    "traj": ("trajectories", "succeeded", [("max_violation", "max violation", 1.0, ""),
                                           ("median_solve_time", "median solve time", 1.0, "s")]),
    "sim": ("runs", "succeeded", [("falls", "falls", 1.0, ""),
                                  ("median_rms_position_error", "median rms position error", 1e3, "mm")]),
    "steps": ("configurations", "valid", [("configurations", "configurations", 1.0, "")]),
    "dataset": ("tasks", "converged", []),
}
ITEM_MEDIANS = {"traj": [("duration", "median duration", "s")]}
SHOWN_REASONS = 3


@dataclass(frozen=True)
class Verdict:
    outcome: str              # "12/14 steps succeeded", or "" for an artefact without items
    ok: bool | None           # every item succeeded (None: no items)
    numbers: list[str]        # "worst slip 0.95 mm", ...
    failures: list[str]       # "2 × Timeout within the 10 s budget", ...


def verdict(handle, kind: str, summary: dict[str, tuple[float, str]]) -> Verdict:
    """The verdict of one open artefact of `kind` with `/summary` rows `summary`."""
    noun, verb, rows = HEADLINES.get(kind, ("items", "succeeded", []))
    numbers = [f"{label} {_number(summary[name][0] * scale)}{' ' + units if units else ''}"
               for name, label, scale, units in rows if name in summary]
    items = list(read_items(handle).values())
    for key, label, units in ITEM_MEDIANS.get(kind, []):
        values = [item[key] for item in items if key in item and math.isfinite(item[key])]
        if values:
            numbers.append(f"{label} {_number(float(np.median(values)))} {units}")
    if not items:
        return Verdict("", None, numbers, [])
    ok = sum(item["success"] for item in items)
    reasons = Counter(item["reason"] or "no reason recorded" for item in items if not item["success"])
    failures = [f"{count} × {reason}" for reason, count in reasons.most_common(SHOWN_REASONS)]
    if len(reasons) > SHOWN_REASONS:
        failures.append(f"{sum(reasons.values()) - sum(c for _, c in reasons.most_common(SHOWN_REASONS))} more "
                        f"with {len(reasons) - SHOWN_REASONS} other reasons")
    return Verdict(f"{ok}/{len(items)} {noun} {verb}", ok == len(items), numbers, failures)


def _number(value: float) -> str:
    return f"{value:.3g}"
