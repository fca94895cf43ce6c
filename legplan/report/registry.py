"""The registry of per-kind figure functions used by `legplan report`.

A figure function takes `(artefact_path, png_path)`, writes one PNG and returns its caption (or None
when the artefact has nothing to show for it, in which case no PNG is expected). Register with

    @figure("motion", "times")
    def motion_times(path, png): ...

Kinds without any registered function get the fallback figure listing the artefact's datasets.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

log = logging.getLogger(__name__)

FigureFunction = Callable[[Path, Path], "str | None"]
FIGURES: dict[str, list[tuple[str, FigureFunction]]] = {}
FALLBACK: list[tuple[str, FigureFunction]] = []


@dataclass(frozen=True)
class Figure:
    filename: str      # PNG name inside the report directory
    caption: str


@dataclass(frozen=True)
class FigureFailure:
    name: str
    message: str


def figure(kind: str, name: str):
    """Decorator registering a figure function for artefacts of `kind` ("*" = the fallback)."""
    def register(function: FigureFunction) -> FigureFunction:
        (FALLBACK if kind == "*" else FIGURES.setdefault(kind, [])).append((name, function))
        return function
    return register


def render_figures(path: Path, kind: str, directory: Path, stem: str
                   ) -> tuple[list[Figure], list[FigureFailure]]:
    """Run every figure function registered for `kind` (or the fallback); PNGs `stem-NAME.png`.

    A figure function that raises is reported as a `FigureFailure` (the rest still render).
    """
    from legplan.report import kinds  # noqa: F401  (registers the per-kind functions)

    figures, failures = [], []
    for name, function in FIGURES.get(kind) or FALLBACK:
        png = directory / f"{stem}-{name}.png"
        try:
            caption = function(path, png)
        except Exception as exc:  # a broken figure must not lose the rest of the report
            log.warning("%s: figure '%s' failed: %s", path, name, exc, exc_info=True)
            failures.append(FigureFailure(name, f"{type(exc).__name__}: {exc}"))
            continue
        if caption is not None:
            figures.append(Figure(png.name, caption))
    return figures, failures
