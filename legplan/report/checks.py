"""The table of an artefact's independent checks, each quantity with the tolerance it was judged
against: traj.h5's `tasks/*/check/<metric>` datasets carry `tolerance`, `bound` ("upper": worst
must not exceed it, "lower": must not fall below it) and `passed` attributes
(`legplan.dyn.artefact`).

Per metric one row: the worst value over the tasks (largest for an upper bound, smallest for a
lower), its units, the tolerance and bound, and how many tasks passed it, naming the failing ones.
Metrics recorded without a tolerance are listed as "recorded, not judged".
"""

from __future__ import annotations

import math
import os

import h5py
import numpy as np

SHOWN_FAILING = 5


def check_rows(path: str | os.PathLike) -> list[dict]:
    """[{"metric", "worst", "units", "tolerance", "bound", "passed", "judged", "failing": [task names]}]
    in metric order; [] when the artefact records no check."""
    from legplan.artefacts import open_artefact

    rows: dict[str, dict] = {}
    with open_artefact(path) as handle:
        tasks = handle.get("tasks")
        if not isinstance(tasks, h5py.Group):
            return []
        for task in sorted(tasks):
            check = tasks[task].get("check")
            if not isinstance(check, h5py.Group):
                continue
            for name in sorted(check):
                dataset = check[name]
                if not isinstance(dataset, h5py.Dataset) or dataset.shape != ():
                    continue
                row = rows.setdefault(name, {"metric": name, "values": [], "units": _text(dataset.attrs.get("units", "")),
                                             "tolerance": None, "bound": "", "passed": 0, "judged": 0, "failing": []})
                value = float(dataset[()])
                row["values"].append(value)
                if "tolerance" in dataset.attrs:
                    row["tolerance"] = float(dataset.attrs["tolerance"])
                    row["bound"] = _text(dataset.attrs.get("bound", "upper"))
                    row["judged"] += 1
                    if bool(dataset.attrs.get("passed", False)):
                        row["passed"] += 1
                    else:
                        row["failing"].append(task)
    out = []
    for row in rows.values():
        values = [v for v in row.pop("values") if math.isfinite(v)]
        pick = min if row["bound"] == "lower" else max
        row["worst"] = pick(values) if values else float("nan")
        out.append(row)
    return out


def check_table(rows: list[dict]) -> str:
    """HTML table of `check_rows`; "" without rows."""
    from html import escape

    if not rows:
        return ""
    body = []
    for row in rows:
        judged = row["judged"] > 0
        tolerance = (f"{'≤' if row['bound'] != 'lower' else '≥'} {row['tolerance']:.4g}" if judged
                     else "recorded, not judged")
        failing = row["failing"][:SHOWN_FAILING]
        more = f" and {len(row['failing']) - SHOWN_FAILING} more" if len(row["failing"]) > SHOWN_FAILING else ""
        verdict = (f"{row['passed']}/{row['judged']} passed" + (f" (failing: {', '.join(failing)}{more})" if failing else "")
                   if judged else "–")
        state = "" if not judged else ' class="ok"' if not row["failing"] else ' class="bad"'
        worst = f"{row['worst']:.4g}" if np.isfinite(row["worst"]) else "–"
        body.append(f"<tr><td>{escape(row['metric'])}</td><td class=\"num\">{worst}</td><td>{escape(row['units'])}</td>"
                    f"<td>{escape(tolerance)}</td><td{state}>{escape(verdict)}</td></tr>")
    return ('<table class="checks verdict"><tr><th>check</th><th>worst</th><th>units</th><th>tolerance</th>'
            f'<th>tasks</th></tr>{"".join(body)}</table>')


def _text(value) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)
