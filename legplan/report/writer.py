"""Write a report directory: index.html, one PNG per figure, and `report.h5`.

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

import os
from dataclasses import dataclass
from pathlib import Path

from legplan.artefacts import open_artefact, read_provenance, read_summary, write_artefact, write_summary
from legplan.artefacts.publish import discard, make_temp, publish
from legplan.errors import ArtefactError
from legplan.report.html import ArtefactSection, render_page
from legplan.report.registry import render_figures

PROVENANCE_FILE = "report.h5"


@dataclass(frozen=True)
class ReportResult:
    directory: Path
    sections: list[ArtefactSection]

    @property
    def failures(self) -> int:
        return sum(len(s.failures) for s in self.sections)


def check_report_dir(directory: str | os.PathLike, overwrite: bool) -> Path:
    """Fail early when `directory` exists and may not be replaced."""
    directory = Path(directory)
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
    staging = make_temp(directory, directory=True)
    try:
        sections = []
        for index, path in enumerate(paths):
            with open_artefact(path) as handle:
                provenance, summary = read_provenance(handle), read_summary(handle)
            stem = f"{index:02d}-{provenance['kind']}"
            figures, failures = render_figures(path, provenance["kind"], staging, stem)
            sections.append(ArtefactSection(str(path), provenance, summary, figures, failures, stem))
            if progress:
                progress(index + 1, len(paths), str(path))
        (staging / "index.html").write_text(render_page(title, sections))
        with write_artefact(staging / PROVENANCE_FILE, "report", params={"title": title},
                            inputs=paths) as handle:
            write_summary(handle, {"artefacts": len(sections),
                                   "figures": sum(len(s.figures) for s in sections),
                                   "figure_failures": sum(len(s.failures) for s in sections)})
        check_report_dir(directory, overwrite)  # again: another writer may have been faster
        publish(staging, directory, overwrite)
    finally:
        discard(staging)
    return ReportResult(directory, sections)
