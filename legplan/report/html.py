"""The report page: one self-contained HTML file (inline CSS and script, no network) referencing PNGs
beside it. It opens with the verdict table (one row per artefact) and the animated 3D views of planned
motions, then one section per artefact. Paths are shown relative to the report directory."""

from __future__ import annotations

import json
import math
import os
import shlex
from dataclasses import dataclass, field
from html import escape

from legplan.report.registry import Figure, FigureFailure
from legplan.report.verdict import Verdict
from legplan.report.viewer import viewer_html

_STYLE = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 72em; color: #222; }
h1 { font-size: 1.6em; } h2 { border-bottom: 1px solid #ccc; padding-bottom: .2em; margin-top: 2em; }
table { border-collapse: collapse; margin: .6em 0; font-size: .9em; }
th, td { border: 1px solid #ddd; padding: .25em .6em; text-align: left; vertical-align: top; }
th { background: #f3f3f3; } td.num { text-align: right; font-variant-numeric: tabular-nums; }
figure { margin: 1em 0; } figure img { max-width: 100%; border: 1px solid #eee; }
figcaption { font-size: .85em; color: #555; } .failure { color: #b00; } code { font-size: .85em; }
table.verdict td.ok { color: #080; } table.verdict td.bad { color: #b00; font-weight: bold; }
.viewer canvas { border: 1px solid #ccc; cursor: grab; max-width: 100%; } .controls input { width: 60%; }
"""


@dataclass
class ArtefactSection:
    """Everything the page shows for one artefact."""

    path: str                  # as shown: relative to the report directory
    provenance: dict
    summary: dict[str, tuple[float, str]]
    figures: list[Figure] = field(default_factory=list)
    failures: list[FigureFailure] = field(default_factory=list)
    anchor: str = ""
    verdict: Verdict | None = None
    scene: dict | None = None  # the 3D view's data (`legplan.report.scene`)
    checks: str = ""           # the independent check's table with its tolerances (`legplan.report.checks`)


def render_page(title: str, sections: list[ArtefactSection], directory: str | os.PathLike,
                overlays=()) -> str:
    """index.html text; absolute paths in provenance are shown relative to `directory`; `overlays`
    (`legplan.report.overlay.Overlay`) follow the verdict table."""
    scenes = [(s.anchor, s.scene) for s in sections if s.scene is not None]
    views = f"<h2>Planned and executed motions</h2>{viewer_html(scenes)}" if scenes else ""
    body = "".join(_section(s, os.path.abspath(directory)) for s in sections)
    return (f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8"><title>{escape(title)}</title>'
            f"<style>{_STYLE}</style></head><body><h1>{escape(title)}</h1>{_verdict_table(sections)}"
            f"{''.join(_overlay(o) for o in overlays)}"
            f"{views}{body}</body></html>\n")


def relative(text: str, directory: str) -> str:
    """An absolute path (or the value of `--option=/path`) relative to `directory`; other text unchanged."""
    prefix, sep, value = text.partition("=")
    if not (sep and text.startswith("-")):
        prefix, sep, value = "", "", text
    return prefix + sep + os.path.relpath(value, directory) if os.path.isabs(value) else text


def _relative_values(value, directory: str):
    """`value` (JSON: dicts, lists, strings, numbers) with every absolute path string made relative."""
    if isinstance(value, dict):
        return {key: _relative_values(item, directory) for key, item in value.items()}
    if isinstance(value, list):
        return [_relative_values(item, directory) for item in value]
    return relative(value, directory) if isinstance(value, str) else value


def _verdict_table(sections: list[ArtefactSection]) -> str:
    rows = []
    for s in sections:
        v = s.verdict or Verdict("", None, [], [])
        state = "" if v.ok is None else ' class="ok"' if v.ok else ' class="bad"'
        problems = [*v.failures, *(f"figure {f.name} failed: {f.message}" for f in s.failures)]
        rows.append(f'<tr><td><a href="#{s.anchor}">{escape(s.path)}</a></td><td>{escape(s.provenance["kind"])}</td>'
                    f"<td{state}>{escape(v.outcome) or '–'}</td><td>{escape('; '.join(v.numbers)) or '–'}</td>"
                    f'<td class="failure">{"<br>".join(escape(p) for p in problems)}</td></tr>')
    return ('<table class="verdict"><tr><th>artefact</th><th>kind</th><th>outcome</th><th>headline numbers</th>'
            f'<th>failures</th></tr>{"".join(rows)}</table>')


UNDEFINED = "n/a"


def _value(value: float) -> str:
    """A summary value; NaN (nothing to take a mean or worst over) as `UNDEFINED`."""
    return f"{value:.6g}" if math.isfinite(value) else UNDEFINED if math.isnan(value) else str(value)


def _overlay(overlay) -> str:
    """One comparison of artefacts of a kind: its table and its figure."""
    head = "".join(f"<th>{escape(h)}</th>" for h in overlay.header)
    rows = "".join("<tr>" + "".join(f'<td{"" if k == 0 else " class=num"}>{escape(v)}</td>' for k, v in enumerate(row))
                   + "</tr>" for row in overlay.rows)
    figure = "" if overlay.figure is None else (
        f'<figure><img src="{escape(overlay.figure[0])}" alt="{escape(overlay.figure[1])}">'
        f"<figcaption>{escape(overlay.figure[1])}</figcaption></figure>")
    return (f'<section id="compare-{overlay.kind}"><h2>Compared: {escape(" / ".join(overlay.labels))}</h2>'
            f'<table class="overlay"><tr>{head}</tr>{rows}</table>{figure}</section>')


def _section(section: ArtefactSection, directory: str) -> str:
    p = section.provenance
    command = shlex.join(relative(token, directory) for token in p["command"])
    rows = [("kind", p["kind"]), ("schema", p["schema_version"]), ("legplan", p["legplan_version"]),
            ("created", p["created"]), ("command", command), ("seed", p["seed"]),
            ("params", json.dumps(_relative_values(p["params"], directory), sort_keys=True, ensure_ascii=False))]
    rows += [("input", f'{relative(r["path"], directory)} ({r["kind"]}, sha256 {r["sha256"][:12]})')
             for r in p["inputs"]]
    provenance = "".join(f"<tr><th>{escape(k)}</th><td><code>{escape(str(v))}</code></td></tr>"
                         for k, v in rows)
    summary = "".join(f'<tr><td>{escape(name)}</td><td class="num">{_value(value)}</td><td>{escape(units)}</td></tr>'
                      for name, (value, units) in section.summary.items())
    undefined = any(not math.isfinite(value) for value, _ in section.summary.values())
    summary_table = (f'<table class="summary"><tr><th>metric</th><th>value</th><th>units</th></tr>{summary}</table>'
                     + (f"<p class=\"note\">{UNDEFINED}: not defined (no item to take it over, e.g. no step "
                        "in the time range the metric names).</p>" if undefined else "")
                     if summary else "<p>No <code>/summary</code> table.</p>")
    checks = f"<h3>Independent check</h3>{section.checks}" if section.checks else ""
    figures = "".join(f'<figure><img src="{escape(f.filename)}" alt="{escape(f.caption)}">'
                      f"<figcaption>{escape(f.caption)}</figcaption></figure>" for f in section.figures)
    failures = "".join(f'<p class="failure">Figure {escape(f.name)} failed: {escape(f.message)}</p>'
                       for f in section.failures)
    return (f'<section id="{section.anchor}"><h2>{escape(section.path)}</h2>'
            f'<h3>Summary</h3>{summary_table}{checks}<h3>Figures</h3>{figures}{failures}'
            f'<h3>Provenance</h3><table class="provenance">{provenance}</table></section>')
