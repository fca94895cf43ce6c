"""`legplan nav refine|simulate`: the TEB back end (quadruped paper Sec. IV, V-C 3).

These commands are registered on the `nav` group of `nav_cmd.py`.
"""

from __future__ import annotations

import click

from legplan.cli.console import progress_bar, status
from legplan.cli.options import (NumbersOption, input_artefact, output_opt, overwrite_opt, param_opt,
                                 verbosity_opts)
from legplan.cli.options import count, number
from legplan.parameters import COORDINATE, SENSING_RADIUS, TIME_LIMIT, WAIT, YAW  # SimParams' ranges too

robot_opt = click.option("--robot", default="jueying_mini", show_default=True,
                         help="Robot name or robot.yaml path (its navigation limits, Table I).")
rounds_opt = click.option("--outer", type=count("iterations"), default=4, show_default=True,
                          help="TEB outer rounds (resize + LM).")
inner_opt = click.option("--inner", type=count("iterations"), default=5, show_default=True,
                         help="TEB inner iterations per round.")
omni_opt = click.option("--omni/--non-omni", default=True, show_default=True,
                        help="Omnidirectional model, or differential drive (lateral velocity zero).")


@click.command("refine")
@click.argument("map_path", metavar="MAP", type=input_artefact)
@click.argument("nav_path", metavar="NAV", type=input_artefact)
@output_opt
@robot_opt
@rounds_opt
@inner_opt
@omni_opt
@overwrite_opt
@verbosity_opts
@click.pass_context
def refine(ctx, map_path, nav_path, output, robot, outer, inner, omni, overwrite):
    """Refine every successful query of NAV (from `nav search`) with the TEB on MAP."""
    import h5py

    from legplan.artefacts import check_output, write_artefact, write_summary
    from legplan.robots.navigation import read_navigation
    from legplan.artefacts.identity import check_same_map
    from legplan.nav.teb.artefact import refinable_queries, write_refinement
    from legplan.nav.teb.distance import DistanceField
    from legplan.nav.teb.params import TebParams
    from legplan.nav.teb.refine import query_path, refine_path
    from legplan.terrain import load_map

    check_output(output, overwrite)
    navigation = read_navigation(robot)
    terrain = load_map(map_path)
    field = DistanceField.from_terrain(terrain)
    params = TebParams(outer_iterations=outer, inner_iterations=inner, omnidirectional=omni)
    queries = refinable_queries(nav_path)
    check_same_map(nav_path, map_path, what="searched")
    rows = []
    with write_artefact(output, "nav", params={"teb": params.as_dict(), "robot": robot}, inputs=[map_path, nav_path],
                        overwrite=overwrite) as f, h5py.File(nav_path, "r") as source, \
            progress_bar("refining") as progress:
        f.copy(source["queries"], "queries")
        for i, query in enumerate(queries):
            progress(i, len(queries), query["name"])
            if not query["success"]:
                continue
            path = query_path(query["trajectory"], query["waypoints"], navigation.limits.v_x_max)
            refinement = refine_path(path, navigation.limits, params, field)
            rows.append(write_refinement(f["queries"][query["name"]], refinement))
        progress(len(queries), len(queries), "done")
        _summary(write_summary, f, len(queries), rows)
    status(f"wrote {output}: {len(rows)} of {len(queries)} queries refined")
    if len(rows) < len(queries):
        ctx.exit(1)


def _summary(write_summary, handle, count, rows):
    import numpy as np

    def median(key):
        return float(np.median([r[key] for r in rows])) if rows else float("nan")

    write_summary(handle, {"queries": count, "refined": len(rows),
                           "median_total_time": (median("total_time"), "s"),
                           "median_effort": (median("effort"), "m^2/s^3"),
                           "median_seconds": (median("seconds"), "s"),
                           "max_violation": max((r["max_violation"] for r in rows), default=float("nan")),
                           "min_clearance": (min((r["min_clearance"] for r in rows), default=float("nan")), "m")})


@click.command("simulate")
@click.argument("map_path", metavar="MAP", type=input_artefact)
@robot_opt
@click.option("--start", cls=NumbersOption, counts=(2, 3), required=True, metavar="X Y [YAW]",
              help="Start pose (m, m, rad; yaw 0 when left out).")
@click.option("--goal", cls=NumbersOption, counts=(2, 3), required=True, metavar="X Y [YAW]",
              help="Goal position and optional heading (m, m, rad).")
@click.option("--via", cls=NumbersOption, counts=(2, 3, 4), ranges=(COORDINATE, COORDINATE, YAW, WAIT), multiple=True, metavar="X Y [YAW [DWELL]]",
              help="Via point (m, m, rad, s); repeatable, in order.")
@click.option("--face-target", cls=NumbersOption, counts=(2,), ranges=(COORDINATE,), default=None, metavar="X Y",
              help="Hold the heading towards this point on the way (omnidirectional side-stepping, "
                   "Table III).")
@click.option("--hidden-obstacles", type=click.Path(dir_okay=False), default=None,
              help="YAML with `obstacles: [map primitives]` missing from the initial map; sensed in range.")
@click.option("--planner", type=click.Choice(["kinoastar", "astar"]), default="kinoastar", show_default=True,
              help="Global planner (astar: grid A* waypoints, the Table II baseline).")
