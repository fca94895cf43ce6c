"""The shipped pipelines/*.yaml load, and every stage's argv parses against the real CLI."""

from pathlib import Path

import click
import pytest

from legplan.cli.main import cli
from legplan.pipeline import load_pipeline, plan_run

PIPELINES = sorted((Path(__file__).resolve().parents[2] / "pipelines").glob("*.yaml"))


def test_the_pipelines_are_shipped():
    assert {p.stem for p in PIPELINES} >= {"gap_crossing", "nav_30m", "compare_baselines", "pallet_climb"}


@pytest.mark.parametrize("path", PIPELINES, ids=[p.stem for p in PIPELINES])
def test_every_stage_is_a_valid_legplan_command(path, tmp_path):
    pipeline = load_pipeline(path)
    decisions = plan_run(pipeline, tmp_path)
    assert decisions and all(d.run for d in decisions)
    for decision in decisions:
        command, args = cli, list(decision.argv)
        parent = click.Context(cli, info_name="legplan")
        while isinstance(command, click.Group):
            name, command, args = command.resolve_command(parent, args)
            parent = click.Context(command, info_name=name, parent=parent)
        command.make_context(command.name, args, parent=parent.parent)  # raises on a bad option


def test_compare_baselines_shares_gap_crossings_map_and_steps(tmp_path):
    """`make run` runs gap_crossing into OUT/gap_crossing, then compare_baselines into
    OUT/compare_baselines: the latter's map and steps stages are the former's, same argv and output,
    so they are up to date there and never computed twice."""
    from legplan.pipeline import resolve_stage

    root = Path(__file__).resolve().parents[2] / "pipelines"
    gap, compare = load_pipeline(root / "gap_crossing.yaml"), load_pipeline(root / "compare_baselines.yaml")
    ours = {name: resolve_stage(gap, gap.stage(name), tmp_path / "gap_crossing") for name in ("map", "steps")}
    theirs = {name: resolve_stage(compare, compare.stage(name), tmp_path / "compare_baselines")
              for name in ("gap_map", "steps")}
    assert theirs["gap_map"].argv == ours["map"].argv and theirs["steps"].argv == ours["steps"].argv
    assert theirs["steps"].output == tmp_path / "gap_crossing" / "steps.h5"
