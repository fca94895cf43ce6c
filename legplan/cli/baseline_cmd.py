"""`legplan baseline nav|step`: OMPL sampling-based planners on the same problems, same artefacts.

    legplan baseline nav map.h5 --start 0.5 0.5 --goal 29.5 29.5 --planner rrtstar -o nav_ompl.h5
    legplan baseline step map.h5 steps.h5 --steps 3:10 --space atlas -o motion_ompl.h5

nav.h5 / motion.h5 are written by the nav search's and the step planner's own writers, so
`legplan inspect`, `legplan compare` and `legplan report` read them like ours. Exit 1 when any
query or step failed (written, with its reason).
"""

from __future__ import annotations

import click

from legplan.baselines.names import CONSTRAINED_SPACES, NAV_PLANNERS
from legplan.cli.main import EXIT_ITEMS_FAILED
from legplan.cli.nav_options import query_opts, resolve_queries
from legplan.cli.options import batch_opts, input_artefact, number, output_opt, overwrite_opt, seed_opt, verbosity_opts
from legplan.parameters import TIME_LIMIT


@click.group("baseline")
@verbosity_opts
def command():
    """OMPL baselines of `nav search` and `step plan` (kinds "nav" and "motion")."""


@command.command("nav")
@click.argument("map_path", metavar="MAP", type=input_artefact)
@click.option("--robot", default="jueying_mini", show_default=True,
              help="Robot whose navigation limits and inscribed radius are used.")
@query_opts("; used by the control planners")
@click.option("--planner", type=click.Choice(NAV_PLANNERS), default="rrtconnect", show_default=True)
@click.option("--time-budget", type=number(TIME_LIMIT), default=1.0, show_default=True,
              help="Seconds of OMPL solve() per query.")
@seed_opt
@output_opt
@overwrite_opt
@batch_opts
@verbosity_opts
@click.pass_context
def nav_cmd(ctx, map_path, robot, start, start_vel, goal, goal_vel, queries_path, planner, time_budget,
            seed, output, overwrite, jobs, scheduler, resume):
    """Plan MAP's navigation queries with an OMPL planner; write nav.h5 (query i uses seed SEED + i)."""
    import functools
    import os

    from legplan.artefacts import check_output
    from legplan.baselines.nav import (NavBaselineParams, NavBaselineWorker, baseline_item, failed_baseline,
                                       write_nav_baseline)
    from legplan.batch import Task
    from legplan.cli.batching import run_stage
    from legplan.cli.console import status, stderr_line
    from legplan.nav import NavGrid, NavParams
    from legplan.robots.navigation import read_navigation
    from legplan.nav.items import query_items

    check_output(output, overwrite)
    navigation = read_navigation(robot)
    grid = NavGrid.from_map(map_path, lethal_radius=navigation.inscribed_radius)  # bad map: exit 2
    queries, query_files = resolve_queries("baseline nav", start, start_vel, goal, goal_vel, queries_path,
                                           grid)
    limits = NavParams.for_robot(navigation)
    params = NavBaselineParams(planner=planner, time_budget=time_budget, seed=seed, v_max=limits.v_max,
                               a_max=limits.a_max)
    task = Task(baseline_item, functools.partial(failed_baseline, params), NavBaselineWorker,
                (os.path.abspath(map_path), navigation.inscribed_radius, params))
    inputs = [map_path, *query_files]
    _, rows = run_stage(task, query_items(queries), f"baseline nav ({planner})", output=output,
                        identity={"stage": "baseline nav", "params": {**params.as_dict(), "robot": robot}},
                        inputs=inputs, jobs=jobs, scheduler=scheduler, resume=resume, overwrite=overwrite,
                        publish=lambda records: write_nav_baseline(output, records, params, robot, inputs=inputs,
                                                                   overwrite=overwrite))
    failed = [index for index, row in enumerate(rows) if not row["success"]]
    status(f"{len(rows) - len(failed)}/{len(rows)} queries planned (ompl {planner}, {time_budget:g} s "
           f"budget) -> {output}")
    for index, row in enumerate(rows):
        if row["success"]:
            status(f"  {index:04d}: first solution {row['time_to_first_solution']:.3f} s, "
                   f"T={row['duration']:.2f} s, J={row['effort']:.3f}, length {row['path_length']:.2f} m, "
                   f"clearance {row['min_clearance']:.2f} m")
        else:
            stderr_line(f"  {index:04d}: failed: {row['reason']}")
    if failed:
        ctx.exit(EXIT_ITEMS_FAILED)


@command.command("step")
@click.argument("map_path", metavar="MAP", type=input_artefact)
@click.argument("steps_path", metavar="STEPS", type=input_artefact)
@click.option("--steps", "step_range", default=None, help="Pairs to plan, 'a:b' (python slice) or 'i'.")
@click.option("--time-budget", type=number(TIME_LIMIT), default=10.0, show_default=True,
              help="Seconds of OMPL solve() per step.")
@click.option("--space", type=click.Choice(CONSTRAINED_SPACES), default="atlas", show_default=True,
              help="OMPL constrained state space.")
@seed_opt
@output_opt
@overwrite_opt
@batch_opts
@verbosity_opts
@click.pass_context
def step_cmd(ctx, map_path, steps_path, step_range, time_budget, space, seed, output, overwrite, jobs,
             scheduler, resume):
    """Constrained RRT-Connect for every consecutive pair of STEPS on MAP; write motion.h5.

    Step i uses seed SEED + i. Metrics are those of `legplan step plan` (dense re-check by the
    independent validator); exit 1 if any step failed."""
    import os

    from legplan.artefacts import check_output
    from legplan.baselines.step import StepBaselineParams, StepBaselineWorker
    from legplan.batch import Task
    from legplan.cli.batching import run_stage
    from legplan.cli.console import status, stderr_line
    from legplan.cli.step_cmd import read_step_pairs
    from legplan.stepplan.batch import failed_item, plan_item, step_items, write_motion

    check_output(output, overwrite)
    params = StepBaselineParams(time_budget=time_budget, space=space, seed=seed)
    seq, indices, _, _ = read_step_pairs(map_path, steps_path, step_range)
    task = Task(plan_item, failed_item, StepBaselineWorker, (seq.robot, os.path.abspath(map_path), params))
    inputs = [map_path, steps_path]
    records, summary = run_stage(
        task, step_items(seq, indices), f"baseline step ({params.planner})", output=output,
        identity={"stage": "baseline step", "params": params.as_dict()}, inputs=inputs, jobs=jobs,
        scheduler=scheduler, resume=resume, overwrite=overwrite,
        publish=lambda records: write_motion(output, records, seq.robot, params, inputs=inputs, overwrite=overwrite,
                                             attrs={"planner": params.planner}))
    failed = [r for r in records if not r["success"]]
    status(f"{summary['steps_succeeded']}/{summary['steps_planned']} steps planned ({params.planner}); "
           f"worst dense stance-foot slip {summary['worst_violation'][0] * 1e3:.3f} mm; "
           f"median {summary['median_time'][0]:.2f} s -> {output}")
    for r in failed:
        stderr_line(f"  step {r['index']}: {r['reason']}")
    if failed:
        ctx.exit(EXIT_ITEMS_FAILED)
