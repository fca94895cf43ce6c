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
from legplan.cli.options import (OutputPath, ShippedPath, batch_opts, init_opt, input_artefact, number, optimize_phases_opt,
                                 output_opt, overwrite_opt, param_opt, seed_opt, verbosity_opts, warm_stage_opt)
from legplan.cli.options import count as count_option
from legplan.parameters import COST
from legplan.errors import LegplanError

CYCLE_FILES = ("dataset_*.h5", "init_*.h5", "cycles.json")  # what `learn cycle` writes into its -o folder


@click.group("learn")
@verbosity_opts
def command():
    """Learned initialization of the centroidal optimizer (kinds "dataset", "init")."""


@command.command("dataset")
@click.argument("space_path", metavar="SPACE", type=ShippedPath("tasks"))
@click.option("--n", "count", type=count_option("items"), required=True, help="Tasks to sample and solve.")
@seed_opt
@init_opt
@click.option("--iterations", type=count_option("iterations"), default=None,
              help="LM iterations per task, all planner stages together (the paper's N_h = 100, N_θ = 25) [default: each stage's own cap].")
@warm_stage_opt
@optimize_phases_opt
@output_opt
@overwrite_opt
@batch_opts
@verbosity_opts
@click.pass_context
def dataset_cmd(ctx, space_path, count, seed, init, iterations, warm_stage, optimize_phases, output, overwrite, jobs,
                scheduler, resume):
    """Sample N tasks of SPACE (a task-space YAML), solve each, write dataset.h5 (x, y, g(y), ...).

    A solve that does not converge is recorded (success false); exit 1 only when a task raised."""
    from legplan.artefacts import check_output
    from legplan.learn.dataset import check_init, check_space_sizes, make_dataset
    from legplan.learn.initializers import check_warm_stage
    from legplan.learn.space import read_space

    check_output(output, overwrite)
    check_warm_stage(warm_stage, init)
    space = read_space(space_path)
    check_space_sizes(space, space_path, warm_stage, optimize_phases)
    check_init(init, space)
    records = make_dataset(space, space_path, count, seed, init, iterations, output, warm_stage=warm_stage,
                           optimize_phases=optimize_phases, overwrite=overwrite,
                           run=_runner(jobs, scheduler, resume, overwrite))
    converged = sum(bool(r["success"]) for r in records)
    status(f"wrote {output}: {converged}/{len(records)} tasks converged")
    for r in records:
        if "y" not in r:
            stderr_line(f"  task {r['index']}: failed: {r['reason']}")
    if any("y" not in r for r in records):
        ctx.exit(EXIT_ITEMS_FAILED)


def _runner(jobs, scheduler, resume, overwrite):
    """The batch runner of the command's `--jobs`/`--scheduler`/`--resume` (progress bar, resume hint)."""
    from functools import partial

    from legplan.cli.batching import run_stage

    return partial(run_stage, jobs=jobs, scheduler=scheduler, resume=resume, overwrite=overwrite)


def _g_max(ctx, param, value):
    if value == "auto":
        return value
    return number(COST).convert(value, param, ctx)  # finite and > 0, or exit 2


def _hidden(ctx, param, value):
    try:
        sizes = tuple(int(v) for v in value.split(","))
    except ValueError:
        sizes = ()
    if not 2 <= len(sizes) <= 3 or min(sizes) < 1:
        raise click.BadParameter(f"expected 2 or 3 layer sizes >= 1 like 256,256, got {value!r}", ctx=ctx, param=param)
    from legplan.budget import check_size
    from legplan.learn.network import weight_count

    check_size("weights", weight_count(1, sizes, 1), f"--hidden {value}")  # before any work; `fit` checks again
    return sizes


