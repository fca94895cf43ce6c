"""Options and helpers shared by the navigation commands (`nav search|refine|simulate`, `baseline nav`)."""

from __future__ import annotations

import click

from legplan.cli.options import number
from legplan.cli.options import pose
from legplan.parameters import VELOCITY

PAIR = pose(2)
VELOCITY_PAIR = (number(VELOCITY), number(VELOCITY))


def query_opts(velocity_help: str):
    """`--start X Y [--start-vel VX VY] --goal X Y [--goal-vel VX VY]` or `--queries FILE`."""
    options = (
        click.option("--start", type=PAIR, metavar="X Y", help="Start position (m)."),
        click.option("--start-vel", type=VELOCITY_PAIR, default=(0.0, 0.0), show_default=True,
                     metavar="VX VY", help=f"Start velocity (m/s, world frame){velocity_help}."),
        click.option("--goal", type=PAIR, metavar="X Y", help="Goal position (m)."),
        click.option("--goal-vel", type=VELOCITY_PAIR, default=(0.0, 0.0), show_default=True,
                     metavar="VX VY", help=f"Goal velocity (m/s, world frame){velocity_help}."),
        click.option("--queries", "queries_path", type=click.Path(dir_okay=False),
                     help="Queries instead of --start/--goal: a CSV (start_x,start_y,start_vx,start_vy,"
                          "goal_x,goal_y,goal_vx,goal_vy) or a MovingAI .scen of the map (row y "
                          "counted from the top: legplan.nav.queries)."),
    )

    def decorate(func):
        for option in reversed(options):
            func = option(func)
        return func

    return decorate


def resolve_queries(command: str, start, start_vel, goal, goal_vel, queries_path, grid=None):
    """The (n, 8) query array of the options above, and the input files it came from; a `.scen`
    file is read on `grid` (the map's `NavGrid`), and a start or goal off `grid` is refused."""
    import numpy as np

    from legplan.errors import LegplanError
    from legplan.nav.queries import read_queries

    if queries_path is not None and (start is not None or goal is not None):
        raise LegplanError(f"{command}: give either --queries or --start/--goal, not both")
    if queries_path is None and (start is None or goal is None):
        raise LegplanError(f"{command}: --start and --goal are required (or --queries FILE)")
    if queries_path is not None:
        queries, files = read_queries(queries_path, grid), [queries_path]
        names = [f"{queries_path}: row {i}: {end}" for i in range(len(queries)) for end in ("start", "goal")]
    else:
        queries, files = np.array([[*start, *start_vel, *goal, *goal_vel]]), []
        names = ["command line: --start", "command line: --goal"]
    if grid is not None:  # an end off the map is bad input (exit 2), not a failed query
        off_map = grid.frame.outside_problem(queries[:, [0, 1, 4, 5]].reshape(-1, 2), names)
        if off_map is not None:
            raise LegplanError(off_map)
    return queries, files

