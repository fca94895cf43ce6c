"""Reports of artefacts: HTML pages with provenance, /summary tables and per-kind figures; and
metric-by-metric comparison of two artefacts for regression runs.

    write_report(["map.h5", "motion.h5"], "report/")      # index.html + PNGs + report.h5
    diff = compare_artefacts("old.h5", "new.h5", parse_tolerances(["worst_*=1e-4"]))
"""

from legplan.report.registry import Figure, figure, render_figures
from legplan.report.writer import PROVENANCE_FILE, ReportResult, write_report

__all__ = ["PROVENANCE_FILE", "Figure", "ReportResult", "figure", "render_figures", "write_report"]
