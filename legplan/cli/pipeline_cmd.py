"""`legplan pipeline run|plan`: run a chain of stages from `pipelines/*.yaml`, skipping up-to-date ones."""

from __future__ import annotations

import shlex
from pathlib import Path

import click

from legplan.cli.options import jobs_opt, verbosity_opts

_STYLE = {"ran": "green", "items_failed": "yellow", "up_to_date": "dim", "failed": "bold red",
          "skipped": "red"}


@click.group("pipeline")
def command():
    """Run declarative chains of legplan stages (pipelines/*.yaml)."""


def _default_out(pipeline_file: str) -> Path:
    return Path("outputs") / Path(pipeline_file).stem


@command.command("run")
@click.argument("pipeline_file", metavar="PIPELINE", type=click.Path(dir_okay=False))
@click.option("--out", "out_dir", type=click.Path(file_okay=False), default=None,
              help="Output directory (default: outputs/<pipeline file stem>).")
@click.option("--force", is_flag=True, help="Rerun every stage even if up to date.")
@click.option("--dry-run", is_flag=True, help="List what would run and why; run nothing.")
@jobs_opt
@verbosity_opts
@click.pass_context
def run_cmd(ctx, pipeline_file, out_dir, force, dry_run, jobs):
    """Run PIPELINE's stages in dependency order (exit 1 if a stage failed, 2 on a bad pipeline file).

    A stage is skipped when its output's recorded provenance (command, params, input sha256)
    matches what would run now; timestamps are never used.
    """
    from legplan.cli.console import progress_bar, stderr_line
    from legplan.pipeline import load_pipeline, plan_run, run_pipeline

    pipeline = load_pipeline(pipeline_file)
    out = Path(out_dir) if out_dir else _default_out(pipeline_file)
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
        result = run_pipeline(pipeline, out, force=force, jobs=jobs, progress=progress, on_result=show)
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
@click.argument("pipeline_file", metavar="PIPELINE", type=click.Path(dir_okay=False))
@click.option("--out", "out_dir", type=click.Path(file_okay=False), default=None,
              help="Output directory (default: outputs/<pipeline file stem>).")
@verbosity_opts
def show_cmd(pipeline_file, out_dir):
    """Print PIPELINE's stages in run order with their resolved commands and dependencies."""
    from legplan.pipeline import load_pipeline, resolve_stage

    pipeline = load_pipeline(pipeline_file)
    out = Path(out_dir) if out_dir else _default_out(pipeline_file)
    for spec in pipeline.stages:
        stage = resolve_stage(pipeline, spec, out)
        after = f" (after {', '.join(stage.depends_on)})" if stage.depends_on else ""
        click.echo(f"{stage.name}{after}: legplan {shlex.join(stage.argv)}")
