"""A test-only legplan-like click group: `fake make INPUTS... -o OUT [--value V] [--fail] [--items-failed]`.

It writes a small artefact with real provenance (via legplan.artefacts), so pipeline tests exercise
up-to-date detection without depending on any planner.
"""

import os
import sys
from pathlib import Path

import click

# `python -c` snippet that runs this group as if it were `legplan` (see run_pipeline's `entry`).
FAKE_ENTRY = (f"import sys; sys.path.insert(0, {str(Path(__file__).parent)!r}); "
              "from fake_stage import cli; cli(prog_name='legplan')")


@click.group()
def cli():
    """The stand-in for `legplan`."""


@cli.group("fake")
def fake():
    """Fake stages."""


@fake.command("make")
@click.argument("inputs", nargs=-1)
@click.option("-o", "--output", required=True)
@click.option("--overwrite", is_flag=True)
@click.option("--value", type=float, default=1.0)
@click.option("--fail", is_flag=True, help="Exit 2 without writing.")
@click.option("--items-failed", is_flag=True, help="Write the artefact, then exit 1.")
def make(inputs, output, overwrite, value, fail, items_failed):
    from legplan.artefacts import write_artefact, write_summary

    if fail:
        click.echo("fake failure: the planner blew up", err=True)
        sys.exit(2)
    scheduler = os.environ.get("LEGPLAN_SCHEDULER")  # what `pipeline run --scheduler` hands the stages
    with write_artefact(output, "series", params={"value": value, "scheduler": scheduler}, inputs=list(inputs),
                        overwrite=overwrite) as f:
        write_summary(f, {"value": (value, "m"), "inputs": len(inputs)})
    if items_failed:
        sys.exit(1)


if __name__ == "__main__":
    cli()
