"""write_report: HTML with summary tables, provenance and figures; atomic directory replacement;
rendering in headless Chromium when it is installed."""

import shutil
import subprocess
from html.parser import HTMLParser

import pytest

from legplan.artefacts import open_artefact, read_provenance, read_summary, sha256_file
from legplan.errors import ArtefactError
from legplan.report import figure, write_report
from legplan.report import kinds  # noqa: F401  (registers the per-kind figures)
from legplan.report.registry import FIGURES


class Page(HTMLParser):
    def __init__(self):
        super().__init__()
        self.images, self.cells, self.tables = [], [], 0

    def handle_starttag(self, tag, attrs):
        if tag == "img":
            self.images.append(dict(attrs)["src"])
        self.tables += tag == "table"

    def handle_data(self, data):
        self.cells.append(data.strip())


def parse(directory):
    page = Page()
    page.feed((directory / "index.html").read_text())
    return page


def test_report_has_summary_tables_figures_and_provenance(tmp_path, artefacts):
    map_path, motion_path = artefacts
    out = tmp_path / "rep"
    result = write_report([map_path, motion_path], out, title="T")
    page = parse(out)
    assert page.tables == 4   # summary + provenance per artefact
    for name in ("cells_x", "height_max", "steps_planned", "worst_violation", "0.003", "m"):
        assert name in page.cells
    assert page.images == ["00-map-layers.png", "01-motion-steps.png"]
    for image in page.images:
        assert (out / image).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert result.failures == 0
    with open_artefact(out / "report.h5", kind="report") as f:
        inputs = read_provenance(f)["inputs"]
        assert read_summary(f)["figures"] == (2.0, "")
    assert [r["sha256"] for r in inputs] == [sha256_file(map_path), sha256_file(motion_path)]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["map.h5", "motion.h5", "rep"]


def test_unregistered_kind_gets_dataset_listing(tmp_path):
    from legplan.artefacts import write_artefact, write_dataset

    with write_artefact(tmp_path / "t.h5", "init") as f:
        write_dataset(f, "com", [[0.0, 0.0, 0.1]], units="m")
    write_report([tmp_path / "t.h5"], tmp_path / "rep")
    assert parse(tmp_path / "rep").images == ["00-init-datasets.png"]
    assert "No" in parse(tmp_path / "rep").cells   # no /summary table message


def test_failing_figure_is_reported_and_others_kept(tmp_path, artefacts, monkeypatch):
    monkeypatch.setitem(FIGURES, "motion", list(FIGURES["motion"]))

    @figure("motion", "broken")
    def broken(path, png):
        raise RuntimeError("boom")

    result = write_report(artefacts, tmp_path / "rep")
    assert result.failures == 1
    assert "Figure broken failed: RuntimeError: boom" in (tmp_path / "rep" / "index.html").read_text()
    assert "01-motion-steps.png" in parse(tmp_path / "rep").images


def test_existing_directory_rules(tmp_path, artefacts):
    out = tmp_path / "rep"
    write_report(artefacts[:1], out)
    with pytest.raises(ArtefactError, match="output exists"):
        write_report(artefacts, out)
    write_report(artefacts, out, overwrite=True)
    assert len(parse(out).images) == 2
    other = tmp_path / "precious"
    other.mkdir()
    (other / "thesis.tex").write_text("x")
    with pytest.raises(ArtefactError, match="not a legplan report directory"):
        write_report(artefacts, other, overwrite=True)
    assert (other / "thesis.tex").exists()


def test_bad_artefact_leaves_previous_report(tmp_path, artefacts):
    out = tmp_path / "rep"
    write_report(artefacts, out)
    before = (out / "index.html").read_text()
    (tmp_path / "junk.h5").write_text("not hdf5")
    with pytest.raises(ArtefactError, match="junk.h5: not an HDF5 file"):
        write_report([artefacts[0], tmp_path / "junk.h5"], out, overwrite=True)
    assert (out / "index.html").read_text() == before
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".")) == []


CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


@pytest.mark.skipif(CHROMIUM is None, reason="chromium is not installed (apt-get install -y chromium)")
def test_page_renders_in_headless_chromium(tmp_path, artefacts):
    out = tmp_path / "rep"
    write_report(artefacts, out)
    shot = tmp_path / "shot.png"
    dom = subprocess.run(
        [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
         "--disable-component-update", "--disable-sync", "--no-first-run", f"--user-data-dir={tmp_path / 'ud'}",
         "--window-size=1000,1400", f"--screenshot={shot}", (out / "index.html").as_uri()],
        capture_output=True, text=True, timeout=120)
    assert dom.returncode == 0, dom.stderr[-2000:]
    assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert shot.stat().st_size > 20_000   # a blank page compresses to a few kB
