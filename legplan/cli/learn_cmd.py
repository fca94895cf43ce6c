"""`legplan learn dataset|train`: the learned initializer of the TOWR-costs paper (Sec. IV, Algorithm 1).

    legplan learn dataset tasks/single_pallet_walk.yaml --n 2000 --seed 0 --iterations 100 -o d0.h5 --jobs 2
    legplan learn train d0.h5 --g-max auto --hidden 256,256 -o init1.h5
    legplan learn dataset tasks/single_pallet_walk.yaml --n 2000 --seed 0 --init init1.h5 --iterations 25 -o d1.h5
"""

from __future__ import annotations

import os

import click

from legplan.cli.console import status, stderr_line
from legplan.cli.main import EXIT_ITEMS_FAILED
from legplan.cli.options import batch_opts, input_artefact, output_opt, overwrite_opt, seed_opt, verbosity_opts
from legplan.errors import LegplanError


@click.group("learn")
@verbosity_opts
def command():
    """Learned initialization of the centroidal optimizer (kinds "dataset", "init")."""


@command.command("dataset")
@click.argument("space_path", metavar="SPACE", type=click.Path(dir_okay=False))
@click.option("--n", "count", type=click.IntRange(min=1), required=True, help="Tasks to sample and solve.")
@seed_opt
@click.option("--init", "init", default="heuristic", show_default=True, metavar="heuristic|INIT.h5",
              help="Initializer: the paper's Heuristic (A_h) or a trained init.h5 (A_θ).")
@click.option("--iterations", type=click.IntRange(min=1), default=None,
              help="LM iterations per planner stage (the paper's N_h = 100, N_θ = 25) [default: the planner's].")
@output_opt
@overwrite_opt
@batch_opts
@verbosity_opts
@click.pass_context
def dataset_cmd(ctx, space_path, count, seed, init, iterations, output, overwrite, jobs, scheduler, resume):
    """Sample N tasks of SPACE (a task-space YAML), solve each, write dataset.h5 (x, y, g(y), ...).

    A solve that does not converge is recorded (success false); exit 1 only when a task raised."""
    from legplan.artefacts import check_output
    from legplan.batch import Task
    from legplan.cli.batching import run_stage
    from legplan.learn.dataset import DatasetWorker, check_init, dataset_items, failed_item, solve_item, write_dataset
    from legplan.learn.space import read_space

    check_output(output, overwrite)
    space = read_space(space_path)
    check_init(init, space)
    items = dataset_items(space, count, seed)
    init_arg = os.path.abspath(init) if init.endswith(".h5") else init
    settings = {"space": space.record(), "n": count, "init": init, "iterations": iterations}
    inputs = [space_path, space.map] + ([init] if init.endswith(".h5") else [])
    task = Task(solve_item, failed_item, DatasetWorker, (space, init_arg, iterations))
    records, _ = run_stage(task, items, "learn dataset", output=output,
                           identity={"stage": "learn dataset", "seed": seed, **settings}, inputs=inputs, jobs=jobs,
                           scheduler=scheduler, resume=resume, overwrite=overwrite,
                           publish=lambda records: write_dataset(output, space, records, settings, seed, inputs,
                                                                 overwrite))
    converged = sum(bool(r["success"]) for r in records)
    raised = [r for r in records if "y" not in r]
    status(f"wrote {output}: {converged}/{len(records)} tasks converged")
    for r in raised:
        stderr_line(f"  task {r['index']}: failed: {r['reason']}")
    if raised:
        ctx.exit(EXIT_ITEMS_FAILED)


def _g_max(ctx, param, value):
    if value == "auto":
        return value
    try:
        number = float(value)
    except ValueError:
        raise click.BadParameter(f"expected 'auto' or a number, got {value!r}", ctx=ctx, param=param) from None
    if not number > 0:
        raise click.BadParameter(f"must be > 0, got {value!r}", ctx=ctx, param=param)
    return number


def _hidden(ctx, param, value):
    try:
        sizes = tuple(int(v) for v in value.split(","))
    except ValueError:
        sizes = ()
    if not 2 <= len(sizes) <= 3 or min(sizes) < 1:
        raise click.BadParameter(f"expected 2 or 3 layer sizes >= 1 like 256,256, got {value!r}", ctx=ctx, param=param)
    return sizes


@command.command("train")
@click.argument("dataset_path", metavar="DATASET", type=input_artefact)
@click.option("--g-max", "g_max", default="auto", show_default=True, callback=_g_max, metavar="auto|VALUE",
              help="Cost threshold of the filter, eq. (4); auto: median + 3 robust sigmas of the converged costs.")
@click.option("--hidden", default="256,256", show_default=True, callback=_hidden,
              help="Hidden layer sizes (2 or 3 layers).")
@click.option("--weights", "weights_path", type=click.Path(dir_okay=False), default=None,
              help="YAML of W per category (base_lin, base_ang, feet, forces; > 0), eq. (3).")
@click.option("--validation", type=click.FloatRange(0.0, 0.5), default=0.2, show_default=True,
              help="Fraction of the filtered tasks held out for validation.")
@seed_opt
@output_opt
@overwrite_opt
@verbosity_opts
def train_cmd(dataset_path, g_max, hidden, weights_path, validation, seed, output, overwrite):
    """Filter DATASET by g(y) <= g_max, fit the network of eq. (3), write init.h5 (numpy-readable)."""
    from legplan.artefacts import check_output
    from legplan.learn.train import train_initializer

    check_output(output, overwrite)
    if weights_path is not None and not os.path.isfile(weights_path):
        raise LegplanError(f"--weights: '{weights_path}' is not a file")
    report = train_initializer(dataset_path, output, g_max=g_max, hidden=hidden, weights_path=weights_path,
                               seed=seed, validation=validation, overwrite=overwrite)
    status(f"wrote {output}: {report['good']}/{report['tasks']} tasks with g <= {report['g_max']:.4g} "
           f"({report['converged']} converged); validation loss {report['validation_loss']:.3g} "
           f"(train {report['train_loss']:.3g}) on {report['validation_tasks']} held-out tasks")
