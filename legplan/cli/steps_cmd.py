"""`legplan steps`: import, generate, show and export step sequences (steps.h5)."""

from __future__ import annotations

import click

from legplan.cli.console import progress_bar, status, stderr_line
from legplan.cli.options import (input_artefact, number, output_opt, overwrite_opt, param_opt, pose_opt, seed_opt,
                                 verbosity_opts)
from legplan.cli.options import count
from legplan.parameters import LENGTH


@click.group("steps")
@verbosity_opts
def command():
    """Step sequences: configurations where legs switch between swing and stance."""


def _load(robot_name, map_path):
    from legplan.robots import load_robot
    from legplan.terrain import load_map
    from legplan.validate import Validator

    robot = load_robot(robot_name)
    terrain = load_map(map_path)
    return robot, terrain, Validator(robot, terrain)


@command.command("import")
@click.argument("path", type=click.Path(dir_okay=False))
@click.option("--robot", "robot_name", required=True, help="Robot name (e.g. scarab2) or robot.yaml path.")
@click.option("--map", "map_path", required=True, type=input_artefact, help="map.h5 of the terrain.")
@click.option("--strict", is_flag=True, help="Treat warnings as errors.")
@click.option("--foot-tolerance", type=number(LENGTH), default=1e-3, show_default=True,
              help="Largest stance-foot distance to the terrain / its foothold [m].")
@output_opt
@overwrite_opt
@verbosity_opts
def import_cmd(path, robot_name, map_path, strict, foot_tolerance, output, overwrite):
    """Import a CSV/JSON/YAML/HDF5 step sequence, check every configuration, write steps.h5."""
    from legplan.artefacts import check_output
    from legplan.errors import SpecError
    from legplan.stepseq import ImportLimits, import_steps, write_steps
    from legplan.stepseq.robotinfo import robot_sha256, urdf_joint_order

    check_output(output, overwrite)
    robot, terrain, validator = _load(robot_name, map_path)
    result = import_steps(path, robot, validator, urdf_order=urdf_joint_order(robot),
                          robot_sha256=robot_sha256(robot), limits=ImportLimits(foot_tolerance=foot_tolerance))
    errors = result.errors(strict)
    if errors:  # bad input is one line: the first error and how many there are
        more = (f" (and {len(errors) - 1} more errors, in {len({i.row for i in errors})} rows in all)"
                if len(errors) > 1 else "")
        raise SpecError(f"{path}: {errors[0]}{more}; nothing written")
    for issue in result.issues:
        stderr_line(f"{path}: {issue}", "Warning:", "yellow")
    write_steps(output, result.sequence, result.checks,
                params={"robot": robot_name, "strict": strict, "foot_tolerance": foot_tolerance},
                inputs=[path, map_path], overwrite=overwrite)
    status(f"wrote {output}: {len(result.sequence)} configurations imported")


@command.command("generate")
@click.argument("map_path", type=input_artefact)
@click.option("--robot", "robot_name", required=True, help="Robot name (e.g. scarab2) or robot.yaml path.")
@pose_opt("--start", required=True, help="Start body pose")
@pose_opt("--goal", required=True, help="Goal body pose")
@click.option("--max-moves", type=count("iterations"), default=200, show_default=True)
@param_opt("Override a generator parameter (legplan.stepseq.GenerateParams: lift_height, clearance, "
           "com_margin, reach_slack, candidates, backtracks, ...; e.g. --param lift_height=0.08).")
@output_opt
@overwrite_opt
@seed_opt
@verbosity_opts
@click.pass_context
def generate_cmd(ctx, map_path, robot_name, start, goal, max_moves, params, output, overwrite, seed):
    """Plan a gait-free step sequence on the map's foothold mask (whole-body IK per configuration).

    Lift height, clearance, CoM margin and reach slack default from the robot's size: SCARAB II's
    5 cm, 2 cm, 1.5 cm, 1.5 cm times the robot's mean leg length / 0.241 m (rounded to 0.1 mm);
    --param sets them. Every configuration is judged independently (stance feet, CoM margin,
    clearance, joint limits); rows that miss one are named on stderr and recorded in the artefact
    (exit 1)."""
    from legplan.artefacts import check_output
    from legplan.specio import apply_overrides
    from legplan.stepseq import GenerateParams, GenerationError, generate_steps, write_steps
    from legplan.validate.judge import row_failures

    check_output(output, overwrite)
    settings = apply_overrides(GenerateParams, {"max_moves": str(max_moves), **params}, "--param", "generator")
    robot, terrain, validator = _load(robot_name, map_path)
    params = settings.sized_for(robot)
    try:
        with progress_bar("generating steps") as progress:
            seq, generated, checks = generate_steps(robot, terrain, start, goal, params=params, seed=seed,
                                                    validator=validator, progress=progress)
    except GenerationError as exc:
        stderr_line(f"{exc}; nothing written", "Generation failed:")
        ctx.exit(1)

    def extra(f):
        f.attrs["success"] = generated.success
        f.attrs["reason"] = generated.reason
        f.attrs["start"] = list(start)
        f.attrs["goal"] = list(goal)

    write_steps(output, seq, checks, params={"robot": robot_name, "start": list(start),
                                              "goal": list(goal), **params.__dict__},
                seed=seed, inputs=[map_path], overwrite=overwrite, extra=extra,
                judged=(generated.shortfalls, params.requirements()))
    status(f"wrote {output}: {len(seq)} configurations, {len(generated.moves)} leg moves")
    missed = row_failures(generated.shortfalls, params.requirements())
    for line in missed:
        stderr_line(f"{output}: {line}", "Requirement missed:")
    if not generated.success:
        stderr_line(generated.reason, "Generation stopped:")
    if missed or not generated.success:
        ctx.exit(1)


@command.command("show")
@click.argument("steps_path", type=input_artefact)
@click.option("--map", "map_path", required=True, type=input_artefact, help="map.h5 of the terrain.")
@output_opt
@overwrite_opt
@verbosity_opts
def show_cmd(steps_path, map_path, output, overwrite):
    """Top view PNG: footholds over the map, support polygons, CoM track."""
    from legplan.artefacts import check_output
    from legplan.robots import load_robot
    from legplan.artefacts.identity import check_same_map
    from legplan.stepseq import read_steps
    from legplan.stepseq.plot import plot_steps
    from legplan.terrain import load_map

    check_output(output, overwrite)
    seq = read_steps(steps_path)
    check_same_map(steps_path, map_path)
    robot = load_robot(seq.robot)
    plot_steps(seq, robot.com(seq.q), load_map(map_path), output, overwrite=overwrite)
    click.echo(f"{output}: written")


@command.command("export")
@click.argument("steps_path", type=input_artefact)
@output_opt
@overwrite_opt
@verbosity_opts
def export_cmd(steps_path, output, overwrite):
    """Write steps.h5 as CSV, JSON or YAML (by the output suffix) for `steps import`."""
    from legplan.artefacts import check_output
    from legplan.stepseq import read_steps, write_records

    check_output(output, overwrite)
    seq = read_steps(steps_path)
    write_records(output, seq, overwrite=overwrite)
    click.echo(f"{output}: {len(seq)} configurations")
