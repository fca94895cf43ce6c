"""`legplan dyn plan|show`: centroidal trajectory optimization (TOWR formulation + the paper's costs) → traj.h5.

    legplan dyn plan map.h5 --robot anymal --gait walk --strides 4 --duration 5.5 \\
        --start -1.0 0.3 0.3 --goal 0.6 0 0 --costs paper -o traj.h5
    legplan dyn plan map.h5 --tasks tasks.csv --gait trot -o traj.h5 --jobs 2
    legplan dyn show traj.h5 -o fig3.png                     # base, feet, forces (the paper's Fig. 3)
    legplan dyn show with_costs.h5 without_costs.h5 -o fig4.png   # forces, ω with vs without costs (Fig. 4)
"""

from __future__ import annotations

import os

import click

from legplan.cli.console import status, stderr_line
from legplan.cli.main import EXIT_ITEMS_FAILED
from legplan.cli.options import (batch_opts, init_opt, input_artefact, number, output_opt, overwrite_opt, param_opt, pose_opt,
                                 verbosity_opts, optimize_phases_opt, warm_stage_opt)
from legplan.cli.options import count
from legplan.errors import LegplanError
from legplan.parameters import DURATION



@click.group("dyn")
@verbosity_opts
def command():
    """Centroidal trajectory optimization of dynamic motions (kind "traj")."""


@command.command("plan")
@click.argument("map_path", metavar="MAP", type=input_artefact)
@click.option("--robot", default="anymal", show_default=True, help="Robot with a `centroidal:` section.")
@click.option("--gait", default=None, help="walk or trot [default: trot]; a tasks file's default.")
@click.option("--strides", type=count("strides"), default=None, help="Strides, >= 1 [default: 4]; a tasks file's default.")
@click.option("--duration", type=number(DURATION), default=None, help="Total duration (s) [default: 2.4]; a tasks file's default.")
@pose_opt("--start", help="Start base pose")
@pose_opt("--goal", help="Goal base pose")
@click.option("--tasks", "tasks_path", type=click.Path(dir_okay=False), default=None,
              help="CSV or YAML tasks file, one task per row: start_x,start_y,start_yaw,goal_x,goal_y,goal_yaw "
                   "[,gait,strides,duration] (instead of --start/--goal).")
@click.option("--costs", default="none", show_default=True, metavar="paper|none|FILE.yaml",
              help="The paper's costs and constraints, none (TOWR's formulation), or a costs file.")
@param_opt("A planner parameter (legplan.dyn.settings.DynParams), nested ones by dotted name, applied after "
           "--costs; e.g. --param dt=0.05 --param costs.force=0.5 --param solver.inner.max_iterations=30.")
