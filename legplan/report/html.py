"""The report page: one self-contained HTML file (inline CSS) referencing PNGs beside it."""

from __future__ import annotations

import json
import shlex
from dataclasses import dataclass, field
from html import escape

from legplan.report.registry import Figure, FigureFailure

_STYLE = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 72em; color: #222; }
h1 { font-size: 1.6em; } h2 { border-bottom: 1px solid #ccc; padding-bottom: .2em; margin-top: 2em; }
table { border-collapse: collapse; margin: .6em 0; font-size: .9em; }
th, td { border: 1px solid #ddd; padding: .25em .6em; text-align: left; vertical-align: top; }
th { background: #f3f3f3; } td.num { text-align: right; font-variant-numeric: tabular-nums; }
figure { margin: 1em 0; } figure img { max-width: 100%; border: 1px solid #eee; }
figcaption { font-size: .85em; color: #555; } .failure { color: #b00; } code { font-size: .85em; }
"""


@dataclass
class ArtefactSection:
    """Everything the page shows for one artefact."""

    path: str
    provenance: dict
    summary: dict[str, tuple[float, str]]
    figures: list[Figure] = field(default_factory=list)
    failures: list[FigureFailure] = field(default_factory=list)
    anchor: str = ""


def render_page(title: str, sections: list[ArtefactSection]) -> str:
    """index.html text."""
    toc = "".join(f'<li><a href="#{s.anchor}">{escape(s.path)}</a> ({escape(s.provenance["kind"])})</li>'
                  for s in sections)
    body = "".join(_section(s) for s in sections)
    return (f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8"><title>{escape(title)}</title>'
            f"<style>{_STYLE}</style></head><body><h1>{escape(title)}</h1><ul>{toc}</ul>{body}"
            "</body></html>\n")


def _section(section: ArtefactSection) -> str:
    p = section.provenance
    rows = [("kind", p["kind"]), ("schema", p["schema_version"]), ("legplan", p["legplan_version"]),
            ("created", p["created"]), ("command", shlex.join(p["command"])), ("seed", p["seed"]),
            ("params", json.dumps(p["params"], sort_keys=True))]
    rows += [("input", f'{r["path"]} ({r["kind"]}, sha256 {r["sha256"][:12]})') for r in p["inputs"]]
    provenance = "".join(f"<tr><th>{escape(k)}</th><td><code>{escape(str(v))}</code></td></tr>"
                         for k, v in rows)
    summary = "".join(f'<tr><td>{escape(name)}</td><td class="num">{value:.6g}</td><td>{escape(units)}</td></tr>'
                      for name, (value, units) in section.summary.items())
    summary_table = (f'<table class="summary"><tr><th>metric</th><th>value</th><th>units</th></tr>{summary}</table>'
                     if summary else "<p>No <code>/summary</code> table.</p>")
    figures = "".join(f'<figure><img src="{escape(f.filename)}" alt="{escape(f.caption)}">'
                      f"<figcaption>{escape(f.caption)}</figcaption></figure>" for f in section.figures)
    failures = "".join(f'<p class="failure">Figure {escape(f.name)} failed: {escape(f.message)}</p>'
                       for f in section.failures)
    return (f'<section id="{section.anchor}"><h2>{escape(section.path)}</h2>'
            f'<h3>Summary</h3>{summary_table}<h3>Figures</h3>{figures}{failures}'
            f'<h3>Provenance</h3><table class="provenance">{provenance}</table></section>')
