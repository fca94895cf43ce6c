"""`legplan dyn simulate TRAJ MAP -o sim.h5`: execute planned trajectories in MuJoCo (kind "sim").

    legplan dyn simulate traj.h5 map.h5 -o sim.h5 --jobs 2

    legplan dyn simulate traj.h5 map.h5 -o sim.h5 --push 1.2 0 150 0.02 --friction-scale 0.8

Registered on the `dyn` group (`legplan.cli.dyn_cmd`). Every task of TRAJ whose plan succeeded runs
through `legplan.sim.simulate` (whole-body controller at 400 Hz, paper Sec. III-B/C); a task whose
plan did not succeed is recorded as skipped, not executed. Exit 1 when any task fails (fell, missed
the goal, skipped, or had nothing to execute), 2 on bad input — including a robot whose MuJoCo
model cannot be built (an unresolvable `package://`, a missing mesh, an inertia that cannot be
repaired, a joint without an effort limit): the model is built once before any task runs.
"""

from __future__ import annotations

import logging
import math
import os

import click

from legplan.cli.console import status, stderr_line
from legplan.cli.main import EXIT_ITEMS_FAILED
from legplan.cli.options import (NumbersOption, batch_opts, input_artefact, number, output_opt, overwrite_opt,
                                 param_opt, verbosity_opts)
from legplan.errors import LegplanError
from legplan.parameters import DURATION, FACTOR, FRICTION, WAIT

log = logging.getLogger("legplan.sim")


class JointValue(click.ParamType):
    """`PATTERN=VALUE`: a joint-name glob pattern and a positive finite number."""

    name = "joint=value"

    def convert(self, value, param, ctx):
        if isinstance(value, tuple):
            return value
        pattern, _, number_text = str(value).rpartition("=")
        try:
            number_value = float(number_text)
        except ValueError:
            number_value = float("nan")
        if not pattern or not (math.isfinite(number_value) and number_value > 0):
            self.fail(f"{value!r} is not JOINT=VALUE with a joint name (or glob pattern) and a positive number",
                      param, ctx)
        return pattern, number_value


@click.command("simulate")
@click.argument("traj_path", metavar="TRAJ", type=input_artefact)
@click.argument("map_path", metavar="MAP", type=input_artefact)
@click.option("--settle", type=number(WAIT), default=0.5, show_default=True,
              help="Seconds the final pose is held after the plan before the goal is judged.")
@click.option("--friction", type=number(FRICTION), default=None,
              help="Friction coefficient of the simulated contacts and the controller [default: the robot's, "
                   "as planned].")
@click.option("--push", "pushes", cls=NumbersOption, counts=(4,), multiple=True, metavar="T FX FY DURATION",
              help="A horizontal push on the trunk: force (FX, FY) N in the world frame from T s (the plan's "
                   "clock) for DURATION s. Repeatable.")
@click.option("--friction-scale", type=number(FACTOR), default=1.0, show_default=True,
              help="Multiplies the simulated friction only (the controller keeps the planned μ).")
@click.option("--mass-scale", type=number(FACTOR), default=1.0, show_default=True,
              help="Multiplies every simulated mass and inertia (the controller keeps the URDF's).")
@click.option("--urdf-collision/--no-urdf-collision", default=False, show_default=True,
              help="Let the URDF's own collision geometry touch the terrain too (robot.yaml's spheres always do).")
@click.option("--package-path", "package_paths", multiple=True,
              type=click.Path(exists=True, file_okay=False, dir_okay=True),
              help="A folder searched for the ROS packages of `package://` meshes, before the folders above the "
                   "URDF and ROS_PACKAGE_PATH. Repeatable.")
@click.option("--effort", "efforts", type=JointValue(), multiple=True, metavar="JOINT=N·M",
              help="Joint torque limit replacing the URDF's (e.g. a placeholder 1000): a joint name or glob "
                   "pattern, e.g. '*_KFE=2.7'. Repeatable; the last match wins.")
@click.option("--velocity", "velocities", type=JointValue(), multiple=True, metavar="JOINT=RAD/S",
              help="Joint velocity limit replacing the URDF's, as --effort. Repeatable.")
@click.option("--replan", "replan_period", type=number(DURATION), default=None, metavar="PERIOD",
              help="Closed loop: replan the rest of the motion from the simulated state every PERIOD s "
                   "(legplan.dyn.replan) and track the new plan; the simulation waits for each replan; every "
                   "replan (state, iterations, CPU seconds, violation, success, tracked) recorded in sim.h5's "
                   "replans/.")
@param_opt("With --replan: a replan parameter (legplan.dyn.replan.ReplanParams), e.g. --param "
           "tube_velocity=0.3 (replan at once when the base's velocity error exceeds it) or "
           "--param max_iterations=15.")