@optimize_phases_opt
@init_opt
@warm_stage_opt
@output_opt
@overwrite_opt
@batch_opts
@verbosity_opts
@click.pass_context
def plan_cmd(ctx, map_path, robot, gait, strides, duration, start, goal, tasks_path, costs, params, optimize_phases,
             init, warm_stage, output, overwrite, jobs, scheduler, resume):
    """Plan every task on MAP; write traj.h5, each task with its solver outcome and independent check.

    Exit 1 when any task failed (its reason is recorded)."""
    from legplan.artefacts import check_output
    from legplan.artefacts.identity import check_same_map
    from legplan.batch import Task
    from legplan.cli.batching import run_stage
    from legplan.dyn.artefact import write_traj
    from legplan.dyn.items import DynWorker, failed_item, plan_item, task_items
    from legplan.dyn.settings import costs_file, dyn_params, settings_record
    from legplan.dyn.tasks import centroidal_model, check_placements, check_sizes, command_line_task, read_tasks
    from legplan.dyn.terrain import TerrainModel
    from legplan.learn.initializers import check_warm_stage, initializer
    from legplan.robots import load_robot
    from legplan.robots.identity import robot_reference, robot_sha256
    from legplan.terrain import load_map

    check_output(output, overwrite)
    if tasks_path is not None and (start is not None or goal is not None):
        raise LegplanError("dyn plan: give either --tasks or --start/--goal, not both")
    if tasks_path is None and (start is None or goal is None):
        raise LegplanError("dyn plan: --start and --goal are required (or --tasks FILE)")
    check_warm_stage(warm_stage, init)
    params = dyn_params(costs, {**params, "warm_stage": warm_stage, "optimize_phases": optimize_phases})
    init_fn = initializer(init)  # an unknown --init: exit 2 before any work
    loaded = load_robot(robot)
    model = centroidal_model(loaded, params, costs)
    if any(model.com_offset):
        status(f"{robot}: CoM at {', '.join(f'{v:g}' for v in model.com_offset)} m in the base frame: planned about the CoM")
    tasks = (read_tasks(tasks_path, gait, strides, duration) if tasks_path is not None
             else [command_line_task(start, goal, gait, strides, duration)])
    check_sizes(tasks, params, tasks_path)
    terrain_map = load_map(map_path)
    terrain = TerrainModel(terrain_map)
    check_placements(tasks, model, terrain, tasks_path, map_path)
    if hasattr(init_fn, "check_task"):  # a learned initializer fits one variable layout: refuse others now
        trained_on = {"path": init_fn.space.get("map"), "sha256": init_fn.space.get("map_sha256"),
                      "terrain": init_fn.space.get("map_terrain")}
        check_same_map(init_fn.path, map_path, [trained_on], what="trained")
        for t in tasks:
            init_fn.check_task(t, params)
            init_fn.check_in_space(t)
        init = init_fn.path

    options = {"robot": robot, "gait": gait, "strides": strides, "duration": duration, "tasks": tasks_path,
               "start": start, "goal": goal}
    settings = {**settings_record(costs, init, params), **{k: v for k, v in options.items() if v is not None}}
    inputs = [path for path in (map_path, tasks_path, costs_file(costs)) if path is not None]
    task = Task(plan_item, failed_item, DynWorker, (robot, os.path.abspath(map_path), params, init_fn))
    task.provide(DynWorker.of(loaded, model, terrain_map, terrain, params, init_fn))  # loaded once (run_stage forks)
    reference = robot_reference(loaded)   # the name, or the robot.yaml's path when given by path
    records, _ = run_stage(task, task_items(tasks), "dyn plan", output=output,
                           identity={"stage": "dyn plan", "params": settings}, inputs=inputs, jobs=jobs,
                           scheduler=scheduler, resume=resume, overwrite=overwrite,
                           publish=lambda records: write_traj(output, records, settings, reference, model.legs,
                                                              inputs=inputs, overwrite=overwrite,
                                                              robot_sha256=robot_sha256(loaded)))
    failed = [r for r in records if not r["success"]]
    status(f"wrote {output}: {len(records) - len(failed)}/{len(records)} tasks planned")
    for r in records:
        if r["success"]:
            check = r["check"]
            missed = [name for name, ok in check["passed"].items() if not ok]
            status(f"  task {r['index']}: {r['iterations']} iterations, {r['solve_seconds']:.2f} s, "
                   f"max violation {r['max_violation']:.1e}, {r['variables']} variables (paper's N "
                   f"{r['paper_variables']}); check " + (f"missed {', '.join(missed)}" if missed else "passed"))
    for r in failed:
        stderr_line(f"  task {r['index']}: failed: {r['reason']}")
    if failed:
        ctx.exit(EXIT_ITEMS_FAILED)


@command.command("show")
@click.argument("paths", metavar="TRAJ [TRAJ2]", nargs=-1, required=True, type=input_artefact)
@click.option("--task", "task_index", type=count("items", 0), default=0, show_default=True,
              help="Which task of each artefact to draw.")
@click.option("--sim", "sims", multiple=True, type=input_artefact, metavar="SIM",
              help="With two TRAJ: the sim.h5 of each (`dyn simulate`), in the same order, given twice: adds "
                   "their tracking errors and executed angular rates (Fig. 4 (e)-(h)).")
