"""Write a report directory: index.html (verdict table, animated 3D views, per-artefact sections),
one PNG per figure, and `report.h5`.

Every artefact is first read with its kind's reader (`wellformed.check_artefact`): a malformed one
fails the whole report before anything is written. A figure or 3D view that cannot be drawn (e.g. its
recorded map input is not found) is a figure failure: shown on the page and counted.

`report.h5` (kind "report") is the directory's provenance: root attrs record the command, params
and every artefact's sha256 as `inputs`, so `legplan pipeline` treats the directory like any other
artefact (its stage declares `provenance: <dir>/report.h5`). Its `/summary` counts artefacts,
figures and figure failures.

The directory is built in a temporary sibling and renamed into place (`legplan.artefacts.publish`),
so a failing or interrupted report leaves any previous one untouched. An existing directory is
replaced only with `overwrite`, and only if it holds a `report.h5` (so a mistyped `-o` never deletes
an unrelated directory), checked before any work and again just before publishing.
"""

from __future__ import annotations

import logging
import os
from dataclasses import dataclass
from pathlib import Path

from legplan.artefacts import open_artefact, read_provenance, read_summary, write_artefact, write_summary
from legplan.artefacts.publish import discard, make_temp, publish
from legplan.errors import ArtefactError
from legplan.report.checks import check_rows, check_table
from legplan.report.html import ArtefactSection, render_page
from legplan.report.overlay import Overlay, overlay, overlay_groups
from legplan.report.registry import FigureFailure, render_figures
from legplan.report.execution import execution_scene
from legplan.report.scene import motion_scene, traj_scene
from legplan.report.verdict import verdict
from legplan.report.wellformed import check_artefact

log = logging.getLogger(__name__)

PROVENANCE_FILE = "report.h5"
SCENES = {"motion": motion_scene, "traj": traj_scene, "sim": execution_scene}


@dataclass(frozen=True)
class ReportResult:
    directory: Path
    sections: list[ArtefactSection]

    @property
    def failures(self) -> int:
        return sum(len(s.failures) for s in self.sections)


FILE_SUFFIXES = (".html", ".htm", ".h5", ".hdf5", ".png", ".pdf", ".json")
"""Suffixes of a file path given as a report's output directory (refused)."""


def check_report_dir(directory: str | os.PathLike, overwrite: bool) -> Path:
    """Fail early when `directory` exists and may not be replaced, or names a file (`report.html`):
    a report is a directory (index.html, its figures, report.h5)."""
    directory = Path(directory)
    if directory.suffix.lower() in FILE_SUFFIXES:
        raise ArtefactError(f"{directory}: a report is a directory holding index.html and its figures; "
                            f"give a directory (-o {directory.with_suffix('')}/)")
    if directory.exists():
        if not directory.is_dir():
            raise ArtefactError(f"{directory}: report output exists and is not a directory")
        if not overwrite:
            raise ArtefactError(f"{directory}: output exists (use --overwrite to replace it)")
        if any(directory.iterdir()) and not (directory / PROVENANCE_FILE).exists():
            raise ArtefactError(f"{directory}: not a legplan report directory (no {PROVENANCE_FILE}); "
                                "refusing to replace it")
    return directory


def write_report(artefacts: list[str | os.PathLike], directory: str | os.PathLike, *,
                 title: str = "legplan report", overwrite: bool = False, progress=None) -> ReportResult:
    """Render every artefact (provenance, /summary, figures by kind) into `directory`."""
    directory = check_report_dir(directory, overwrite)
    paths = [Path(p) for p in artefacts]
    if not paths:
        raise ArtefactError(f"{directory}: no artefacts to report on")
    directory.parent.mkdir(parents=True, exist_ok=True)
    kinds = []
    for path in paths:
        with open_artefact(path) as handle:
            kinds.append(read_provenance(handle)["kind"])
        check_artefact(path, kinds[-1])
    staging = make_temp(directory, directory=True)
    try:
        sections = []
        for index, (path, kind) in enumerate(zip(paths, kinds)):
            with open_artefact(path) as handle:
                provenance, summary = read_provenance(handle), read_summary(handle)
                outcome = verdict(handle, kind, summary)
            stem = f"{index:02d}-{kind}"
            figures, failures = render_figures(path, kind, staging, stem)
            scene = _scene(path, kind, failures)
            shown = os.path.relpath(path.absolute(), directory.absolute())
            sections.append(ArtefactSection(shown, provenance, summary, figures, failures, stem, outcome, scene,
                                            check_table(check_rows(path))))
            if progress:
                progress(index + 1, len(paths), str(path))
        overlays = _overlays(paths, kinds, sections, staging)
        (staging / "index.html").write_text(render_page(title, sections, directory, overlays))
        with write_artefact(staging / PROVENANCE_FILE, "report", params={"title": title},
                            inputs=paths) as handle:
            write_summary(handle, {"artefacts": len(sections),
                                   "figures": sum(len(s.figures) for s in sections) + len(overlays),
                                   "figure_failures": sum(len(s.failures) for s in sections)})
        check_report_dir(directory, overwrite)  # again: another writer may have been faster
        publish(staging, directory, overwrite)
    finally:
        discard(staging)
    return ReportResult(directory, sections)


def _scene(path: Path, kind: str, failures: list[FigureFailure]) -> dict | None:
    """The 3D view's data for `kind` (None: none registered or nothing to show); a failure is
    appended to `failures` like a figure's."""
    if kind not in SCENES:
        return None
    try:
        return SCENES[kind](path)
    except Exception as exc:  # a broken view must not lose the rest of the report
        log.warning("%s: 3D view failed: %s", path, exc, exc_info=True)
        failures.append(FigureFailure("3d-view", f"{type(exc).__name__}: {exc}"))
        return None


def _overlays(paths: list[Path], kinds: list[str], sections: list[ArtefactSection], staging: Path) -> list[Overlay]:
    """Ours and OMPL overlaid (`legplan.report.overlay`) for each kind given more than once; a
    comparison that cannot be drawn is a figure failure of the first artefact of its kind."""
    out = []
    for kind, group in overlay_groups(paths, kinds).items():
        shown = [sections[paths.index(path)].path for path in group]
        try:
            out.append(overlay(kind, group, shown, staging, f"compare-{kind}"))
        except Exception as exc:  # a broken comparison must not lose the rest of the report
            log.warning("comparison of %s failed: %s", kind, exc, exc_info=True)
            sections[paths.index(group[0])].failures.append(FigureFailure(f"compare-{kind}", f"{type(exc).__name__}: {exc}"))
    return out
