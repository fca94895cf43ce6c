"""write_report: HTML with summary tables, provenance and figures; atomic directory replacement;
rendering in headless Chromium when it is installed."""

import re
import shutil
import subprocess
from html.parser import HTMLParser

import numpy as np
import pytest
from pictures import pixels, share

from legplan.artefacts import open_artefact, read_provenance, read_summary, sha256_file
from legplan.errors import ArtefactError
from legplan.report import PROVENANCE_FILE, figure, write_report
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
    assert page.tables == 5   # the verdict, then summary + provenance per artefact
    for name in ("cells_x", "height_max", "steps_planned", "worst_violation", "0.003", "m"):
        assert name in page.cells
    first = page.cells.index("failures") + 1   # the verdict table's rows, each artefact's cells
    assert page.cells[first:first + 9] == ["../map.h5", "map", "–", "–", "../motion.h5", "motion",
                                           "2/3 steps succeeded", "worst slip 3 mm", "1 × slip too large"]
    assert str(tmp_path) not in (out / "index.html").read_text()   # paths relative to the report
    assert page.images == ["00-map-layers.png", "01-motion-steps.png"]
    layers, steps = (pixels(out / image) for image in page.images)
    assert len(np.unique(layers.reshape(-1, 3), axis=0)) > 100   # two filled colour-mapped grids
    assert share(steps, "tab:blue") > 1e-3 and share(steps, "tab:red") > 1e-3   # succeeded and failed bars
    assert result.failures == 0
    with open_artefact(out / "report.h5", kind="report") as f:
        inputs = read_provenance(f)["inputs"]
        assert read_summary(f)["figures"] == (2.0, "")
    assert [r["sha256"] for r in inputs] == [sha256_file(map_path), sha256_file(motion_path)]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["map.h5", "motion.h5", "rep"]


def test_unregistered_kind_gets_dataset_listing(tmp_path):
    from legplan.artefacts import write_artefact, write_dataset

    with write_artefact(tmp_path / "t.h5", "report") as f:
        write_dataset(f, "com", [[0.0, 0.0, 0.1]], units="m")
    write_report([tmp_path / "t.h5"], tmp_path / "rep")
    assert parse(tmp_path / "rep").images == ["00-report-datasets.png"]
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


def test_report_from_another_directory_finds_recorded_inputs(tmp_path, robot_motion, monkeypatch):
    """Inputs recorded relative to the producing command's directory are found by content from
    elsewhere; the motion gets its figures and its 3D view."""
    map_path, motion_path = robot_motion
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    result = write_report([map_path, motion_path], "rep")
    assert result.failures == 0
    motion = result.sections[1]
    # no slip recorded and the time histograms are the tracks figure's Fig. 4: no "steps" figure
    assert [f.filename for f in motion.figures] == ["01-motion-tracks.png"]
    assert motion.scene["title"] == "motion.h5: 3 steps of scarab2"
    assert motion.verdict.outcome == "2/3 steps succeeded" and motion.verdict.failures == ["1 × clearance"]
    with open_artefact(elsewhere / "rep" / PROVENANCE_FILE) as f:
        assert read_summary(f)["figure_failures"] == (0.0, "")


def test_missing_input_is_a_counted_figure_failure(tmp_path, robot_motion):
    map_path, motion_path = robot_motion
    moved = tmp_path / "moved.h5"
    map_path.rename(moved)
    result = write_report([motion_path], tmp_path / "rep")
    failed = {f.name: f.message for f in result.sections[0].failures}
    assert set(failed) == {"tracks", "3d-view"}
    assert "input map 'out/map.h5' not found" in failed["tracks"]
    with open_artefact(tmp_path / "rep" / PROVENANCE_FILE) as f:
        assert read_summary(f)["figure_failures"] == (2.0, "")
    moved.write_bytes(b"other content")   # a file at the recorded path with other content is not used
    map_path.write_bytes(b"other content")
    failed = write_report([motion_path], tmp_path / "rep", overwrite=True).sections[0].failures
    assert "sha256 differs" in failed[0].message


def test_malformed_artefact_fails_before_writing(tmp_path, artefacts):
    from legplan.artefacts import write_artefact

    with write_artefact(tmp_path / "steps.h5", "steps") as f:
        f.attrs.update(leg_names='["a", "b", "c"]', joint_names='["j"]', robot="scarab2", robot_sha256="x")
    with pytest.raises(ArtefactError, match="steps.h5: .*'/?q'"):
        write_report([artefacts[0], tmp_path / "steps.h5"], tmp_path / "rep")
    assert not (tmp_path / "rep").exists()
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".")) == []