@output_opt
@overwrite_opt
@batch_opts
@verbosity_opts
@click.pass_context
def simulate_cmd(ctx, traj_path, map_path, settle, friction, pushes, friction_scale, mass_scale, urdf_collision,
                 package_paths, efforts, velocities, replan_period, params, output, overwrite, jobs, scheduler,
                 resume):
    """Execute every trajectory of TRAJ on MAP in MuJoCo under the whole-body controller; write sim.h5.

    Success: no fall (base below half its nominal height above the terrain, tilted > 0.8 rad, or the
    trunk on the terrain) and the base within 10 cm and 0.2 rad (yaw) of the task's goal after the plan and --settle.
    A task whose plan did not succeed is recorded as skipped, not executed. Contacts: robot.yaml's
    collision spheres (and the URDF's collision geometry with --urdf-collision). Joint velocity limits
    are enforced by the motors and the controller; a QP the controller cannot solve falls back to a
    relaxed QP (counted per task)."""
    import numpy as np

    from legplan.artefacts import check_output
    from legplan.artefacts.identity import check_same_map
    from legplan.robots.identity import check_same_robot
    from legplan.batch import Task
    from legplan.cli.batching import run_stage
    from legplan.dyn.artefact import check_executable, read_tasks
    from legplan.robots import load_robot
    from legplan.sim.artefact import write_sim
    from legplan.sim.items import SimWorker, failed_item, sim_items, simulate_item
    from legplan.sim.model import ModelOptions, build_model
    from legplan.sim.run import SimParams
    from legplan.terrain import load_map

    from legplan.dyn.replan import ReplanParams
    from legplan.specio import apply_overrides

    if params and replan_period is None:
        raise click.UsageError("--param sets replan parameters: it needs --replan PERIOD")
    replan_settings = apply_overrides(ReplanParams, params, "--param", "replan")
    check_output(output, overwrite)
    attrs, tasks = read_tasks(traj_path)
    if not tasks:
        raise LegplanError(f"{traj_path}: no tasks")
    robot = load_robot(str(attrs["robot"]))
    if "robot_sha256" in attrs:
        check_same_robot(traj_path, str(attrs["robot_sha256"]), robot, what="planned")
    if robot.centroidal is None:
        raise LegplanError(f"{traj_path}: robot {robot.name} has no centroidal section")
    terrain_map = load_map(map_path)
    check_same_map(traj_path, map_path, what="planned")
    lo = np.array(terrain_map.grid.origin)
    hi = lo + terrain_map.grid.resolution * (np.array(terrain_map.grid.shape[::-1]) - 1)
    for task in tasks:
        check_executable(traj_path, task)
        if "samples" in task:
            xy = np.concatenate([task["samples"]["base_pos"][:, :2], task["samples"]["feet_pos"][..., :2].reshape(-1, 2)])
            if np.any(xy < lo) or np.any(xy > hi):
                raise LegplanError(f"{traj_path}: task {int(task['index'])}: trajectory leaves the map {map_path}")
    options = ModelOptions(urdf_collision=urdf_collision,
                           package_paths=tuple(os.path.abspath(p) for p in package_paths),
                           effort=tuple(efforts), velocity=tuple(velocities))
    sim_params = SimParams(settle=settle, friction=friction, friction_scale=friction_scale, mass_scale=mass_scale,
                       pushes=tuple(tuple(p) for p in pushes), model=options)
    model = build_model(robot, terrain_map, robot.centroidal.friction if friction is None else friction, options)
    for warning in model.warnings:
        log.warning(warning)
    settings = {"settle": settle, "friction": friction, "friction_scale": friction_scale, "mass_scale": mass_scale,
                "pushes": [list(p) for p in pushes], "urdf_collision": urdf_collision,
                "package_paths": list(options.package_paths), "effort": [list(e) for e in efforts],
                "velocity": [list(v) for v in velocities], "traj": str(traj_path)}
    replan = None
    if replan_period is not None:
        import json

        from legplan.dyn.replan_io import recorded_params

        replan = (replan_period, recorded_params(json.loads(attrs.get("params", "{}"))), replan_settings)
        settings["replan"] = replan_period
        settings["replan_params"] = dict(params)
    task = Task(simulate_item, failed_item, SimWorker,
                (str(attrs["robot"]), os.path.abspath(map_path), sim_params, replan))
    records, _ = run_stage(task, sim_items(tasks), "dyn simulate", output=output,
                           identity={"stage": "dyn simulate", "params": settings}, inputs=[traj_path, map_path],
                           jobs=jobs, scheduler=scheduler, resume=resume, overwrite=overwrite,
                           publish=lambda records: write_sim(output, records, settings, robot,
                                                             inputs=[traj_path, map_path], overwrite=overwrite,
                                                             warnings=model.warnings))
    failed = [r for r in records if not r["success"]]
    status(f"wrote {output}: {len(records) - len(failed)}/{len(records)} tasks executed successfully")
    for r in records:
        line = f"  task {r['index']}: {r['reason']}"
        if not r["skipped"] and math.isfinite(r["simulated"]):
            line += (f"; tracking rms {r['rms_position_error']:.3f} m, {r['rms_orientation_error']:.3f} rad; "
                     f"peak torque {r['peak_torque']:.0f} N m; QP failures {r['qp_failures']:.0f} "
                     f"(relaxed QP), {r['qp_held']:.0f} held")
        (status if r["success"] else stderr_line)(line)
    if failed:
        ctx.exit(EXIT_ITEMS_FAILED)
