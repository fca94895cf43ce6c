"""A step sequence (Bézier paper eq. (2)): configurations q_1..q_k with stance flags and footholds.

steps.h5 (kind "steps"):
  /q          (k, nq)        pinocchio order (free-flyer position, quaternion x y z w, joints)
  /stance     (k, n_legs)    bool
  /footholds  (k, n_legs, 3) m, NaN for swing legs
  root attrs  robot, robot_sha256, leg_names (JSON), joint_names (JSON)
  /checks     com_margin, clearance, foot_gap per configuration (validator); when judged also
              shortfall_<constraint> (k,) and root attr requirements (JSON, `legplan.validate.judge`)
  /summary    configurations, legs, min CoM margin, min clearance, worst foot gap; when judged the
              worst shortfall and the tolerance of each constraint
"""

from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np

from legplan.artefacts import check_finite, open_artefact, read_array, write_artefact, write_dataset, write_summary
from legplan.errors import ArtefactError
from legplan.validate.judge import CONSTRAINTS


@dataclass
class StepSequence:
    """k configurations of one robot; `footholds` rows of swing legs are NaN."""

    q: np.ndarray
    stance: np.ndarray
    footholds: np.ndarray
    robot: str
    robot_sha256: str
    leg_names: tuple[str, ...]
    joint_names: tuple[str, ...]

    def __post_init__(self):
        self.q = np.asarray(self.q, float)
        self.stance = np.asarray(self.stance, bool)
        self.footholds = np.asarray(self.footholds, float)
        self.leg_names = tuple(self.leg_names)
        self.joint_names = tuple(self.joint_names)
        k = len(self.q)
        if self.stance.shape != (k, len(self.leg_names)):
            raise ValueError(f"stance must be ({k}, {len(self.leg_names)}), got {self.stance.shape}")
        if self.footholds.shape != (k, len(self.leg_names), 3):
            raise ValueError(f"footholds must be ({k}, {len(self.leg_names)}, 3), got {self.footholds.shape}")

    def __len__(self) -> int:
        return len(self.q)


def summary_metrics(checks) -> dict:
    """The /summary rows of steps.h5 from the validator's `ConfigChecks`."""
    return {
        "configurations": len(checks.com),
        "legs": checks.foot_gap.shape[1],
        "min_com_margin": (float(np.min(checks.com_margin)), "m"),
        "min_clearance": (float(np.min(checks.clearance)), "m"),
        "worst_foot_gap": (float(np.max(checks.worst_foot_gap)), "m"),
    }


def write_steps(path, seq: StepSequence, checks, *, params=None, seed=None, inputs=(),
                overwrite: bool = False, extra=None, judged=None) -> None:
    """Write steps.h5 atomically; `extra(f)` may add datasets (e.g. per-configuration checks);
    `judged` = (shortfalls {constraint: (k,)}, `Requirements`) of `legplan.validate.judge`."""
    summary = summary_metrics(checks)
    with write_artefact(path, "steps", params=params, seed=seed, inputs=inputs, overwrite=overwrite) as f:
        f.attrs["robot"] = seq.robot
        f.attrs["robot_sha256"] = seq.robot_sha256
        f.attrs["leg_names"] = json.dumps(list(seq.leg_names))
        f.attrs["joint_names"] = json.dumps(list(seq.joint_names))
        write_dataset(f, "q", seq.q, units="m|quaternion|rad",
                      description="pinocchio order: base position, base quaternion (x y z w), joints")
        write_dataset(f, "stance", seq.stance.astype(np.uint8), units="bool")
        write_dataset(f, "footholds", seq.footholds, units="m")
        checks_group = f.create_group("checks")
        write_dataset(checks_group, "com_margin", checks.com_margin, units="m")
        write_dataset(checks_group, "clearance", checks.clearance, units="m")
        write_dataset(checks_group, "foot_gap", checks.foot_gap, units="m")
        if judged is not None:
            shortfalls, required = judged
            f.attrs["requirements"] = json.dumps(required.as_dict())
            for name, value in shortfalls.items():
                write_dataset(checks_group, f"shortfall_{name}", value, units=CONSTRAINTS[name],
                              tolerance=required.tolerances()[name])
                summary[f"worst_shortfall_{name}"] = (float(np.max(value)), CONSTRAINTS[name])
                summary[f"tolerance_{name}"] = (required.tolerances()[name], CONSTRAINTS[name])
        if extra is not None:
            extra(f)
        write_summary(f, summary)


QUATERNION_TOLERANCE = 1e-6
"""How far from 1 the norm of a stored base quaternion may be (steps.h5 holds normalised ones)."""


def read_steps(path) -> StepSequence:
    """Read steps.h5 (validating kind and schema) and check its arrays at the boundary: `/q` finite
    with unit base quaternions, the shapes agreeing with the leg and joint names, stance footholds
    finite. Any problem is an `ArtefactError` naming the file and the dataset (and row)."""
    with open_artefact(path, kind="steps") as f:
        try:
            leg_names = json.loads(f.attrs["leg_names"])
            joint_names = json.loads(f.attrs["joint_names"])
            robot, sha = str(f.attrs["robot"]), str(f.attrs["robot_sha256"])
        except KeyError as exc:
            raise ArtefactError(f"{path}: missing root attribute {exc.args[0]!r}") from None
        except (TypeError, ValueError):
            raise ArtefactError(f"{path}: root attributes 'leg_names'/'joint_names' must be JSON lists") from None
        q = read_array(f, "q", ndim=2)
        stance = read_array(f, "stance", ndim=2).astype(bool)
        footholds = read_array(f, "footholds", ndim=3, finite=False)
    k, legs = len(q), len(leg_names)
    expected = {"q": (k, 7 + len(joint_names)), "stance": (k, legs), "footholds": (k, legs, 3)}
    for name, array in (("q", q), ("stance", stance), ("footholds", footholds)):
        if array.shape != expected[name]:
            raise ArtefactError(f"{path}: dataset '/{name}' has shape {array.shape}, expected "
                                f"{expected[name]} ({k} configurations, {legs} legs, {len(joint_names)} joints)")
    check_finite(f"{path}: dataset '/footholds' (stance legs)", footholds[stance])
    norms = np.linalg.norm(q[:, 3:7], axis=1)
    bad = np.flatnonzero(np.abs(norms - 1.0) > QUATERNION_TOLERANCE)
    if bad.size:
        raise ArtefactError(f"{path}: dataset '/q' row {bad[0]}: base quaternion norm {norms[bad[0]]:.6g}, expected 1")
    return StepSequence(q=q, stance=stance, footholds=footholds, robot=robot, robot_sha256=sha,
                        leg_names=leg_names, joint_names=joint_names)
