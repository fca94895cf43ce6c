"""`legplan export ARTEFACT -o OUT.csv|OUT.h5 [--rate HZ]`: a motion, traj or sim as time series."""

from __future__ import annotations

import click

from legplan.cli.options import input_artefact, number, output_opt, overwrite_opt, verbosity_opts
from legplan.parameters import DURATION, RATE


@click.command("export")
@click.argument("path", metavar="ARTEFACT", type=input_artefact)
@output_opt
@click.option("--rate", type=number(RATE), default=100.0, show_default=True,
              help="Samples per second.")
@click.option("--step-duration", type=number(DURATION), default=1.0, show_default=True,
              help="Seconds given to each step of a motion.h5 (its curves are geometric, uniform in s).")
@overwrite_opt
@verbosity_opts
def command(path, output, rate, step_duration, overwrite):
    """Export ARTEFACT (motion.h5, traj.h5 or sim.h5) as time series at --rate: base pose, joint
    positions (by inverse kinematics for a traj), feet and contact flags; CSV or HDF5 by the
    output's suffix (legplan.export)."""
    from legplan.artefacts import check_output
    from legplan.cli.console import status
    from legplan.export import export_series, output_format, write_series

    output_format(output)
    check_output(output, overwrite)
    series = export_series(path, rate, step_duration=step_duration)
    write_series(series, output, source=path, params={"rate": rate, "step_duration": step_duration},
                 overwrite=overwrite)
    samples = sum(len(one.columns["t"]) for one in series)
    status(f"wrote {output}: {len(series)} series, {samples} samples at {rate:g} Hz")
