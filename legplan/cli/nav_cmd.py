"""`legplan nav search|show`: 2D navigation front end (kinodynamic A* or grid A*) → nav.h5.

    legplan nav search map.h5 --start 1 1 --start-vel 0.5 0 --goal 28 28 -o nav.h5
    legplan nav search map.h5 --queries queries.csv --planner astar -o nav.h5 --param weight=2
    legplan nav show nav.h5 --map map.h5 -o nav.png

Start and goal positions take exactly two numbers; their optional velocities are separate options
(`--start-vel`, `--goal-vel`, default 0 0), which keeps every option fixed-arity.
"""

from __future__ import annotations

import click

from legplan.cli.console import progress_bar, status, stderr
from legplan.cli.main import EXIT_ITEMS_FAILED
from legplan.cli.options import input_artefact, output_opt, overwrite_opt, verbosity_opts

PAIR = (float, float)


@click.group("nav")
@verbosity_opts
def command():
    """2D navigation: kinodynamic A* / grid A* search (kind "nav")."""


@command.command("search")
@click.argument("map_path", metavar="MAP", type=input_artefact)
@click.option("--robot", default="jueying_mini", show_default=True,
              help="Robot whose navigation limits (Table I) and inscribed radius are used.")
@click.option("--start", type=PAIR, metavar="X Y", help="Start position (m).")
@click.option("--start-vel", type=PAIR, default=(0.0, 0.0), show_default=True, metavar="VX VY",
              help="Start velocity (m/s, world frame).")
@click.option("--goal", type=PAIR, metavar="X Y", help="Goal position (m).")
@click.option("--goal-vel", type=PAIR, default=(0.0, 0.0), show_default=True, metavar="VX VY",
              help="Goal velocity (m/s, world frame).")
@click.option("--queries", "queries_path", type=click.Path(dir_okay=False),
              help="CSV of queries: start_x,start_y,start_vx,start_vy,goal_x,goal_y,goal_vx,goal_vy "
                   "(instead of --start/--goal).")
@click.option("--planner", type=click.Choice(["kinoastar", "astar"]), default="kinoastar",
              show_default=True)
@click.option("--param", "param_items", multiple=True, metavar="KEY=VALUE",
              help="Override a search parameter (legplan.nav.NavParams), e.g. weight=2, mu=1.")
@output_opt
@overwrite_opt
@verbosity_opts
@click.pass_context
def search(ctx, map_path, robot, start, start_vel, goal, goal_vel, queries_path, planner,
           param_items, output, overwrite):
    """Plan start → goal on MAP's costmap; every query is written (with its reason if it failed).

    Exit 1 when any query failed."""
    import numpy as np

    from legplan.artefacts import check_output, write_artefact
    from legplan.errors import LegplanError
    from legplan.nav import PLANNERS, NavGrid, NavParams
    from legplan.nav.artefact import write_query, write_summary_table
    from legplan.nav.queries import read_queries_csv
    from legplan.robots import load_robot

    check_output(output, overwrite)
    if queries_path is not None and (start is not None or goal is not None):
        raise LegplanError("nav search: give either --queries or --start/--goal, not both")
    if queries_path is None and (start is None or goal is None):
        raise LegplanError("nav search: --start and --goal are required (or --queries FILE)")
    overrides = _parse_params(param_items)
    navigation = load_robot(robot).navigation
    if navigation is None:
        raise LegplanError(f"robot '{robot}': robot.yaml has no 'navigation' section")
    params = NavParams.for_robot(navigation).with_overrides(overrides)
    if queries_path is not None:
        queries = read_queries_csv(queries_path)
    else:
        queries = np.array([[*start, *start_vel, *goal, *goal_vel]])
    grid = NavGrid.from_map(map_path, lethal_radius=navigation.inscribed_radius)
    plan = PLANNERS[planner]
    inputs = [map_path] + ([queries_path] if queries_path else [])
    rows = []
    with write_artefact(output, "nav", params={**params.as_dict(), "planner": planner,
                                               "robot": robot}, inputs=inputs,
                        overwrite=overwrite) as handle:
        group = handle.create_group("queries")
        with progress_bar(f"nav search ({planner})") as progress:
            for index, query in enumerate(queries):
                progress(index, len(queries), f"query {index}")
                result = plan(grid, query[:4], query[4:], params)
                rows.append(write_query(group, index, result, grid))
            progress(len(queries), len(queries))
        write_summary_table(handle, rows)
    failed = [(index, row) for index, row in enumerate(rows) if not row["success"]]
    status(f"wrote {output}: {len(rows) - len(failed)}/{len(rows)} queries planned ({planner})")
    for index, row in enumerate(rows):
        if row["success"]:
            status(f"  {index:04d}: T={row['duration']:.2f} s, J={row['effort']:.3f}, "
                   f"length {row['path_length']:.2f} m, clearance {row['min_clearance']:.2f} m, "
                   f"{row['expansions']} expansions in {row['planning_time']:.3f} s")
    for index, row in failed:
        stderr.print(f"  {index:04d}: failed: {row['reason']}", highlight=False, markup=False)
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
    from legplan.nav.artefact import read_queries
    from legplan.nav.plot import render_nav

    check_output(output, overwrite)
    with open_artefact(nav_path, kind="nav") as handle:
        queries = read_queries(handle)
    render_nav(NavGrid.from_map(map_path), queries, output)
    status(f"wrote {output}")


def _parse_params(items) -> dict[str, str]:
    from legplan.errors import LegplanError

    overrides = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise LegplanError(f"--param: expected KEY=VALUE, got {item!r}")
        overrides[key.strip()] = value.strip()
    return overrides

from legplan.cli.nav_teb_cmd import refine, simulate  # noqa: E402  (TEB back end, issue 8)
command.add_command(refine); command.add_command(simulate)
