"""Generic report figures (matplotlib `Figure`, no pyplot state): gridded layers, per-item times and
violations, and the fallback listing of an artefact's datasets."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
from matplotlib.figure import Figure

from legplan.artefacts import open_artefact
from legplan.terrain.grid import Grid2D
from legplan.report.items import read_items


def new_figure(width: float, height: float) -> Figure:
    return Figure(figsize=(width, height), layout="constrained")


def grid_extent(dataset: h5py.Dataset) -> list[float]:
    """imshow extent of a grid whose `origin` is cell [0, 0]'s centre and `resolution` its size."""
    x0, y0 = np.asarray(dataset.attrs["origin"], float)[:2]
    return list(Grid2D((x0, y0), float(dataset.attrs["resolution"]), dataset.shape[:2]).extent)


def grid_figure(path: Path, png: Path, layers: list[tuple[str, str, str]]) -> str | None:
    """One panel per present 2-D grid dataset `(name, title, colormap)`, in world coordinates."""
    with open_artefact(path) as handle:
        present = [(handle[name], title, cmap) for name, title, cmap in layers
                   if name in handle and handle[name].ndim == 2 and "resolution" in handle[name].attrs]
        if not present:
            return None
        fig = new_figure(5.0 * len(present), 4.2)
        for ax, (dataset, title, cmap) in zip(fig.subplots(1, len(present), squeeze=False)[0], present):
            image = ax.imshow(dataset[()], origin="lower", extent=grid_extent(dataset), cmap=cmap,
                              interpolation="nearest")
            units = dataset.attrs.get("units", "")
            fig.colorbar(image, ax=ax, shrink=0.8, label=f"{title} [{units}]" if units else title)
            ax.set_title(title)
            ax.set_xlabel("x [m]")
            ax.set_ylabel("y [m]")
        names = ", ".join(dataset.name for dataset, _, _ in present)
    fig.savefig(png, dpi=100)
    return f"Grid layers: {names}."


def items_figure(path: Path, png: Path, time_key: str, violation_key: str | None, unit: str,
                 noun: str, *, histogram: bool = True, items: dict | None = None, what: str = "") -> str | None:
    """Per-item planning-time histogram (succeeded / failed stacked, as the Bézier paper's Fig. 4;
    left out with `histogram=False` where another figure of the artefact draws it) and, when
    `violation_key` is present, the violation of every item. `items`: the artefact's items when the
    caller reads other numbers than `read_items` (e.g. a refinement's), `what` names them."""
    if items is None:
        with open_artefact(path) as handle:
            items = read_items(handle)
    rows = [item for item in items.values() if time_key in item]
    if not rows:
        return None
    nouns = noun[:-1] + "ies" if noun.endswith("y") else noun + "s"
    times = np.array([item[time_key] for item in rows])
    ok = np.array([item["success"] for item in rows])
    violations = np.array([item.get(violation_key, np.nan) for item in rows]) if violation_key else None
    drawn_violations = violations is not None and np.isfinite(violations).any()
    panels = int(histogram) + int(drawn_violations)
    if not panels:
        return None
    fig = new_figure(5.5 * panels, 3.8)
    axes = list(fig.subplots(1, panels, squeeze=False)[0])
    if histogram:
        ax = axes.pop(0)
        top = max(float(np.nanmax(times)), 1e-6)
        ax.hist([times[ok], times[~ok]], bins=np.linspace(0.0, top * 1.0001, 21), stacked=True,
                color=["tab:blue", "tab:red"], label=["succeeded", "failed"])
        ax.set_xlabel(f"{what + ' ' if what else ''}time [s]" if what else "planning time [s]")
        ax.set_ylabel(nouns)
        ax.set_title(f"{what.capitalize() or 'Planning'} time per {noun}")
        ax.legend(fontsize=8)
    if drawn_violations:
        ax = axes.pop(0)
        index = np.arange(len(rows))
        ax.bar(index, violations, color=np.where(ok, "tab:blue", "tab:red"))
        ax.set_xlabel(f"{noun} index")
        ax.set_ylabel(f"{violation_key} [{unit}]")
        ax.set_title(f"{what + ' ' if what else ''}{violation_key} per {noun} (red: failed)")
    fig.savefig(png, dpi=100)
    shown = [f"{what + ' ' if what else 'planning '}time ('{time_key}') histogram"] if histogram else []
    shown += [f"{what + ' ' if what else ''}'{violation_key}' per {noun}"] if drawn_violations else []
    return (f"{len(rows)} {noun if len(rows) == 1 else nouns}, {int(ok.sum())} succeeded; "
            + " and ".join(shown) + ".")


def datasets_figure(path: Path, png: Path) -> str:
    """Fallback: a table of every dataset (name, shape, dtype, units)."""
    rows = []
    with open_artefact(path) as handle:
        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and name != "summary":
                units = obj.attrs.get("units", "")
                rows.append(["/" + name, "x".join(map(str, obj.shape)) or "scalar", str(obj.dtype),
                             units.decode() if isinstance(units, bytes) else str(units)])
        handle.visititems(visit)
    shown = rows[:40] or [["(no datasets)", "", "", ""]]
    fig = new_figure(9.0, 0.6 + 0.28 * len(shown))
    ax = fig.subplots()
    ax.axis("off")
    table = ax.table(cellText=shown, colLabels=["dataset", "shape", "dtype", "units"], loc="upper center",
                     cellLoc="left", colLoc="left")
    table.auto_set_font_size(False)
    table.set_fontsize(8)
    fig.savefig(png, dpi=100)
    more = f" (first 40 of {len(rows)})" if len(rows) > 40 else ""
    return f"Datasets{more}; no figure is registered for this kind."