@output_opt
@overwrite_opt
@verbosity_opts
def show_cmd(paths, task_index, sims, output, overwrite):
    """PNG of TRAJ: base, feet and forces over time (Fig. 3); of two runs, forces and base angular
    velocity of TRAJ against TRAJ2, e.g. with vs without costs (Fig. 4 (a)-(d)), and with --sim
    twice their executions' tracking errors and angular rates (Fig. 4 (e)-(h))."""
    from legplan.artefacts import check_output
    from legplan.dyn.figures import plot_comparison, plot_trajectory, shown_task
    from legplan.sim.artefact import read_executed

    check_output(output, overwrite)
    if len(paths) > 2:
        raise LegplanError(f"dyn show: give one or two traj artefacts, got {len(paths)}")
    if sims and (len(sims) != 2 or len(paths) != 2):
        raise LegplanError(f"dyn show: --sim: give one sim artefact per traj artefact of two, got {len(sims)} "
                           f"for {len(paths)}")
    runs = [shown_task(path, task_index) for path in paths]
    executed = tuple(read_executed(path, task_index) for path in sims) or None
    if len(runs) == 1:
        plot_trajectory(output, *runs[0], overwrite=overwrite)
    else:
        plot_comparison(output, runs[0], runs[1], executed=executed, overwrite=overwrite)
    status(f"wrote {output}")


from legplan.cli.sim_cmd import simulate_cmd  # noqa: E402  (legplan dyn simulate: physics execution, issue 17)

command.add_command(simulate_cmd)


@command.command("replan")
@click.argument("traj_path", metavar="TRAJ", type=input_artefact)
@click.argument("state_path", metavar="STATE", type=click.Path(dir_okay=False))
@click.option("--map", "map_path", required=True, type=input_artefact, help="The map TRAJ was planned on.")
@click.option("--warm-stage", "warm_stage", type=click.Choice(["projection", "costs"]), default="projection",
              show_default=True, help="From the shifted plan: the constraints alone, or the costs under them.")
@output_opt
@overwrite_opt
@verbosity_opts
@click.pass_context
def replan_cmd(ctx, traj_path, state_path, map_path, warm_stage, output, overwrite):
    """Plan the rest of a task of TRAJ from the measured state in STATE (YAML/JSON: t, task, base_pos,
    base_euler, base_vel, base_ang_vel, feet_pos; legplan.dyn.replan_io), warm-started from TRAJ's
    solution shifted to t; write a traj.h5 of the rest (time 0 = t), checked like `dyn plan`'s.

    Exit 1 when the replan failed (its reason is recorded)."""
    import json

    from legplan.artefacts import check_output
    from legplan.artefacts.identity import check_same_map
    from legplan.dyn.artefact import read_tasks, trajectory_record, write_traj
    from legplan.dyn.replan import replan
    from legplan.dyn.replan_io import check_state_time, previous_of, read_state, recorded_params, traj_task
    from legplan.dyn.tasks import centroidal_model
    from legplan.dyn.terrain import TerrainModel
    from legplan.robots import load_robot
    from legplan.terrain import load_map
    from legplan.validate.trajectory import check_trajectory

    check_output(output, overwrite)
    attrs, tasks = read_tasks(traj_path)
    legs = str(attrs["legs"]).split(",")
    index, state = read_state(state_path, len(legs))
    task = traj_task(traj_path, tasks, index, state_path)
    check_state_time(state_path, state, float(task["duration"]))
    settings = json.loads(attrs.get("params", "{}"))
    params = recorded_params(settings)
    robot = load_robot(str(attrs["robot"]))
    model = centroidal_model(robot, params)
    terrain_map = load_map(map_path)
    check_same_map(traj_path, map_path, what="planned")
    terrain = TerrainModel(terrain_map)
    out = replan(previous_of(task, model, params), state, model, terrain, params, warm_stage=warm_stage)
    check = check_trajectory(out.plan.samples, model, terrain_map, robot, node_times=out.plan.problem.form.knots)
    rest = out.plan.problem.task
    record = trajectory_record(0, rest, out.plan, check)
    replanned = {"traj": os.fspath(traj_path), "state": os.fspath(state_path), "task": index, "warm_stage": warm_stage,
                 **{k: (v.tolist() if hasattr(v, "tolist") else v) for k, v in state.record().items()}}
    write_traj(output, [record], {**settings, "replan": replanned}, str(attrs["robot"]), legs,
               inputs=[traj_path, state_path, map_path], overwrite=overwrite,
               robot_sha256=attrs.get("robot_sha256"))
    line = (f"wrote {output}: replan from t = {state.t:g} s {'succeeded' if record['success'] else 'failed'}: "
            f"{out.iterations} iterations, {out.cpu_seconds:.3f} s CPU")
    if record["success"]:
        status(line)
    else:
        stderr_line(f"{line}: {record['reason']}")
        ctx.exit(EXIT_ITEMS_FAILED)
