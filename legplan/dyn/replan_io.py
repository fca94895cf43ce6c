"""The inputs of `legplan dyn replan`: the measured state file and the previous plan in a traj.h5.

A state file is a YAML (or JSON) mapping, every field required but `task` and `contact`:

    t: 1.2                        # s, on the plan's clock: inside [0, duration) of the task
    task: 0                       # which task of TRAJ (its index; default 0)
    base_pos: [-0.41, 0.02, 0.47] # m, the base origin in the world
    base_euler: [0.0, 0.01, 0.0]  # rad, roll, pitch, yaw
    base_vel: [0.30, 0.05, 0.0]   # m/s
    base_ang_vel: [0.0, 0.0, 0.1] # rad/s, world frame
    feet_pos: [[...], [...], [...], [...]]  # m, one xyz per leg in TRAJ's `legs` order
    contact: [true, true, false, true]      # the feet the robot senses on the ground, per leg (default:
                                            # not sensed; a planned stance foot sensed off the ground
                                            # above the terrain is a late touchdown, `lifted_feet`)

Every problem is one line naming the file and the field (`legplan.specio.FieldReader`).
"""

from __future__ import annotations

from dataclasses import fields

import numpy as np

from legplan.dyn.replan import MeasuredState, Previous
from legplan.dyn.settings import DynParams
from legplan.specio import override
from legplan.errors import LegplanError
from legplan.specio import FieldReader, read_yaml_mapping

VECTORS = ("base_pos", "base_euler", "base_vel", "base_ang_vel")
STATE_FIELDS = ("t", "task", *VECTORS, "feet_pos", "contact")


def read_state(path, legs: int) -> tuple[int, MeasuredState]:
    """The task index and the `MeasuredState` of a state file (module docstring)."""
    data = read_yaml_mapping(path, "state file")
    reader = FieldReader(path)
    for key in data:
        if key not in STATE_FIELDS:
            reader.fail(str(key), f"is unknown (known: {', '.join(STATE_FIELDS)})")
    task = reader.get(data, "task", "task", default=0)
    if isinstance(task, bool) or not isinstance(task, int) or task < 0:
        reader.fail("task", f"must be a task index (an integer >= 0), got {task!r}")
    t = reader.number(reader.get(data, "t", "t"), "t", "[0, inf)")
    vectors = {name: _vector(reader, data, name, 3) for name in VECTORS}
    feet = reader.get(data, "feet_pos", "feet_pos", list)
    if len(feet) != legs:
        reader.fail("feet_pos", f"must list {legs} feet (one xyz each), got {len(feet)}")
    feet_pos = np.array([_numbers(reader, foot, f"feet_pos[{k}]", 3) for k, foot in enumerate(feet)])
    contact = reader.get(data, "contact", "contact", default=None)
    if contact is not None and (not isinstance(contact, list) or len(contact) != legs
                                or not all(isinstance(c, bool) for c in contact)):
        reader.fail("contact", f"must list {legs} booleans (one per leg, true: on the ground), got {contact!r}")
    return task, MeasuredState(t, feet_pos=feet_pos, contact=contact, **vectors)


def _vector(reader: FieldReader, data: dict, name: str, size: int) -> np.ndarray:
    return np.array(_numbers(reader, reader.get(data, name, name), name, size))


def _numbers(reader: FieldReader, value, field: str, size: int) -> list[float]:
    if not isinstance(value, list) or len(value) != size:
        reader.fail(field, f"must be a list of {size} numbers, got {value!r}")
    return [reader.number(v, f"{field}[{k}]") for k, v in enumerate(value)]


def check_state_time(path, state: MeasuredState, duration: float) -> None:
    """A one-line error naming the state file's field 't' unless t lies inside the plan."""
    from legplan.dyn.rest_gait import PHASE_END

    if not state.t < duration - PHASE_END:
        raise LegplanError(f"{path}: field 't' {state.t:g} s is not inside the plan's [0, {duration:g}) s")


def traj_task(path, tasks: list[dict], index: int, state_path) -> dict:
    """The task of a traj.h5 the state file names, solved (it has nodes to shift), or a one-line error."""
    chosen = [task for task in tasks if int(task["index"]) == index]
    if not chosen:
        raise LegplanError(f"{state_path}: field 'task' {index}: {path} has no such task "
                           f"(it has {', '.join(str(int(t['index'])) for t in tasks)})")
    if "nodes" not in chosen[0] or not bool(chosen[0]["solved"]):
        raise LegplanError(f"{path}: task {index} has no solved plan to replan")
    return chosen[0]


def recorded_params(settings: dict) -> DynParams:
    """The `DynParams` a traj.h5's root `params` records (`settings.settings_record`'s "dyn")."""
    flat: dict = {}

    def walk(prefix: str, value) -> None:
        if isinstance(value, dict):
            for key, inner in value.items():
                walk(f"{prefix}{key}.", inner)
        else:
            flat[prefix[:-1]] = tuple(value) if isinstance(value, list) else value

    walk("", settings.get("dyn", {}))
    known = {f.name for f in fields(DynParams)}
    return override(DynParams(), {k: v for k, v in flat.items() if k.partition(".")[0] in known},
                    FieldReader("traj params"))


def previous_of(task: dict, model, params: DynParams) -> Previous:
    return Previous.from_record(task, model.com_offset, params.dt)
