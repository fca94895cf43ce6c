"""`legplan report ARTEFACT... -o DIR`: an HTML page of artefacts (verdict table, 3D views of planned
motions, provenance, /summary, figures)."""

from __future__ import annotations

import click

from legplan.cli.options import OutputPath, input_artefact, overwrite_opt, verbosity_opts


@click.command("report")
@click.argument("artefacts", nargs=-1, required=True, type=input_artefact)
@click.option("-o", "--output", required=True, type=OutputPath(file_okay=False, whole_directory=True),
              help="Report directory (index.html, PNGs, report.h5 with provenance).")
@click.option("--title", default="legplan report", show_default=True, help="Page title.")
@overwrite_opt
@verbosity_opts
@click.pass_context
def command(ctx, artefacts, output, title, overwrite):
    """Write an HTML report of ARTEFACTS into a directory (exit 1 if some figure or 3D view failed, 2 if an
    artefact is malformed)."""
    from legplan.cli.console import progress_bar, status, stderr_line
    from legplan.report import write_report
    from legplan.report.writer import check_report_dir

    check_report_dir(output, overwrite)
    with progress_bar("report") as progress:
        result = write_report(list(artefacts), output, title=title, overwrite=overwrite, progress=progress)
    figures = sum(len(s.figures) for s in result.sections)
    status(f"{len(result.sections)} artefacts, {figures} figures, {result.failures} figure failures "
           f"-> {result.directory}/index.html")
    for section in result.sections:
        for failure in section.failures:
            stderr_line(f"  {section.path}: figure {failure.name} failed: {failure.message}")
    if result.failures:
        ctx.exit(1)
