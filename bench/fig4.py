"""The paper's Fig. 4 regenerated through the CLI: the step climb (Single Pallet, Sec. V-2) planned with
and without the paper's costs, both executed in MuJoCo, and the figure with their forces, planned and
executed angular rates and tracking errors.

    .venv/bin/python bench/fig4.py [--work outputs/fig4] [--no-append]

1. `legplan map build maps/single_pallet.yaml`;
2. per costs setting (paper, none): `legplan dyn plan MAP --gait walk --strides 4 --duration 5.5
   --start -1.0 0.3 0.3 --goal 0.6 0 0 --costs C` (bench/sim.py's and bench/dyn.py's single pallet walk)
   and `legplan dyn simulate`;
3. `legplan dyn show traj_paper.h5 traj_none.h5 --sim sim_paper.h5 --sim sim_none.h5` into
   docs/figures/fig4_single_pallet_walk.png (Fig. 4 (a)–(d) from the plans, (e)–(h) from the runs).

Per setting: whether it planned (solved, check passed) and executed (goal reached without a fall),
the planned peak |f_x|, |f_y|, |f_z| over the feet and peak |ω_x|, |ω_y| of the base (Fig. 4 (a)–(d)),
the executed peak roll and pitch rates, and the rms and max base tracking errors (Fig. 4 (e)–(f)).
Writes bench/results/fig4.json and the fig4 section of BENCHMARKS.md.
"""

from __future__ import annotations

import argparse
import datetime
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
from common import ROOT, code_version, load_average, machine, update_benchmarks, write_result

TASK = ["--gait", "walk", "--strides", "4", "--duration", "5.5", "--start", "-1.0", "0.3", "0.3",
        "--goal", "0.6", "0", "0"]
FIGURE = ROOT / "docs" / "figures" / "fig4_single_pallet_walk.png"
SETTINGS = ("paper", "none")   # run A (solid) and run B (dashed) of the figure


def legplan(*args) -> int:
    """Run one `legplan` command of this interpreter's venv; its exit code (1: the task failed)."""
    command = [os.fspath(Path(sys.executable).parent / "legplan"), *map(str, args), "-q"]
    code = subprocess.run(command).returncode
    if code not in (0, 1):
        sys.exit(f"{' '.join(command[1:3])} failed with exit {code}")
    return code


def measure(traj: Path, sim: Path) -> dict:
    """The figure's quantities of one setting (module docstring)."""
    import h5py

    with h5py.File(traj, "r") as ft, h5py.File(sim, "r") as fs:
        plan, run = ft["tasks/0000"], fs["tasks/0000"]
        row = {"planned": bool(plan.attrs["success"]), "executed": bool(run.attrs["success"]),
               "reason": str(run.attrs["reason"])}
        if "samples" in plan:
            forces = np.abs(plan["samples/forces"][()])
            omega = np.abs(plan["samples/base_ang_vel"][()])
            row.update({f"peak_f{a}": float(forces[..., k].max()) for k, a in enumerate("xyz")})
            row.update({"peak_roll_rate": float(omega[:, 0].max()), "peak_pitch_rate": float(omega[:, 1].max())})
        if "series" in run:
            executed = np.abs(run["series/base_ang_vel"][()])
            row.update({"executed_peak_roll_rate": float(executed[:, 0].max()),
                        "executed_peak_pitch_rate": float(executed[:, 1].max())})
            for name in ("rms_position_error", "max_position_error", "rms_orientation_error",
                         "max_orientation_error", "saturation"):
                row[name] = float(run.attrs[name])
    return row


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", default="outputs/fig4", help="folder of the artefacts")
    parser.add_argument("--no-append", action="store_true", help="do not touch BENCHMARKS.md")
    args = parser.parse_args()
    work = (ROOT / args.work).resolve()
    work.mkdir(parents=True, exist_ok=True)
    load_start, started = load_average(), datetime.datetime.now(datetime.timezone.utc)
    map_h5 = work / "map.h5"
    legplan("map", "build", ROOT / "maps" / "single_pallet.yaml", "-o", map_h5, "--overwrite")
    rows = {}
    for costs in SETTINGS:
        traj, sim = work / f"traj_{costs}.h5", work / f"sim_{costs}.h5"
        legplan("dyn", "plan", map_h5, *TASK, "--costs", costs, "-o", traj, "--overwrite")
        legplan("dyn", "simulate", traj, map_h5, "-o", sim, "--overwrite")
        rows[costs] = measure(traj, sim)
        print(f"{costs}: {rows[costs]}", file=sys.stderr)
    FIGURE.parent.mkdir(parents=True, exist_ok=True)
    legplan("dyn", "show", *(work / f"traj_{c}.h5" for c in SETTINGS),
            *(x for c in SETTINGS for x in ("--sim", work / f"sim_{c}.h5")), "-o", FIGURE, "--overwrite")
    result = {"machine": machine(), "commit": code_version(), "date": started.strftime("%Y-%m-%d %H:%M UTC"),
              "load_start": load_start, "load_end": load_average(), "figure": os.fspath(FIGURE.relative_to(ROOT)),
              "rows": rows}
    write_result("fig4", result)
    if not args.no_append:
        update_benchmarks("fig4", markdown(result))
    print(markdown(result))


def markdown(result: dict) -> str:
    def value(row, key, fmt):
        return format(row[key], fmt) if key in row else "—"

    lines = [f"## fig4 — the paper's Fig. 4 on the current formulation (`bench/fig4.py`, {result['date']}, "
             f"{result['machine']}, {result['commit']}, load {result['load_start']:.1f} → {result['load_end']:.1f})",
             "",
             "The step climb (single pallet walk (−1.0, 0.3, 0.3) → (0.6, 0, 0), 4 strides, 5.5 s) planned by "
             "`legplan dyn plan` with and without the paper's costs and executed by `legplan dyn simulate` (ANYmal "
             f"at its URDF's 40 N m); figure: [{result['figure']}]({result['figure']}) (`legplan dyn show` with "
             "`--sim`: (a)–(d) the plans, (e)–(h) the runs). Peaks are of |value| over the whole plan or run; "
             "outcomes and tracking do not depend on the machine's load (the simulation is deterministic).", "",
             "| costs | planned | executed | peak f_x / f_y / f_z (N) | peak ω_x / ω_y planned (rad/s) | "
             "peak ω_x / ω_y executed (rad/s) | rms / max position error (m) | rms / max orientation error (rad) | "
             "τ saturated |", "|---|---|---|---|---|---|---|---|---|"]
    for costs, r in result["rows"].items():
        if "saturation" not in r:   # not executed
            lines.append(f"| {costs} | {r['planned']} | {r['reason']} | | | | | | |")
            continue
        lines.append(
            f"| {costs} | {r['planned']} | {'yes' if r['executed'] else r['reason']} | "
            f"{value(r, 'peak_fx', '.0f')} / {value(r, 'peak_fy', '.0f')} / {value(r, 'peak_fz', '.0f')} | "
            f"{value(r, 'peak_roll_rate', '.2f')} / {value(r, 'peak_pitch_rate', '.2f')} | "
            f"{value(r, 'executed_peak_roll_rate', '.2f')} / {value(r, 'executed_peak_pitch_rate', '.2f')} | "
            f"{value(r, 'rms_position_error', '.4f')} / {value(r, 'max_position_error', '.4f')} | "
            f"{value(r, 'rms_orientation_error', '.3f')} / {value(r, 'max_orientation_error', '.3f')} | "
            f"{100 * r['saturation']:.1f} % |")
    return "\n".join(lines)


if __name__ == "__main__":
    main()
