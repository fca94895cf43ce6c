"""`legplan nav search|show`: 2D navigation front end (kinodynamic A* or grid A*) → nav.h5.

    legplan nav search map.h5 --start 1 1 --start-vel 0.5 0 --goal 28 28 -o nav.h5
    legplan nav search map.h5 --queries queries.csv --planner astar -o nav.h5 --param weight=2
    legplan nav show nav.h5 --map map.h5 -o nav.png

Start and goal positions take exactly two numbers; their optional velocities are separate options
(`--start-vel`, `--goal-vel`, default 0 0), which keeps every option fixed-arity.
"""

from __future__ import annotations

import click

from legplan.cli.console import status, stderr_line
from legplan.cli.main import EXIT_ITEMS_FAILED
from legplan.cli.nav_options import query_opts, resolve_queries
from legplan.cli.options import batch_opts, input_artefact, output_opt, overwrite_opt, param_opt, verbosity_opts


@click.group("nav")
@verbosity_opts
def command():
    """2D navigation: kinodynamic A* / grid A* search (kind "nav")."""


@command.command("search")
@click.argument("map_path", metavar="MAP", type=input_artefact)
@click.option("--robot", default="jueying_mini", show_default=True,
              help="Robot whose navigation limits (Table I) and inscribed radius are used.")
@query_opts("")
@click.option("--planner", type=click.Choice(["kinoastar", "astar"]), default="kinoastar",
              show_default=True)
@param_opt("Override a search parameter (legplan.nav.NavParams), e.g. weight=2, mu=1.")
@output_opt
@overwrite_opt
@batch_opts
@verbosity_opts
@click.pass_context
def search(ctx, map_path, robot, start, start_vel, goal, goal_vel, queries_path, planner,
           params, output, overwrite, jobs, scheduler, resume):
    """Plan start → goal on MAP's costmap; every query is written (with its reason if it failed).

    Exit 1 when any query failed."""
    import functools
    import os

    from legplan.artefacts import check_output
    from legplan.batch import Task
    from legplan.cli.batching import run_stage
    from legplan.nav import NavGrid, NavParams
    from legplan.robots.navigation import read_navigation
    from legplan.nav.artefact import write_nav
    from legplan.nav.items import SearchWorker, failed_query, query_items, search_item

    check_output(output, overwrite)
    navigation = read_navigation(robot)
    grid = NavGrid.from_map(map_path, lethal_radius=navigation.inscribed_radius)  # bad map: exit 2
    queries, query_files = resolve_queries("nav search", start, start_vel, goal, goal_vel, queries_path,
                                           grid)
    settings = NavParams.for_robot(navigation).with_overrides(params)
    task = Task(search_item, functools.partial(failed_query, planner), SearchWorker,
                (os.path.abspath(map_path), navigation.inscribed_radius, planner, settings))
    stage_params = {**settings.as_dict(), "planner": planner, "robot": robot}
    inputs = [map_path, *query_files]
    _, rows = run_stage(task, query_items(queries), f"nav search ({planner})", output=output,
                        identity={"stage": "nav search", "params": stage_params}, inputs=inputs, jobs=jobs,
                        scheduler=scheduler, resume=resume, overwrite=overwrite,
                        publish=lambda records: write_nav(output, records, stage_params, inputs=inputs,
                                                          overwrite=overwrite))
    failed = [(index, row) for index, row in enumerate(rows) if not row["success"]]
    status(f"wrote {output}: {len(rows) - len(failed)}/{len(rows)} queries planned ({planner})")
    for index, row in enumerate(rows):
        if row["success"]:
            status(f"  {index:04d}: T={row['duration']:.2f} s, J={row['effort']:.3f}, "
                   f"length {row['path_length']:.2f} m, clearance {row['min_clearance']:.2f} m, "
                   f"{row['expansions']} expansions in {row['planning_time']:.3f} s")
    for index, row in failed:
        stderr_line(f"  {index:04d}: failed: {row['reason']}")
    if failed:
        ctx.exit(EXIT_ITEMS_FAILED)


@command.command("show")
@click.argument("nav_path", metavar="NAV", type=input_artefact)
@click.option("--map", "map_path", required=True, type=input_artefact, help="The map.h5 searched.")
@output_opt
@overwrite_opt
@verbosity_opts
def show(nav_path, map_path, output, overwrite):
    """Draw NAV's paths and velocity arrows over the map's costmap (PNG)."""
    from legplan.artefacts import check_output, open_artefact
    from legplan.nav import NavGrid
    from legplan.artefacts.identity import check_same_map
    from legplan.nav.artefact import read_queries
    from legplan.nav.plot import render_nav

    check_output(output, overwrite)
    with open_artefact(nav_path, kind="nav") as handle:
        queries = read_queries(handle)
    check_same_map(nav_path, map_path, what="searched")
    render_nav(NavGrid.from_map(map_path), queries, output, overwrite=overwrite)
    status(f"wrote {output}")


from legplan.cli.nav_teb_cmd import refine, simulate  # noqa: E402  (TEB back end, issue 8)
command.add_command(refine); command.add_command(simulate)
