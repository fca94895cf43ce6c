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
