"""`legplan dyn simulate TRAJ MAP -o sim.h5`: execute planned trajectories in MuJoCo (kind "sim").

    legplan dyn simulate traj.h5 map.h5 -o sim.h5 --jobs 2

Registered on the `dyn` group (`legplan.cli.dyn_cmd`). Every task of TRAJ with a sampled trajectory
runs through `legplan.sim.simulate` (whole-body controller at 400 Hz, paper Sec. III-B/C); exit 1
when any task fails (fell, missed the goal, or had nothing to execute), 2 on bad input.
"""

from __future__ import annotations

import os

import click

from legplan.cli.console import status, stderr_line
from legplan.cli.main import EXIT_ITEMS_FAILED
from legplan.cli.options import batch_opts, input_artefact, number, output_opt, overwrite_opt, verbosity_opts
from legplan.parameters import FRICTION, WAIT
from legplan.errors import LegplanError


@click.command("simulate")
@click.argument("traj_path", metavar="TRAJ", type=input_artefact)
@click.argument("map_path", metavar="MAP", type=input_artefact)
@click.option("--settle", type=number(WAIT), default=0.5, show_default=True,
              help="Seconds the final pose is held after the plan before the goal is judged.")
@click.option("--friction", type=number(FRICTION), default=None,
              help="Friction coefficient of the simulated contacts [default: the robot's, as planned].")
@output_opt
@overwrite_opt
@batch_opts
@verbosity_opts
@click.pass_context
def simulate_cmd(ctx, traj_path, map_path, settle, friction, output, overwrite, jobs, scheduler, resume):
    """Execute every trajectory of TRAJ on MAP in MuJoCo under the whole-body controller; write sim.h5.

    Success: no fall (base below half its nominal height above the terrain, tilted > 0.8 rad, or the
    trunk on the terrain) and the base within 10 cm and 0.2 rad (yaw) of the task's goal after the plan and --settle."""
    import numpy as np

    from legplan.artefacts import check_output
    from legplan.artefacts.identity import check_same_map, check_same_robot
    from legplan.batch import Task
    from legplan.cli.batching import run_stage
    from legplan.dyn.artefact import check_executable, read_tasks
    from legplan.robots import load_robot
    from legplan.sim.artefact import write_sim
    from legplan.sim.items import SimWorker, failed_item, sim_items, simulate_item
    from legplan.sim.run import SimParams
    from legplan.terrain import load_map

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
    params = SimParams(settle=settle, friction=friction)
    settings = {"settle": settle, "friction": friction, "traj": str(traj_path)}
    task = Task(simulate_item, failed_item, SimWorker, (robot.name, os.path.abspath(map_path), params))
    records, _ = run_stage(task, sim_items(tasks), "dyn simulate", output=output,
                           identity={"stage": "dyn simulate", "params": settings}, inputs=[traj_path, map_path],
                           jobs=jobs, scheduler=scheduler, resume=resume, overwrite=overwrite,
                           publish=lambda records: write_sim(output, records, settings, robot,
                                                             inputs=[traj_path, map_path], overwrite=overwrite))
    failed = [r for r in records if not r["success"]]
    status(f"wrote {output}: {len(records) - len(failed)}/{len(records)} tasks executed successfully")
    for r in records:
        line = (f"  task {r['index']}: {r['reason']}; tracking rms {r['rms_position_error']:.3f} m, "
                f"{r['rms_orientation_error']:.3f} rad; peak torque {r['peak_torque']:.0f} N m")
        (status if r["success"] else stderr_line)(line)
    if failed:
        ctx.exit(EXIT_ITEMS_FAILED)
