"""`legplan step plan|show`: Bézier + Levenberg-Marquardt single-step motion planning (Bézier paper Sec. III)."""

from __future__ import annotations

import os

import click

from legplan.cli.options import batch_opts, input_artefact, output_opt, overwrite_opt, param_opt, verbosity_opts
from legplan.errors import LegplanError


@click.group("step")
def command():
    """Plan single-step motions between consecutive configurations of a step sequence."""


def read_step_pairs(map_path: str, steps_path: str, step_range: str | None):
    """The step sequence of STEPS, the indices of its consecutive pairs selected by `--steps`, and the
    robot and map as read to check them (loaded once: a command's task context takes them over); MAP
    must read as a valid map artefact. Shared by `step plan` and `baseline step`."""
    from legplan.artefacts.identity import check_same_map
    from legplan.robots.identity import check_same_robot
    from legplan.robots import load_robot
    from legplan.stepseq.sequence import read_steps
    from legplan.terrain import load_map

    terrain_map = load_map(map_path)  # every layer checked (finite, shapes) before any work
    seq = read_steps(steps_path)
    check_same_map(steps_path, map_path)
    robot = load_robot(seq.robot)
    check_same_robot(steps_path, seq.robot_sha256, robot)
    if len(seq) < 2:
        raise LegplanError(f"{steps_path}: field 'q' needs at least 2 configurations, got {len(seq)}")
    return seq, _parse_range(step_range, len(seq) - 1, steps_path), robot, terrain_map


def _parse_range(text: str | None, pairs: int, steps_path: str) -> range:
    """'a:b' (pairs a..b-1, either end optional) or 'i' over the `pairs` consecutive pairs."""
    if text is None:
        return range(pairs)
    try:
        if ":" in text:
            a, b = text.split(":", 1)
            start, stop = int(a) if a else 0, int(b) if b else pairs
        else:
            start = int(text)
            stop = start + 1
    except ValueError:
        raise LegplanError(f"--steps: expected 'a:b' or an index, got {text!r}") from None
    if not 0 <= start < stop <= pairs:
        raise LegplanError(f"--steps {text}: {steps_path} has {pairs} consecutive pairs (indices 0..{pairs - 1})")
    return range(start, stop)


@command.command("plan")
@click.argument("map_path", metavar="MAP", type=input_artefact)
@click.argument("steps_path", metavar="STEPS", type=input_artefact)
@output_opt
@overwrite_opt
@batch_opts
@click.option("--steps", "step_range", default=None, help="Pairs to plan, 'a:b' (python slice) or 'i'.")
@param_opt("Override a planner parameter (Table I: samples, max_degree, max_iterations, lambda_init, "
           "lambda_drop, lambda_boost, epsilon; also eps_num, clearance, ...).")
@verbosity_opts
@click.pass_context
def plan_cmd(ctx, map_path, steps_path, output, overwrite, jobs, scheduler, resume, step_range, params):
    """Plan every consecutive pair of STEPS on MAP; write motion.h5 (exit 1 if any step failed).

    Each worker plans on one core (one BLAS thread); use --jobs or --scheduler for parallelism.
    """
    from legplan.artefacts import check_output
    from legplan.batch import Task
    from legplan.cli.batching import run_stage
    from legplan.cli.console import status, stderr_line
    from legplan.stepplan.batch import StepWorker, failed_item, plan_item, step_items, write_motion
    from legplan.stepplan.params import StepPlanParams

    check_output(output, overwrite)
    settings = StepPlanParams.from_overrides(params)
    seq, indices, robot, terrain_map = read_step_pairs(map_path, steps_path, step_range)
    task = Task(plan_item, failed_item, StepWorker, (seq.robot, os.path.abspath(map_path), settings))
    task.provide(StepWorker.of(robot, terrain_map, settings))  # the robot and map read once
    inputs = [map_path, steps_path]
    records, summary = run_stage(
        task, step_items(seq, indices), "planning steps", output=output,
        identity={"stage": "step plan", "params": settings.as_dict()}, inputs=inputs, jobs=jobs,
        scheduler=scheduler, resume=resume, overwrite=overwrite,
        publish=lambda records: write_motion(output, records, seq.robot, settings, inputs=inputs, overwrite=overwrite))
    failed = [r for r in records if not r["success"]]
    status(f"{summary['steps_succeeded']}/{summary['steps_planned']} steps planned; "
           f"worst dense stance-foot slip {summary['worst_violation'][0] * 1e3:.3f} mm; "
           f"median {summary['median_time'][0]:.2f} s, mean {summary['mean_time'][0]:.2f} s -> {output}")
    for r in failed:
        stderr_line(f"  step {r['index']}: {r['reason']}")
    if failed:
        ctx.exit(1)


@command.command("show")
@click.argument("motion_path", metavar="MOTION", type=input_artefact)
@click.option("--map", "map_path", required=True, type=input_artefact, help="The map the motion was planned on.")
@output_opt
@overwrite_opt
@verbosity_opts
def show_cmd(motion_path, map_path, output, overwrite):
    """PNG of MOTION: foot and CoM tracks over the terrain (side view) and Fig. 4 time histograms."""
    from legplan.artefacts import check_output, open_artefact
    from legplan.artefacts.identity import check_same_map
    from legplan.robots import load_robot
    from legplan.stepplan.batch import read_motion
    from legplan.stepplan.figures import plot_motion
    from legplan.terrain import load_map

    check_output(output, overwrite)
    with open_artefact(motion_path, kind="motion") as f:
        robot_name = str(f.attrs.get("robot", ""))
    if not robot_name:
        raise LegplanError(f"{motion_path}: missing root attribute 'robot'")
    records = read_motion(motion_path)
    check_same_map(motion_path, map_path, what="planned")
    plot_motion(output, load_robot(robot_name), load_map(map_path), records, overwrite=overwrite)