@command.command("train")
@click.argument("dataset_paths", metavar="DATASET...", type=input_artefact, nargs=-1, required=True)
@click.option("--g-max", "g_max", default="auto", show_default=True, callback=_g_max, metavar="auto|VALUE",
              help="Cost threshold of the filter, eq. (4); auto: the tail of the cost given the task "
                   "(median + 3 robust sigmas of g - g_fit(x), g_fit quadratic in x).")
@click.option("--hidden", default="256,256", show_default=True, callback=_hidden,
              help="Hidden layer sizes (2 or 3 layers).")
@click.option("--weights", "weights_path", type=click.Path(dir_okay=False), default=None,
              help="YAML of W per category (base_lin, base_ang, feet, forces, phases; > 0), eq. (3).")
@click.option("--validation", type=number("[0, 0.5]"), default=0.2, show_default=True,
              help="Fraction of the filtered tasks held out for validation.")
@param_opt("A fit parameter (legplan.learn.network.FitParams): model (network|polynomial), degree and ridge "
           "(the polynomial's), alpha (the network's L2 penalty), scale (category|order: output normalization), "
           "ensemble (networks averaged), e.g. --param model=polynomial --param degree=3.")
@seed_opt
@output_opt
@overwrite_opt
@verbosity_opts
def train_cmd(dataset_paths, g_max, hidden, weights_path, validation, params, seed, output, overwrite):
    """Filter DATASET by g(y) <= g_max, fit the network of eq. (3), write init.h5 (numpy-readable).

    Several datasets of the same tasks (a cycle's) are trained on each task's best converged outcome."""
    from legplan.artefacts import check_output
    from legplan.learn.network import FitParams
    from legplan.learn.train import train_initializer
    from legplan.specio import apply_overrides

    fit_params = apply_overrides(FitParams, params, "--param", "fit")
    check_output(output, overwrite)
    if weights_path is not None and not os.path.isfile(weights_path):
        raise LegplanError(f"--weights: '{weights_path}' is not a file")
    report = train_initializer(dataset_paths, output, g_max=g_max, hidden=hidden, weights_path=weights_path,
                               seed=seed, validation=validation, overwrite=overwrite, fit_params=fit_params)
    status(f"wrote {output}: {report['good']}/{report['tasks']} tasks with {_filtered(report)} "
           f"({report['converged']} converged); validation loss {report['validation_loss']:.3g} "
           f"(train {report['train_loss']:.3g}) on {report['validation_tasks']} held-out tasks")


@command.command("ship")
@click.argument("init_path", metavar="INIT", type=input_artefact)
@click.argument("held_out_path", metavar="HELD_OUT", type=input_artefact)
@click.option("-o", "--output", required=True, type=OutputPath(file_okay=False, files=("*.h5",)),
              help="Directory to write NAME.h5 into (NAME: the task space's name).")
@overwrite_opt
@verbosity_opts
def ship_cmd(init_path, held_out_path, output, overwrite):
    """Ready a trained INIT to ship: NAME.h5, the network with its training's provenance and held-out results.

    HELD_OUT is a dataset solved from INIT on tasks it was not trained on (`learn dataset --init INIT
    --seed S` with another seed). Copied into the shipped tasks/initializers/, `--init NAME` uses it."""
    from legplan.learn.shipping import ship_initializer

    record = ship_initializer(init_path, held_out_path, output, overwrite=overwrite)
    status(f"wrote {output}/{record['name']}.h5: held out {_held_out_line(record['held_out'])}")


@command.command("shipped")
@verbosity_opts
def shipped_cmd():
    """List the trained initializers that ship with legplan (`--init NAME`), with their held-out results."""
    from legplan.learn.shipping import shipped_records

    records = shipped_records()
    if not records:
        click.echo("no trained initializer ships with this installation")
    for record in records:
        trained = record["trained"]
        click.echo(f"{record['name']}: {record['space']['gait']}, {record['space']['strides']} strides, "
                   f"{record['space']['duration']:g} s, robot {record['space']['robot']}; trained by "
                   f"`{' '.join(trained['command'][1:])}` (seed {trained['seed']}); held out "
                   f"{_held_out_line(record['held_out'])}")


