"""Compare two artefacts of the same kind metric by metric, for regression runs.

Compared: every `/summary` row; per-item results (groups with a `success` attr): success of each
item present in both, items present in only one, every numeric item attr / scalar dataset (worst
item per metric) and every item array whose shape is the same in both (max |difference|, e.g.
trajectories and control points; arrays whose shapes differ are listed but not judged). A dataset or
attr that an item has in one artefact and not in the other (e.g. a step without `control_points`) is
a difference.

Tolerances are symmetric: a value is within tolerance when |b - a| <= abs + rel * max(|a|, |b|),
so swapping A and B never changes the verdict. Defaults: abs 1e-6 + rel 1e-6 for every computed
value (violations, counts, trajectories, durations, sample times). NaN equals NaN.

Clock values (`is_clock`: wall-clock readings such as `seconds`, `timings/*`, `*_seconds`,
`mean_time`, `median_solve_time`, `max_planning_time`) vary with the machine's load, so they are
listed but left out of the verdict unless `timings=True` (`--timings`); then a summary time must be
within 0.05 s + 50 % and a per-item one (one item's reading varies far more than a mean over
items) within 0.5 s + 50 %. An override that names a clock value judges it without `--timings`.

Overrides `{pattern: "50%" | "0.01"}`: a glob matched against the metric name (summary row name,
or item attr/dataset name); "N%" is relative, a plain number absolute; the last matching override
wins.
"""

from __future__ import annotations

import fnmatch
import math
import os
from dataclasses import asdict, dataclass, field

import numpy as np

from legplan.artefacts import open_artefact, read_provenance, read_summary
from legplan.errors import ArtefactError, LegplanError
from legplan.parameters import TOLERANCE, check_value
from legplan.report.items import read_items
from legplan.specio import parse_number

TIME_TOLERANCE = (0.05, 0.5)
ITEM_CLOCK_TOLERANCE = (0.5, 0.5)
TIGHT_TOLERANCE = (1e-6, 1e-6)
CLOCK_PATTERNS = ("*seconds*", "timings/*", "*/timings/*", "mean_time*", "median_time*", "max_time*",
                  "*planning_time*", "*solve_time*", "*iteration_time*", "*time_per_*")
"""Globs of the metric names that are wall-clock readings (`is_clock`); durations of planned or
simulated motions (`duration`, `total_time`, `running_time`, `t`, `dt`) are computed values."""


@dataclass(frozen=True)
class Tolerance:
    abs: float
    rel: float

    def holds(self, a: float, b: float) -> bool:
        if math.isnan(a) or math.isnan(b):
            return math.isnan(a) and math.isnan(b)
        return abs(b - a) <= self.abs + self.rel * max(abs(a), abs(b))

    def holds_all(self, a: np.ndarray, b: np.ndarray) -> bool:
        """`holds` elementwise on two arrays of one shape (NaN equals NaN)."""
        a, b = np.asarray(a, float), np.asarray(b, float)
        within = np.abs(b - a) <= self.abs + self.rel * np.maximum(np.abs(a), np.abs(b))
        return bool(np.all(within | (np.isnan(a) & np.isnan(b))))

    def __str__(self) -> str:
        parts = ([f"{self.abs:g}"] if self.abs else []) + ([f"{self.rel * 100:g}%"] if self.rel else [])
        return " + ".join(parts) or "exact"


@dataclass(frozen=True)
class MetricDiff:
    name: str
    a: float | str
    b: float | str
    ok: bool
    tolerance: str = ""
    units: str = ""
    note: str = ""
    judged: bool = True
    """False for a clock value compared without `--timings`: shown, not in the verdict."""


@dataclass
class Comparison:
    kind: str
    a: str
    b: str
    rows: list[MetricDiff] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return all(row.ok for row in self.rows if row.judged)

    def as_dict(self) -> dict:
        return {"kind": self.kind, "a": self.a, "b": self.b, "ok": self.ok,
                "rows": [asdict(row) for row in self.rows]}