@click.option("--sensing-radius", type=number(SENSING_RADIUS), default=4.0, show_default=True, help="m.")
@click.option("--max-time", type=number(TIME_LIMIT), default=300.0, show_default=True, help="Simulated seconds.")
@click.option("--warm-start/--cold-start", default=True, show_default=True,
              help="Warm-start each cycle's band from the previous one, or re-initialize it every cycle.")
@rounds_opt
@inner_opt
@omni_opt
@param_opt("Override a parameter: search.KEY (legplan.nav.NavParams, e.g. search.weight=3), teb.KEY "
           "(TebParams, e.g. teb.weight_obstacle=80) or sim.KEY (NavRunParams, e.g. sim.window=4).")
@output_opt
@overwrite_opt
@verbosity_opts
@click.pass_context
def simulate(ctx, map_path, robot, start, goal, via, face_target, hidden_obstacles, planner, sensing_radius,
             max_time, warm_start, outer, inner, omni, params, output, overwrite):
    """Receding-horizon run on MAP: global plan, TEB at 10 Hz on a 5 m window, hidden obstacles."""
    import numpy as np

    from legplan.artefacts import check_output, write_artefact, write_summary
    from legplan.robots.navigation import read_navigation
    from legplan.errors import LegplanError
    from legplan.nav.params import NavParams
    from legplan.nav.simulate import (Goal, NavRunParams, World, grid_planner, hidden_obstacles as load_hidden,
                                      kinodynamic_planner, run_navigation as run)
    from legplan.nav.teb.artefact import write_simulation
    from legplan.nav.teb.params import TebParams
    from legplan.specio import apply_overrides
    from legplan.terrain import load_map

    check_output(output, overwrite)
    goals = []
    for v in via:
        goals.append(Goal((v[0], v[1]), v[2] if len(v) > 2 else float("nan"), v[3] if len(v) > 3 else 0.0))
    goals.append(Goal((goal[0], goal[1]), goal[2] if len(goal) > 2 else float("nan")))
    target = tuple(face_target) if face_target else None
    navigation = read_navigation(robot)
    terrain = load_map(map_path)
    off_map = terrain.grid.outside_problem([start[:2], *(g.xy for g in goals)],
                                           ["--start", *(["--via"] * len(via)), "--goal"])
    if off_map is not None:
        raise LegplanError(f"command line: {off_map}")
    hidden = (load_hidden(hidden_obstacles, terrain.grid) if hidden_obstacles
              else np.zeros(terrain.grid.shape, bool))
    world = World(terrain.grid, terrain.occupancy, hidden, terrain.nav_params, navigation.circumscribed_radius)
    overrides = simulation_overrides(params)
    search = apply_overrides(NavParams.for_robot(navigation), overrides["search"], "--param", "search")
    plan = (kinodynamic_planner(search) if planner == "kinoastar"
            else grid_planner(search, navigation.limits.v_x_max))
    teb = apply_overrides(TebParams(outer_iterations=outer, inner_iterations=inner, omnidirectional=omni),
                          overrides["teb"], "--param", "teb")
    sim = apply_overrides(NavRunParams(sensing_radius=sensing_radius, max_time=max_time, warm_start=warm_start,
                                    yaw="target" if target else "velocity", target=target),
                          overrides["sim"], "--param", "sim")
    pose = np.array([start[0], start[1], start[2] if len(start) > 2 else 0.0])
    with progress_bar("simulating") as progress:
        result = run(world, plan, pose, goals, navigation.limits, teb, sim, progress)
    record = {"teb": teb.as_dict(), "search": search.as_dict(), "sim": sim.as_dict(), "planner": planner,
              "robot": robot, "start": list(pose), "goals": [[*g.xy, g.heading, g.dwell] for g in goals],
              "sensing_radius": sim.sensing_radius, "warm_start": sim.warm_start,
              "collision_radius": navigation.circumscribed_radius}
    inputs = [map_path] + ([hidden_obstacles] if hidden_obstacles else [])
    with write_artefact(output, "nav", params=record, inputs=inputs, overwrite=overwrite) as f:
        metrics = write_simulation(f, result)
        write_summary(f, {"success": float(result.success), "running_time": (metrics["running_time"], "s"),
                          "effort": (metrics["effort"], "m^2/s^3"), "collisions": metrics["collisions"],
                          "replans": metrics["replans"],
                          "median_cycle_seconds": (metrics["median_cycle_seconds"], "s")})
    outcome = "reached the goal" if result.success else f"failed: {result.reason}"
    status(f"wrote {output}: {outcome} in {result.times[-1]:.1f} s, effort {metrics['effort']:.3f}, "
           f"{result.collisions} collisions, median TEB cycle {1e3 * metrics['median_cycle_seconds']:.0f} ms")
    if not result.success:  # a run with a collision is not a success (legplan.nav.simulate.run)
        ctx.exit(1)


def simulation_overrides(params: dict[str, str]) -> dict[str, dict[str, str]]:
    """`--param` KEY=VALUE of `nav simulate` split by prefix: {"search": ..., "teb": ..., "sim": ...}."""
    from legplan.errors import LegplanError

    groups = {"search": {}, "teb": {}, "sim": {}}
    for key, value in params.items():
        prefix, _, name = key.partition(".")
        if prefix not in groups or not name or (prefix == "sim" and name in ("yaw", "target")):
            raise LegplanError(f"--param: '{key}' must be search.KEY, teb.KEY or sim.KEY (sim.yaw and "
                               "sim.target come from --face-target)")
        groups[prefix][name] = value
    return groups
