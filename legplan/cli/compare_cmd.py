"""`legplan compare A B [--tol NAME=VALUE ...] [--timings] [--json]`: regression check of two artefacts."""

from __future__ import annotations

import json

import click

from legplan.cli.options import input_artefact, json_opt, verbosity_opts


@click.command("compare")
@click.argument("path_a", metavar="A", type=input_artefact)
@click.argument("path_b", metavar="B", type=input_artefact)
@click.option("--tol", "tolerances", multiple=True, metavar="NAME=VALUE",
              help="Tolerance for metrics matching the glob NAME: '20%' relative or '0.001' absolute, "
                   "against max(|A|, |B|) (default 1e-6 + 1e-6 relative); naming a clock value judges it.")
@click.option("--timings", is_flag=True,
              help="Judge clock values too (summary times 0.05 s + 50%, per-item ones 0.5 s + 50%).")
@json_opt
@verbosity_opts
@click.pass_context
def command(ctx, path_a, path_b, tolerances, timings, as_json):
    """Compare two artefacts of one kind: /summary rows and per-item results (exit 1 if out of tolerance).

    For CI: the defaults judge every computed value within 1e-6 + 1e-6 relative, symmetric in A and
    B (|B - A| <= abs + rel * max(|A|, |B|)), so two runs of one command with the same inputs and
    seed pass whatever --jobs or --scheduler they used. Clock values (seconds, timings/*,
    mean_time, median_solve_time, ...) are listed as 'clock' but not judged unless --timings.
    """
    from legplan.report.compare import compare_artefacts, parse_tolerances

    result = compare_artefacts(path_a, path_b, parse_tolerances(tolerances), timings=timings)
    if as_json:
        click.echo(json.dumps(result.as_dict(), indent=2, default=float))
    else:
        _print_table(result)
    if not result.ok:
        ctx.exit(1)


def _cell(value) -> str:
    return f"{value:.6g}" if isinstance(value, float) else str(value)


def _print_table(result) -> None:
    header = ("", "metric", "A", "B", "units", "tolerance", "note")
    rows = [("clock" if not r.judged else "ok" if r.ok else "DIFF", r.name, _cell(r.a), _cell(r.b), r.units,
             r.tolerance, r.note) for r in result.rows]
    widths = [max(len(row[i]) for row in [header, *rows]) for i in range(len(header) - 1)]
    click.echo(f"{result.kind}: A = {result.a}, B = {result.b}")
    for row in [header, *rows]:
        click.echo("  ".join(cell.ljust(width) for cell, width in zip(row, widths)) + "  " + row[-1])
    failing = sum(r.judged and not r.ok for r in result.rows)
    click.echo(f"{'within tolerance' if result.ok else f'{failing} metric(s) out of tolerance'}")