def parse_tolerances(items) -> dict[str, Tolerance]:
    """`["mean_time=20%", "worst_*=1e-4"]` -> `{pattern: Tolerance}` (LegplanError on bad syntax)."""
    out = {}
    for item in items:
        name, sep, value = item.partition("=")
        try:
            if not sep or not name.strip():
                raise ValueError
            value = value.strip()
            float(value.removesuffix("%"))
        except ValueError:
            raise LegplanError(f"--tol: expected NAME=NUMBER or NAME=PERCENT%, got {item!r}") from None
        number = parse_number(value.removesuffix("%"), f"--tol {name.strip()}")  # finite, of a sane size
        check_value(number, TOLERANCE, f"--tol {name.strip()}")
        number = number / 100 if value.endswith("%") else number
        out[name.strip()] = Tolerance(0.0, number) if value.endswith("%") else Tolerance(number, 0.0)
    return out


def is_clock(name: str) -> bool:
    """Whether metric `name` is a wall-clock reading (`CLOCK_PATTERNS`)."""
    return any(fnmatch.fnmatchcase(name, pattern) for pattern in CLOCK_PATTERNS)


def _override(name: str, overrides: dict[str, Tolerance]) -> Tolerance | None:
    """The last override whose glob matches `name`."""
    chosen = None
    for pattern, tolerance in overrides.items():
        if fnmatch.fnmatchcase(name, pattern):
            chosen = tolerance
    return chosen


def tolerance_for(name: str, overrides: dict[str, Tolerance], *, item: bool = False) -> Tolerance:
    """The last override whose glob matches `name`, else the default for a clock value (summary or
    per-`item`) or any other metric."""
    chosen = _override(name, overrides)
    if chosen is not None:
        return chosen
    if is_clock(name):
        return Tolerance(*(ITEM_CLOCK_TOLERANCE if item else TIME_TOLERANCE))
    return Tolerance(*TIGHT_TOLERANCE)


def _judged(name: str, overrides: dict[str, Tolerance], timings: bool) -> bool:
    """A clock value counts in the verdict only with `timings` or an override naming it."""
    return timings or not is_clock(name) or _override(name, overrides) is not None


def _row(name: str, a, b, tolerance: Tolerance, ok: bool, judged: bool, note: str = "", units: str = "") -> MetricDiff:
    if not judged:
        note = "; ".join(filter(None, ["clock value, not judged (--timings)", note]))
    return MetricDiff(name, a, b, ok, str(tolerance), units=units, note=note, judged=judged)


def compare_artefacts(path_a: str | os.PathLike, path_b: str | os.PathLike,
                      tolerances: dict[str, Tolerance] | None = None, *, timings: bool = False) -> Comparison:
    """Metric-by-metric comparison of two artefacts; `ArtefactError` when the kinds differ. Clock
    values count in the verdict only with `timings` (or an override naming them)."""
    overrides = tolerances or {}
    with open_artefact(path_a) as fa, open_artefact(path_b) as fb:
        kind_a, kind_b = read_provenance(fa)["kind"], read_provenance(fb)["kind"]
        if kind_a != kind_b:
            raise ArtefactError(f"{path_b}: is a '{kind_b}' artefact, cannot compare with {path_a} ('{kind_a}')")
        summary_a, summary_b = read_summary(fa), read_summary(fb)
        items_a, items_b = read_items(fa), read_items(fb)
    result = Comparison(kind_a, str(path_a), str(path_b))
    for name in [*summary_a, *(n for n in summary_b if n not in summary_a)]:
        if name not in summary_a or name not in summary_b:
            side = "B" if name not in summary_a else "A"
            result.rows.append(MetricDiff(name, summary_a.get(name, ("-",))[0], summary_b.get(name, ("-",))[0],
                                          False, note=f"only in {side}"))
            continue
        (a, units), (b, _) = summary_a[name], summary_b[name]
        tolerance = tolerance_for(name, overrides)
        result.rows.append(_row(name, a, b, tolerance, tolerance.holds(a, b), _judged(name, overrides, timings),
                                units=units))
    if items_a or items_b:
        result.rows.extend(_item_rows(items_a, items_b, overrides, timings))
    return result


