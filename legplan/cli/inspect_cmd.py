"""`legplan inspect FILE [--full]`: print any artefact's kind, summary and provenance; `--full`
adds its parameters, inputs and every dataset."""

from __future__ import annotations

import json
from collections import Counter

import click

from legplan.cli.options import input_artefact, json_opt, verbosity_opts


@click.command("inspect")
@click.argument("path", type=input_artefact)
@click.option("--full", is_flag=True, help="Also print the parameters, the inputs and every dataset.")
@json_opt
@verbosity_opts
def command(path, full, as_json):
    """Print an artefact: kind, schema, /summary first, then its command and seed; --full adds the
    parameters, inputs and datasets with shapes and units (--json prints everything)."""
    from legplan.artefacts import describe_artefact

    info = describe_artefact(path)
    if as_json:
        click.echo(json.dumps(info, indent=2))
        return
    click.echo(f"{info['path']}: {info['kind']} artefact, schema {info['schema_version']}, "
               f"legplan {info['legplan_version']}, created {info['created']}")
    if info["summary"]:
        click.echo("  summary:")
        width = max(len(name) for name in info["summary"])
        for name, entry in info["summary"].items():
            click.echo(f"    {name:<{width}}  {entry['value']:.6g} {entry['units']}".rstrip())
    click.echo(f"  command: {' '.join(info['command'])}")
    click.echo(f"  seed: {info['seed']}")
    if not full:
        groups = Counter(dataset["name"].split("/")[1] for dataset in info["datasets"])
        parts = ", ".join(f"/{name} {count}" for name, count in groups.most_common())
        click.echo(f"  datasets: {len(info['datasets'])} ({parts}); params, inputs and datasets: --full")
        return
    click.echo(f"  params: {json.dumps(info['params'], sort_keys=True)}")
    for record in info["inputs"]:
        click.echo(f"  input: {record['path']} ({record['kind']}, sha256 {record['sha256'][:12]})")
    click.echo("  datasets:")
    for dataset in info["datasets"]:
        units = f" [{dataset['units']}]" if dataset["units"] else ""
        shape = "x".join(map(str, dataset["shape"])) or "scalar"
        click.echo(f"    {dataset['name']}: {shape} {dataset['dtype']}{units}")
