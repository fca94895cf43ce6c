"""`legplan pipeline run|plan`: run a chain of stages from `pipelines/*.yaml`, skipping up-to-date ones."""

from __future__ import annotations

import shlex
from pathlib import Path

import click

from legplan.cli.options import SCHEDULER_VARIABLE, OutputPath, ShippedPath, check_scheduler, jobs_opt, verbosity_opts

_STYLE = {"ran": "green", "items_failed": "yellow", "up_to_date": "dim", "failed": "bold red",
          "skipped": "red"}


@click.group("pipeline")
def command():
    """Run declarative chains of legplan stages (pipelines/*.yaml)."""


def _default_out(pipeline_file: str) -> Path:
    return Path("outputs") / Path(pipeline_file).stem


def _output_opts(func):
    """`-o/--output DIR` of a pipeline's outputs, with `--out` kept as a hidden deprecated alias."""
    func = click.option("--out", "legacy_out", type=OutputPath(file_okay=False), default=None, hidden=True,
                        help="Deprecated spelling of -o/--output.")(func)
    return click.option("-o", "--output", "out_dir", type=OutputPath(file_okay=False), default=None,
                        help="Output directory (default: outputs/<pipeline file stem>).")(func)


def _deprecated(old: str, new: str) -> None:
    from legplan.cli.console import stderr_line

    stderr_line(f"{old} is deprecated; use {new}", "Warning:", "yellow")


def _out_dir(pipeline_file: str, out_dir: str | None, legacy_out: str | None) -> Path:
    if legacy_out is not None:
        _deprecated("--out", "-o/--output")
        if out_dir is not None and out_dir != legacy_out:
            raise click.UsageError("give the output directory once (-o/--output)")
        out_dir = legacy_out
    return Path(out_dir) if out_dir else _default_out(pipeline_file)


@command.command("run")
@click.argument("pipeline_file", metavar="PIPELINE", type=ShippedPath("pipelines"))
@_output_opts
@click.option("--overwrite", is_flag=True, help="Rerun every stage, replacing its output, even if up to date.")
@click.option("--force", "legacy_force", is_flag=True, hidden=True, help="Deprecated spelling of --overwrite.")
@click.option("--dry-run", is_flag=True, help="List what would run and why; run nothing.")
@jobs_opt
@click.option("--scheduler", metavar="local|tcp://HOST:PORT", default=None, callback=check_scheduler,
              help="Run the items of every many-item stage on this dask scheduler ('local': a LocalCluster "
                   "of the stage's --jobs workers); handed to the stages, not recorded in their provenance.")
@verbosity_opts
@click.pass_context
def run_cmd(ctx, pipeline_file, out_dir, legacy_out, overwrite, legacy_force, dry_run, jobs, scheduler):
    """Run PIPELINE's stages in dependency order (exit 1 if a stage failed, 2 on a bad pipeline file).
    PIPELINE is a file or a shipped pipeline's name (gap_crossing, pallet_climb, ...).

    A stage is skipped when its output's recorded provenance (command, params, input sha256)
    matches what would run now; timestamps are never used.
    """
    from legplan.cli.console import progress_bar, stderr_line
    from legplan.pipeline import load_pipeline, plan_run, run_pipeline

    if legacy_force:
        _deprecated("--force", "--overwrite")
    force = overwrite or legacy_force
    out = _out_dir(pipeline_file, out_dir, legacy_out)
    pipeline = load_pipeline(pipeline_file)
    _check_commands(pipeline, out)
    if dry_run:
        for decision in plan_run(pipeline, out, force=force):
            verb = "run " if decision.run else "skip"
            click.echo(f"{verb} {decision.name}: {decision.reason}")
            click.echo(f"     legplan {shlex.join(decision.argv)}")
        return

    def show(result):
        stderr_line(result.line(), f"{result.status:>12}", _STYLE[result.status])

    with progress_bar(f"pipeline {pipeline.name}") as progress:
        result = run_pipeline(pipeline, out, force=force, jobs=jobs, progress=progress, on_result=show,
                              environment={SCHEDULER_VARIABLE: scheduler} if scheduler else None)
    for failed in result.failed:
        stderr_line(f"{failed.reason} (log: {failed.log})", f"stage '{failed.name}' failed:")
    if not result.ok:
        ctx.exit(1)


def _check_commands(pipeline, out: Path) -> None:
    """Every stage's command and parameters parsed by its click command (exit 2 on the first bad
    one) before anything runs; a stage's `-v` / `-q` must not change the pipeline's verbosity."""
    from legplan.cli.console import set_verbosity, verbosity
    from legplan.cli.main import cli
    from legplan.pipeline.commands import check_stage_commands

    level = verbosity()
    try:
        check_stage_commands(pipeline, out, cli)
    finally:
        set_verbosity(level)


@command.command("show")
@click.argument("pipeline_file", metavar="PIPELINE", type=ShippedPath("pipelines"))
@_output_opts
@verbosity_opts
def show_cmd(pipeline_file, out_dir, legacy_out):
    """Print PIPELINE's stages in run order with their resolved commands and dependencies."""
    from legplan.pipeline import load_pipeline, resolve_stage

    out = _out_dir(pipeline_file, out_dir, legacy_out)
    pipeline = load_pipeline(pipeline_file)
    for spec in pipeline.stages:
        stage = resolve_stage(pipeline, spec, out)
        after = f" (after {', '.join(stage.depends_on)})" if stage.depends_on else ""
        click.echo(f"{stage.name}{after}: legplan {shlex.join(stage.argv)}")
