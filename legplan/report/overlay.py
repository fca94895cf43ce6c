"""Ours and OMPL in one comparison: artefacts of one kind (motion.h5 from `step plan` and from
`baseline step`; nav.h5 from `nav search` and from `baseline nav`) given together to `report` are
overlaid in one figure and one table, item by item (a step or query index is the same problem in
each: both commands take the same steps or queries file).

Each artefact is labelled by its planner: the items' `planner` attribute ("ompl-rrtconnect",
"kinoastar"), else the producing command ("step plan" is the Bézier + LM planner).

Figure: planning time per item (failed items hollow), the fraction of items solved within a time
(the usual planner-benchmark curve) and, for nav, every artefact's paths over the costmap.
Table: items, succeeded, median and worst planning time and the kind's quality numbers.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from legplan.report.items import read_items

OVERLAID = {"motion": ("seconds", "step"), "nav": ("planning_time", "query")}
QUALITY = {"motion": [("dense/foot_slip", "worst foot slip", "m", max)],
           "nav": [("effort", "median effort", "m²/s³", np.median), ("duration", "median duration", "s", np.median)]}
MARKERS = "osD^v<>"


@dataclass
class Overlay:
    """One comparison: its kind, the artefacts (as shown) and their labels, the table rows and the
    figure (file name, caption) once drawn."""

    kind: str
    paths: list[str]
    labels: list[str]
    header: list[str]
    rows: list[list[str]]
    figure: tuple[str, str] | None = None


def planner_label(path: str | os.PathLike) -> str:
    """The planner of an artefact's items, else its producing command's stage."""
    from legplan.artefacts import open_artefact, read_provenance

    with open_artefact(path) as handle:
        found = []

        def visit(name, obj):
            if "success" in obj.attrs and "planner" in obj.attrs and not found:
                value = obj.attrs["planner"]
                found.append(value.decode() if isinstance(value, bytes) else str(value))

        handle.visititems(visit)
        if found:
            return found[0]
        words = [w for w in read_provenance(handle)["command"][1:] if not w.startswith("-")][:2]
    stage = " ".join(words)
    return "ours (Bézier + LM)" if stage == "step plan" else stage or Path(path).name


def overlay_groups(paths: list[Path], kinds: list[str]) -> dict[str, list[Path]]:
    """{kind: artefacts} for every overlaid kind given more than once."""
    groups: dict[str, list[Path]] = {}
    for path, kind in zip(paths, kinds):
        if kind in OVERLAID:
            groups.setdefault(kind, []).append(path)
    return {kind: group for kind, group in groups.items() if len(group) > 1}


def _items(path: Path) -> list[dict]:
    from legplan.artefacts import open_artefact

    with open_artefact(path) as handle:
        items = read_items(handle)
    return [items[name] for name in sorted(items)]


def overlay(kind: str, paths: list[Path], shown: list[str], directory: Path, stem: str) -> Overlay:
    """The table of one comparison and its figure written as `directory/stem.png`."""
    time_key, noun = OVERLAID[kind]
    labels = [f"{planner_label(path)} — {Path(name).name}" for path, name in zip(paths, shown)]
    items = [_items(path) for path in paths]
    header = ["artefact", f"{noun}s", "succeeded", "median time [s]", "worst time [s]",
              *(f"{label} [{units}]" for _, label, units, _ in QUALITY[kind])]
    rows = []
    for label, group in zip(labels, items):
        times = np.array([item.get(time_key, np.nan) for item in group], float)
        ok = np.array([item["success"] for item in group], bool)
        quality = []
        for key, _, _, reduce in QUALITY[kind]:
            values = [item[key] for item, good in zip(group, ok) if good and key in item and np.isfinite(item[key])]
            quality.append(f"{float(reduce(values)):.4g}" if values else "–")
        finite = times[np.isfinite(times)]
        rows.append([label, str(len(group)), str(int(ok.sum())),
                     f"{np.median(finite):.4g}" if len(finite) else "–", f"{finite.max():.4g}" if len(finite) else "–",
                     *quality])
    result = Overlay(kind, shown, labels, header, rows)
    png = directory / f"{stem}.png"
    caption = _figure(kind, paths, labels, items, png)
    result.figure = (png.name, caption)
    return result


def _figure(kind: str, paths: list[Path], labels: list[str], items: list[list[dict]], png: Path) -> str:
    from legplan.report.plots import new_figure

    time_key, noun = OVERLAID[kind]
    panels = 3 if kind == "nav" else 2
    fig = new_figure(5.2 * panels, 4.2)
    axes = fig.subplots(1, panels, squeeze=False)[0]
    for k, (label, group) in enumerate(zip(labels, items)):
        colour = f"C{k}"
        times = np.array([item.get(time_key, np.nan) for item in group], float)
        ok = np.array([item["success"] for item in group], bool)
        index = np.arange(len(group))
        marker = MARKERS[k % len(MARKERS)]
        axes[0].plot(index[ok], times[ok], marker, color=colour, ms=5, ls="none", label=label)
        axes[0].plot(index[~ok], times[~ok], marker, color=colour, ms=5, ls="none", mfc="none")
        solved = np.sort(times[ok & np.isfinite(times)])
        if len(group):
            axes[1].step(np.concatenate([[0.0], solved]), np.arange(len(solved) + 1) / len(group), where="post",
                         color=colour, label=label)
    axes[0].set_yscale("log")
    axes[0].set_xlabel(f"{noun} index")
    axes[0].set_ylabel("planning time [s]")
    axes[0].set_title(f"Planning time per {noun} (hollow: failed)")
    axes[0].legend(fontsize=7)
    axes[1].set_xlabel("planning time [s]")
    axes[1].set_ylabel(f"fraction of {noun}s solved")
    axes[1].set_ylim(0, 1.02)
    axes[1].set_title("Solved within a time")
    if kind == "nav":
        _nav_paths(axes[2], paths)
    fig.savefig(png, dpi=100)
    return (f"{' against '.join(labels)}: planning time per {noun} and the fraction solved within a time"
            + (", and every solved query's path over the costmap." if kind == "nav" else "."))


def _nav_paths(ax, paths: list[Path]) -> None:
    """Every solved query's path of each nav artefact, one colour per artefact, over the first's costmap."""
    from legplan.artefacts import open_artefact, require
    from legplan.report.inputs import recorded_input
    from legplan.report.plots import grid_extent

    terrain = recorded_input(paths[0], "map")
    if terrain is not None:
        with open_artefact(terrain, kind="map") as handle:
            costmap = require(handle, "nav/costmap")
            ax.imshow(costmap[()], origin="lower", extent=grid_extent(costmap), cmap="Greys", interpolation="nearest")
    for k, path in enumerate(paths):
        with open_artefact(path, kind="nav") as handle:
            queries = handle["queries"] if "queries" in handle else {}
            for name in sorted(queries):
                group = queries[name]
                if not bool(group.attrs.get("success", False)):
                    continue
                points = group["p"][()] if "p" in group else group["waypoints"][()] if "waypoints" in group else None
                if points is not None and len(points):
                    ax.plot(points[:, 0], points[:, 1], color=f"C{k}", lw=1.0)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title("Paths (colour per artefact)")