def _held_out_line(held: dict) -> str:
    def shown(key, form):
        return "-" if held.get(key) is None else format(held[key], form)

    return (f"{held['tasks']:g} tasks, {shown('success_rate', '.0%')} converged, median "
            f"{shown('median_iterations', 'g')} iterations, {shown('median_seconds', '.2f')} s, max/median cost "
            f"{shown('cost_max_over_median', '.2f')}")


def _filtered(report: dict) -> str:
    from legplan.learn.network import filter_rule

    return filter_rule(report["g_max"], bool(report["g_max_conditional"]))


@command.command("cycle")
@click.argument("space_path", metavar="SPACE", type=ShippedPath("tasks"))
@click.option("--cycles", type=count_option("iterations"), default=3, show_default=True, help="Train-and-solve cycles K.")
@click.option("--n", "count", type=count_option("items"), required=True, help="Tasks X (the same in every cycle).")
@seed_opt
@click.option("--heuristic-iterations", type=count_option("iterations"), default=100, show_default=True,
              help="N_h: iterations per task (all planner stages) from the Heuristic.")
@click.option("--learned-iterations", type=count_option("iterations"), default=25, show_default=True,
              help="N_θ: iterations per task (all planner stages) from the learned initializer.")
@click.option("--g-max", "g_max", default="auto", show_default=True, callback=_g_max, metavar="auto|VALUE",
              help="Cost threshold of the filter, eq. (4), in every cycle.")
@click.option("--hidden", default="256,256", show_default=True, callback=_hidden,
              help="Hidden layers of the first network (trained on the Heuristic's outcomes).")
@click.option("--hidden-later", default="256,256,256", show_default=True, callback=_hidden,
              help="Hidden layers of the later networks (more tasks pass the filter).")
@click.option("--weights", "weights_path", type=click.Path(dir_okay=False), default=None,
              help="YAML of W per category, eq. (3).")
@optimize_phases_opt
@param_opt("A fit parameter of every cycle's training (legplan.learn.network.FitParams), as for learn train.")
@click.option("-o", "--output", required=True, type=OutputPath(file_okay=False, files=CYCLE_FILES),
              help="Directory of the cycle's artefacts: dataset_0.h5, init_1.h5, dataset_1.h5, ..., cycles.json.")
@overwrite_opt
@batch_opts
@verbosity_opts
def cycle_cmd(space_path, cycles, count, seed, heuristic_iterations, learned_iterations, g_max, hidden, hidden_later,
              weights_path, optimize_phases, params, output, overwrite, jobs, scheduler, resume):
    """Algorithm 1 (TRAININITIALIZER): Y ← solve(A_h(X); N_h), then K times filter, train, Y ← solve(A_θ(X); N_θ).

    Each cycle trains on every task's best converged outcome so far (all earlier datasets), so a
    cycle never trains on a worse solution of a task than an earlier one found. Keeps every dataset
    and initializer in OUTPUT; cycles.json holds per cycle the success rate, median iterations and
    time of converged tasks and their cost quantiles. --resume reuses the
    artefacts already written and continues an interrupted dataset."""
    from legplan.learn.cycle import run_cycle
    from legplan.learn.network import FitParams
    from legplan.specio import apply_overrides

    fit_params = apply_overrides(FitParams, params, "--param", "fit")
    run_cycle(space_path, output, count=count, cycles=cycles, seed=seed, heuristic_iterations=heuristic_iterations,
              learned_iterations=learned_iterations, g_max=g_max, hidden=hidden, hidden_later=hidden_later,
              weights_path=weights_path, optimize_phases=optimize_phases, fit_params=fit_params, overwrite=overwrite,
              resume=resume,
              run=_runner(jobs, scheduler, resume, overwrite), report=status)