def _item_rows(items_a: dict, items_b: dict, overrides, timings: bool) -> list[MetricDiff]:
    rows = []
    only = sorted(set(items_a) ^ set(items_b))
    common = [name for name in items_a if name in items_b]
    ok_a = sum(item["success"] for item in items_a.values())
    ok_b = sum(item["success"] for item in items_b.values())
    rows.append(MetricDiff("items succeeded", f"{ok_a}/{len(items_a)}", f"{ok_b}/{len(items_b)}",
                           ok_a == ok_b and len(items_a) == len(items_b)))
    if only:
        rows.append(MetricDiff("items in one artefact only", len(set(items_a) - set(items_b)),
                               len(set(items_b) - set(items_a)), False, note=", ".join(only[:5])))
    flipped = [name for name in common if items_a[name]["success"] != items_b[name]["success"]]
    for name in flipped:
        a, b = items_a[name], items_b[name]
        rows.append(MetricDiff(f"{name} success", str(a["success"]), str(b["success"]), False,
                               note=b["reason"] or a["reason"]))
    rows.extend(_missing_rows(items_a, items_b, common))
    keys = sorted({key for name in common for key in items_a[name]
                   if key not in ("success", "reason", "arrays", "units") and key in items_b[name]})
    for key in keys:
        tolerance = tolerance_for(key, overrides, item=True)
        pairs = [(name, items_a[name][key], items_b[name][key]) for name in common
                 if key in items_a[name] and key in items_b[name]]
        bad = [(name, a, b) for name, a, b in pairs if not tolerance.holds(a, b)]
        name, a, b = bad[0] if bad else max(pairs, key=lambda p: _gap(p[1], p[2]))
        note = f"{len(bad)} of {len(pairs)} items differ, first {name}" if bad else f"largest at {name}"
        rows.append(_row(f"item {key}", a, b, tolerance, not bad, _judged(key, overrides, timings), note))
    arrays = sorted({key for name in common for key in items_a[name]["arrays"] if key in items_b[name]["arrays"]})
    for key in arrays:
        tolerance = tolerance_for(key, overrides, item=True)
        same = [(name, items_a[name]["arrays"][key], items_b[name]["arrays"][key]) for name in common
                if key in items_a[name]["arrays"] and key in items_b[name]["arrays"]]
        shaped = [(name, a, b) for name, a, b in same if a.shape == b.shape]
        gaps = [(float(np.max(np.abs(b.astype(float) - a.astype(float)), initial=0.0)), name) for name, a, b in shaped]
        worst, where = max(gaps, default=(0.0, ""))
        within = all(tolerance.holds_all(a, b) for _, a, b in shaped)
        note = f"max |Δ| over {len(shaped)} items" + (f" at {where}" if where else "")
        if len(shaped) < len(same):
            note += f"; {len(same) - len(shaped)} with different shapes not compared"
        rows.append(_row(f"item {key} (array)", 0.0, worst, tolerance, within, _judged(key, overrides, timings), note))
    return rows


def _missing_rows(items_a: dict, items_b: dict, common: list[str]) -> list[MetricDiff]:
    """One failing row per item attr / dataset that some item has in only one of the artefacts:
    columns A and B count the items missing it there."""
    missing: dict[str, tuple[list[str], list[str]]] = {}
    for name in common:
        a, b = _fields(items_a[name]), _fields(items_b[name])
        for key in b - a:
            missing.setdefault(key, ([], []))[0].append(name)
        for key in a - b:
            missing.setdefault(key, ([], []))[1].append(name)
    return [MetricDiff(f"item {key} missing", len(in_a), len(in_b), False,
                       note=f"missing in {'A' if in_a else 'B'} at {(in_a or in_b)[0]}")
            for key, (in_a, in_b) in sorted(missing.items())]


def _fields(item: dict) -> set[str]:
    """Names of an item's numeric attrs, scalar datasets and arrays."""
    return {key for key in item if key not in ("success", "reason", "arrays", "units")} | set(item["arrays"])


def _gap(a: float, b: float) -> float:
    return 0.0 if math.isnan(a) and math.isnan(b) else math.inf if math.isnan(a) or math.isnan(b) else abs(b - a)
