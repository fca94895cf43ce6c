"""Import a step-sequence file: parse records, check every configuration, report issues by row.

Structural checks (per record): missing/extra fields, wrong joint count, unknown joint or leg
names, non-numeric values, quaternion norm (normalised with a warning when within 1e-6 of 1).
Physical checks (independent `Validator`, pinocchio + FCL): joints within limits, stance feet on the
terrain (|distance| <= foot_tolerance), on their explicit footholds, at least 3 stance legs, CoM
inside the support polygon, no sphere in collision, and consecutive stance sets differing by at
most one leg (the sequence of eq. (2) switches one leg at a time). Warnings (errors under
`strict`): normalised quaternions, CoM margin or clearance positive but below the planning margins.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from legplan.errors import SpecError
from legplan.parameters import magnitude_problem
from legplan.stepseq.records import read_records
from legplan.stepseq.robotinfo import robot_reference
from legplan.stepseq.sequence import StepSequence

QUATERNION_KEYS = ("qx", "qy", "qz", "qw")
RPY_KEYS = ("roll", "pitch", "yaw")
UNIT_TOLERANCE = 1e-6
EXACT_UNIT = 1e-12


@dataclass(frozen=True)
class Issue:
    """One problem of one configuration: row index (0-based), field name, message, severity."""

    row: int
    field: str
    message: str
    severity: str = "error"

    def __str__(self) -> str:
        return f"row {self.row}: field '{self.field}': {self.message}"


@dataclass
class ImportLimits:
    """Tolerances of the physical checks (m) and the planning margins below which we warn."""

    foot_tolerance: float = 1e-3
    min_stance_legs: int = 3
    com_margin_warning: float = 0.0
    clearance_warning: float = 0.0


@dataclass
class ImportResult:
    sequence: StepSequence | None
    checks: object | None
    issues: list[Issue] = field(default_factory=list)

    def errors(self, strict: bool = False) -> list[Issue]:
        return [i for i in self.issues if i.severity == "error" or strict]


def _number(value, row: int, name: str, issues: list[Issue]) -> float:
    """A finite number, or NaN with an issue naming the row and field (NaN, inf, text, bool)."""
    try:
        out = float(value) if not isinstance(value, bool) else math.nan
    except (TypeError, ValueError):
        out = math.nan
    if not math.isfinite(out):
        issues.append(Issue(row, name, f"must be a finite number, got {value!r}"))
        return math.nan
    if magnitude_problem(out):
        issues.append(Issue(row, name, f"{magnitude_problem(out)}, got {value!r}"))
        return math.nan
    return out


def _flag(value, row: int, name: str, issues: list[Issue]) -> bool:
    if isinstance(value, bool):
        return value
    text = str(value).strip().lower()
    if text in ("1", "1.0", "true", "yes"):
        return True
    if text in ("0", "0.0", "false", "no"):
        return False
    issues.append(Issue(row, name, f"stance flag must be 0/1 or true/false, got {value!r}"))
    return False


def orientation_quaternion(record: dict, row: int, issues: list[Issue]) -> np.ndarray:
    """Quaternion (x, y, z, w) from qx..qw or roll/pitch/yaw (R = Rz(yaw) Ry(pitch) Rx(roll))."""
    has_q = [k in record for k in QUATERNION_KEYS]
    has_r = [k in record for k in RPY_KEYS]
    if any(has_q) and any(has_r):
        issues.append(Issue(row, "orientation", "give either qx,qy,qz,qw or roll,pitch,yaw, not both"))
        return np.array([0.0, 0.0, 0.0, 1.0])
    if any(has_r):
        missing = [k for k, h in zip(RPY_KEYS, has_r, strict=True) if not h]
        if missing:
            issues.append(Issue(row, missing[0], "missing (orientation given as roll, pitch, yaw)"))
            return np.array([0.0, 0.0, 0.0, 1.0])
        rpy = np.array([_number(record[k], row, k, issues) for k in RPY_KEYS])
        if not np.all(np.isfinite(rpy)):
            return np.array([0.0, 0.0, 0.0, 1.0])
        return pin.Quaternion(pin.rpy.rpyToMatrix(rpy)).coeffs().copy()
    missing = [k for k, h in zip(QUATERNION_KEYS, has_q, strict=True) if not h]
    if missing:
        issues.append(Issue(row, missing[0], "missing (orientation needs qx,qy,qz,qw or roll,pitch,yaw)"))
        return np.array([0.0, 0.0, 0.0, 1.0])
    quat = np.array([_number(record[k], row, k, issues) for k in QUATERNION_KEYS])
    norm = float(np.linalg.norm(quat))
    if not np.isfinite(norm):
        return np.array([0.0, 0.0, 0.0, 1.0])
    if abs(norm - 1.0) > UNIT_TOLERANCE:
        issues.append(Issue(row, "qw", f"quaternion norm {norm:.9g} is not 1 (tolerance {UNIT_TOLERANCE:g})"))
        return np.array([0.0, 0.0, 0.0, 1.0])
    if abs(norm - 1.0) > EXACT_UNIT:
        issues.append(Issue(row, "qw", f"quaternion norm {norm:.12g} normalised to 1", "warning"))
        quat = quat / norm
    return quat


def _joint_values(record: dict, row: int, robot, urdf_order, issues: list[Issue]) -> np.ndarray:
    """Joint angles in pinocchio order from names, a `joints` list or j0.. columns (URDF order)."""
    names = list(robot.joint_names)
    pin_index = {name: i for i, name in enumerate(names)}
    out = np.full(len(names), math.nan)
    ordered = record.get("joints")
    indexed = sorted((k for k in record if re.fullmatch(r"j\d+", k)), key=lambda k: int(k[1:]))
    if ordered is not None or indexed:
        values = ordered if ordered is not None else [record[k] for k in indexed]
        if not isinstance(values, (list, tuple)) or len(values) != len(names):
            count = len(values) if isinstance(values, (list, tuple)) else 1
            issues.append(Issue(row, "joints", f"wrong dimension: {count} joint values, "
                                f"robot {robot.name} has {len(names)}"))
            return out
        for name, value in zip(urdf_order, values, strict=True):
            out[pin_index[name]] = _number(value, row, "joints", issues)
        return out
    for name in names:
        if name in record:
            out[pin_index[name]] = _number(record[name], row, name, issues)
    given = sum(name in record for name in names)
    if given != len(names):
        missing = [n for n in names if n not in record]
        issues.append(Issue(row, missing[0], f"wrong dimension: {given} of {len(names)} joints given "
                            f"(missing {', '.join(missing[:4])}{'...' if len(missing) > 4 else ''})"))
    return out


def _known_fields(robot) -> set[str]:
    legs = [leg.name for leg in robot.legs]
    fields = {"x", "y", "z", "joints", *QUATERNION_KEYS, *RPY_KEYS, *robot.joint_names}
    fields |= {f"stance_{leg}" for leg in legs}
    fields |= {f"foothold_{leg}_{a}" for leg in legs for a in "xyz"}
    return fields


def parse_records(records: list[dict], robot, urdf_order) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[Issue]]:
    """Records -> q (k, nq), stance (k, L), footholds (k, L, 3) (NaN unknown) and issues."""
    issues: list[Issue] = []
    legs = [leg.name for leg in robot.legs]
    known = _known_fields(robot)
    k = len(records)
    Q = np.full((k, robot.nq), math.nan)
    stance = np.zeros((k, len(legs)), bool)
    footholds = np.full((k, len(legs), 3), math.nan)
    for row, record in enumerate(records):
        for name in record:
            if name not in known and not re.fullmatch(r"j\d+", name):
                what = "joint" if not name.startswith(("stance_", "foothold_")) else "leg"
                issues.append(Issue(row, name, f"unknown {what} name for robot {robot.name}"))
        for i, axis in enumerate("xyz"):
            if axis not in record:
                issues.append(Issue(row, axis, "missing base position"))
            else:
                Q[row, i] = _number(record[axis], row, axis, issues)
        Q[row, 3:7] = orientation_quaternion(record, row, issues)
        Q[row, 7:] = _joint_values(record, row, robot, urdf_order, issues)
        for j, leg in enumerate(legs):
            key = f"stance_{leg}"
            if key not in record:
                issues.append(Issue(row, key, "missing stance flag"))
                continue
            stance[row, j] = _flag(record[key], row, key, issues)
            if stance[row, j]:
                point = [record.get(f"foothold_{leg}_{a}") for a in "xyz"]
                if any(p is not None for p in point):
                    footholds[row, j] = [_number(p, row, f"foothold_{leg}_{a}", issues)
                                         for p, a in zip(point, "xyz", strict=True)]
    return Q, stance, footholds, issues


def physical_issues(checks, stance, limits: ImportLimits, robot, explicit) -> list[Issue]:
    """Issues of the validator results (see module docstring), row by row."""
    issues: list[Issue] = []
    legs = [leg.name for leg in robot.legs]
    for row in range(len(stance)):
        for j in np.flatnonzero(checks.joint_excess[row] > 0):
            issues.append(Issue(row, robot.joint_names[j], f"joint outside its limits by "
                                f"{checks.joint_excess[row, j]:.4g} rad"))
        n_stance = int(stance[row].sum())
        if n_stance < limits.min_stance_legs:
            issues.append(Issue(row, "stance", f"{n_stance} stance legs, at least "
                                f"{limits.min_stance_legs} are needed"))
        for j in np.flatnonzero(stance[row]):
            gap = checks.foot_gap[row, j]
            if abs(gap) > limits.foot_tolerance:
                issues.append(Issue(row, f"stance_{legs[j]}", f"stance foot {gap * 1e3:+.2f} mm from the "
                                    f"terrain surface (tolerance {limits.foot_tolerance * 1e3:g} mm)"))
            slip = checks.foot_slip[row, j]
            if explicit[row, j] and slip > limits.foot_tolerance:
                issues.append(Issue(row, f"foothold_{legs[j]}_x", f"stance foot {slip * 1e3:.2f} mm from "
                                    f"its foothold (tolerance {limits.foot_tolerance * 1e3:g} mm)"))
        margin = checks.com_margin[row]
        if n_stance >= limits.min_stance_legs:
            if margin < 0:
                issues.append(Issue(row, "com", f"CoM {-margin * 1e3:.1f} mm outside the support polygon"))
            elif margin < limits.com_margin_warning:
                issues.append(Issue(row, "com", f"CoM only {margin * 1e3:.1f} mm inside the support "
                                    f"polygon (< {limits.com_margin_warning * 1e3:g} mm)", "warning"))
        clearance = checks.clearance[row]
        if clearance < 0:
            issues.append(Issue(row, "spheres", f"collision sphere {int(checks.clearance_sphere[row])} "
                                f"penetrates the terrain by {-clearance * 1e3:.1f} mm"))
        elif clearance < limits.clearance_warning:
            issues.append(Issue(row, "spheres", f"clearance {clearance * 1e3:.1f} mm below "
                                f"{limits.clearance_warning * 1e3:g} mm", "warning"))
        if row > 0:
            changed = np.flatnonzero(stance[row] != stance[row - 1])
            if len(changed) > 1:
                issues.append(Issue(row, "stance", f"stance set differs from row {row - 1} in "
                                    f"{len(changed)} legs ({', '.join(legs[j] for j in changed)}); "
                                    "at most one may change"))
    return issues


def import_steps(path, robot, validator, *, urdf_order, robot_sha256: str,
                 limits: ImportLimits = ImportLimits()) -> ImportResult:
    """Parse and check a step-sequence file; `sequence` is None when a structural error occurred."""
    records = read_records(path)
    if not records:
        raise SpecError(f"{path}: no configurations")
    Q, stance, footholds, issues = parse_records(records, robot, urdf_order)
    if any(i.severity == "error" for i in issues):
        return ImportResult(None, None, issues)
    explicit = np.all(np.isfinite(footholds), axis=2)
    checks = validator.check(Q, stance, footholds)
    issues += physical_issues(checks, stance, limits, robot, explicit)
    filled = np.where(explicit[..., None], footholds, checks.foot_positions)
    filled[~stance] = np.nan
    seq = StepSequence(q=Q, stance=stance, footholds=filled, robot=robot_reference(robot),
                       robot_sha256=robot_sha256, leg_names=[leg.name for leg in robot.legs], joint_names=robot.joint_names)
    issues.sort(key=lambda i: i.row)
    return ImportResult(seq, checks, issues)