def test_traj_scene_has_base_box_feet_and_force_arrows(tmp_path, flat_terrain):
    from fake_artefacts import write_traj

    from legplan.report.scene import FORCE_SCALE, traj_scene
    from legplan.terrain.terrain_map import save_map

    flat = tmp_path / "flat.h5"
    save_map(flat_terrain, flat)
    scene = traj_scene(write_traj(tmp_path / "traj.h5", flat, samples=50))
    assert len(scene["frames"]) == 50 and scene["terrain"]["nx"] > 1
    first, last = scene["frames"][0], scene["frames"][-1]
    box = np.array(first["b"]).reshape(8, 3)
    assert np.allclose(box.min(axis=0), [-340, -190, 370]) and np.allclose(box.max(axis=0), [340, 190, 530])
    assert np.array(last["c"])[0] == 300                     # the base moved 0.3 m
    arrows = np.array(first["a"]).reshape(-1, 6)
    assert len(arrows) == 4 and np.allclose(arrows[:, 5] - arrows[:, 2], 29.5 * 9.81 / 4 * FORCE_SCALE * 1000, atol=1)
    assert len(first["p"]) == 12 and len(first["s"]) == 12  # support polygon and feet of four legs


CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


def test_page_and_3d_views_render_in_headless_chromium(tmp_path, robot_motion):
    """Load the page with 1.5 s of virtual time: no JavaScript error, every viewer drew a frame, and
    the canvases hold the terrain, the CoM dot and force arrows. Whether the animations advanced is
    not asserted: headless chromium fires requestAnimationFrame within the virtual-time budget in
    some runs only (measured here: both viewers still at frame 0 in 3 of 10 runs, with budgets of
    2.5 and 8 s and 12 s motions alike)."""
    from fake_artefacts import write_sim_run, write_traj
    from PIL import Image

    from legplan.report.viewer import BACKGROUND

    assert CHROMIUM, "chromium is not installed (packaging/apt-packages-test.txt)"
    map_path, motion_path = robot_motion
    out = tmp_path / "rep"
    traj = write_traj(tmp_path / "traj.h5", map_path, samples=300, duration=3.0)
    write_report([motion_path, traj, write_sim_run(tmp_path / "sim.h5", traj, map_path, fall_time=2.0)], out)
    shot = tmp_path / "shot.png"
    run = subprocess.run(
        [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
         "--disable-component-update", "--disable-sync", "--no-first-run", f"--user-data-dir={tmp_path / 'ud'}",
         "--enable-logging=stderr", "--v=0", "--virtual-time-budget=1500", "--window-size=1000,1600",
         f"--screenshot={shot}", "--dump-dom", (out / "index.html").as_uri()],
        capture_output=True, text=True, timeout=180)
    assert run.returncode == 0, run.stderr[-2000:]
    console = [line for line in run.stderr.splitlines() if ":CONSOLE" in line]
    assert console == []                               # an uncaught error would be logged here
    frames = [int(v) for v in re.findall(r'data-frame="(\d+)"', run.stdout)]
    assert len(frames) == 3                            # every viewer drew (draw() sets data-frame)
    pixels = np.asarray(Image.open(shot).convert("RGB")).astype(int)
    background = np.array([int(BACKGROUND[k:k + 2], 16) for k in (1, 3, 5)])
    rows, cols = np.nonzero((pixels == background).all(axis=2))
    canvas = pixels[rows.min():rows.max() + 1, cols.min():cols.max() + 1]
    drawn = ~(canvas == background).all(axis=2)
    assert 0.15 < drawn.mean() < 0.9                   # terrain, robot and box, not an empty or broken canvas

    def near(rgb):
        return int((np.abs(canvas - np.array(rgb)).sum(axis=2) < 10).sum())

    assert near((221, 0, 0)) > 20                      # CoM dots (#d00)
    assert near((230, 0, 126)) > 20                    # force arrows (#e6007e)
    assert near((34, 34, 34)) > 5                      # scarab2's feet (#222)
    assert near((43, 29, 143)) > 50                    # the legs' skeleton lines (links.SKELETON_COLOUR)
