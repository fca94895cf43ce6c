"""Interrupts and kills with real signals (issue 18, class 5), and two writers racing for one output
(class 6). After each: the older artefact is byte-identical, no process of ours is alive (its
process family, taken from /proc just before the signal, is gone), no temporary is left (for SIGKILL:
after the next run of the same output), and the exit code is 130 / 143.

"During the write" is reached deterministically with LEGPLAN_TEST_PAUSE_BEFORE_PUBLISH (the publish
step says "pausing before publishing" and sleeps); "during compute" by waiting for a log line that
precedes the work (map build's "building ... layers", a batch's "item N done")."""

import os
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import click
import pytest
from click.testing import CliRunner

from legplan.artefacts import open_artefact
from legplan.cli.main import cli
from legplan.interrupts import Terminated

LEGPLAN = str(Path(sys.executable).parent / "legplan")
PAUSING = "pausing before publishing"
OLDER = b"the older artefact\n"
EXIT = {signal.SIGINT: 130, signal.SIGTERM: 143, signal.SIGKILL: -signal.SIGKILL}
# 20 x 20 cells and 2001 SDF layers: a few seconds of SDF work after the "building" line
SLOW_MAP = "resolution: 0.05\nextent: {x: [0, 1], y: [0, 1]}\nsdf: {z_min: -50, z_max: 50}\n"
SMALL_MAP = "resolution: 0.05\nextent: {x: [0, 1], y: [0, 1]}\n"
TEMP = re.compile(r"\..*\.\d+-[0-9a-f]{8}\.tmp")


class Command:
    """A legplan command in a subprocess; its stderr (or a log file it writes) is read as it comes."""

    def __init__(self, *argv, pause: float = 0, log: Path | None = None):
        env = {**os.environ, "LEGPLAN_TEST_PAUSE_BEFORE_PUBLISH": str(pause), "COLUMNS": "1000"}  # no wrapping
        self.process = subprocess.Popen([LEGPLAN, *map(str, argv)], stderr=subprocess.PIPE,
                                        stdout=subprocess.DEVNULL, text=True, env=env)
        self.log, self.lines = log, []
        self.reader = threading.Thread(target=lambda: self.lines.extend(self.process.stderr), daemon=True)
        self.reader.start()

    def text(self) -> str:
        own = "".join(self.lines)
        return own + (self.log.read_text() if self.log is not None and self.log.exists() else "")

    def wait_for(self, marker: str, count: int = 1, timeout: float = 60) -> None:
        deadline = time.monotonic() + timeout
        while self.text().count(marker) < count:
            if self.process.poll() is not None and self.text().count(marker) < count:
                pytest.fail(f"ended with {self.process.returncode} before {marker!r}:\n{self.text()}")
            assert time.monotonic() < deadline, f"no {marker!r} after {timeout} s:\n{self.text()}"
            time.sleep(0.05)

    def signal(self, signum: int) -> tuple[int, set]:
        """Send `signum`; returns the exit code and the family (self and descendants) at that time."""
        family = descendants(self.process.pid)
        self.process.send_signal(signum)
        code = self.process.wait(timeout=60)
        self.reader.join(timeout=10)
        return code, family

    def finish(self) -> int:
        code = self.process.wait(timeout=120)
        self.reader.join(timeout=10)
        return code


def _stat(pid: int) -> tuple[int, str, int] | None:
    """(parent pid, state, start time) of a process, or None when it is gone."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except (FileNotFoundError, ProcessLookupError, IndexError):
        return None
    return int(fields[1]), fields[0], int(fields[19])


def descendants(root: int) -> set[tuple[int, int]]:
    """(pid, start time) of `root` and every process below it, from a /proc scan."""
    table = {int(name): _stat(int(name)) for name in os.listdir("/proc") if name.isdigit()}
    family, frontier = set(), [root]
    while frontier:
        pid = frontier.pop()
        if table.get(pid):
            family.add((pid, table[pid][2]))
            frontier += [child for child, stat in table.items() if stat and stat[0] == pid]
    return family


def assert_all_gone(family: set, timeout: float = 15) -> None:
    """Every process of `family` ends (a zombie counts as ended) within `timeout` s."""
    deadline = time.monotonic() + timeout
    while True:
        alive = [pid for pid, start in family
                 if (stat := _stat(pid)) is not None and stat[2] == start and stat[1] != "Z"]
        if not alive:
            return
        assert time.monotonic() < deadline, f"still alive after {timeout} s: {alive}"
        time.sleep(0.1)


def temporaries(directory: Path) -> list[str]:
    return sorted(p.name for p in directory.rglob("*") if TEMP.fullmatch(p.name))


def snapshot(path: Path) -> dict[str, bytes]:
    """Every file under `path` (or `path` itself) with its bytes."""
    if path.is_file():
        return {path.name: path.read_bytes()}
    return {str(p.relative_to(path)): p.read_bytes() for p in sorted(path.rglob("*")) if p.is_file()}


def map_spec(directory: Path, moment: str) -> Path:
    """spec.yaml: a map whose SDF takes seconds to compute (to signal during it), else a quick one."""
    spec = directory / "spec.yaml"
    spec.write_text(SLOW_MAP if moment == "compute" else SMALL_MAP)
    return spec


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
@pytest.mark.parametrize("moment", ["compute", "write"])
def test_map_build_interrupted_publishes_nothing(tmp_path, signum, moment):
    spec, output = map_spec(tmp_path, moment), tmp_path / "map.h5"
    output.write_bytes(OLDER)
    build = Command("map", "build", spec, "-o", output, "--overwrite", "-v", pause=30)
    build.wait_for("building 20x20 cells" if moment == "compute" else PAUSING)
    code, family = build.signal(signum)
    assert code == EXIT[signum], build.text()
    assert "Interrupted: stopped; nothing published" in build.text()
    assert output.read_bytes() == OLDER
    assert_all_gone(family)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["map.h5", "spec.yaml"]


def test_map_build_killed_while_writing_leaves_a_temp_the_next_run_removes(tmp_path):
    spec, output = map_spec(tmp_path, "write"), tmp_path / "map.h5"
    output.write_bytes(OLDER)
    build = Command("map", "build", spec, "-o", output, "--overwrite", pause=30)
    build.wait_for(PAUSING)
    code, family = build.signal(signal.SIGKILL)
    assert code == -signal.SIGKILL and output.read_bytes() == OLDER
    assert_all_gone(family)
    assert len(temporaries(tmp_path)) == 1  # a SIGKILL cannot be cleaned up after...
    assert Command("map", "build", spec, "-o", output, "--overwrite", "-q").finish() == 0
    assert temporaries(tmp_path) == []  # ...but the next run of the same output removes it
    with open_artefact(output, kind="map"):
        pass


@pytest.fixture(scope="module")
def scene(box):
    """The box scene walked back and forth (4 steps), its map and steps files."""
    return box.map_path, box.steps_file((0, 1, 2, 1, 0))


@pytest.mark.parametrize("signum, moment", [(signal.SIGINT, "compute"), (signal.SIGTERM, "write"),
                                            (signal.SIGKILL, "compute")])
def test_step_plan_with_two_workers_stops_them_all(scene, tmp_path, signum, moment):
    output = tmp_path / "motion.h5"
    output.write_bytes(OLDER)
    plan = Command("step", "plan", *scene, "-o", output, "--overwrite", "--jobs", "2", "-vv",
                   "--param", "samples=30", "--param", "dense_samples=200", pause=30)
    plan.wait_for("item" if moment == "compute" else PAUSING)
    if moment == "compute":
        plan.wait_for(" done (1/4")
    code, family = plan.signal(signum)
    assert code == EXIT[signum], plan.text()
    if moment == "compute":
        assert len(family) >= 3  # the command and its two workers (at the write, the pool is closed)
    assert_all_gone(family)
    assert output.read_bytes() == OLDER
    # the work file is kept on purpose (--resume continues it); nothing else is left
    assert sorted(p.name for p in tmp_path.iterdir()) == ["motion.h5", "motion.h5.work"]


@pytest.mark.parametrize("signum, pauses", [(signal.SIGINT, 1), (signal.SIGTERM, 2), (signal.SIGKILL, 2)])
def test_report_interrupted_keeps_the_older_directory(scene, tmp_path, signum, pauses):
    """The report pauses twice: before report.h5 is published inside the staging directory, then
    before the directory itself is."""
    report = tmp_path / "report"
    report.mkdir()
    (report / "report.h5").write_bytes(OLDER)
    (report / "index.html").write_text("older page")
    older = snapshot(report)
    run = Command("report", scene[0], "-o", report, "--overwrite", pause=30 if pauses == 1 else 3)
    run.wait_for(PAUSING, pauses)
    code, family = run.signal(signum)
    assert code == EXIT[signum], run.text()
    assert_all_gone(family)
    assert snapshot(report) == older
    if signum == signal.SIGKILL:
        assert len(temporaries(tmp_path)) == 1
        assert Command("report", scene[0], "-o", report, "--overwrite", "-q").finish() == 0
        assert snapshot(report) != older
    assert temporaries(tmp_path) == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report"]


PIPELINE = """name: slow
stages:
  - name: map
    command: [map, build, "{pipeline_dir}/spec.yaml"]
    inputs: ["{pipeline_dir}/spec.yaml"]
    output: map.h5
    params: {verbose: true}
  - name: report
    command: [report, "{stages.map.output}"]
    inputs: ["{stages.map.output}"]
    output: report/
    provenance: report/report.h5
"""


@pytest.mark.parametrize("signum, moment", [(signal.SIGINT, "write"), (signal.SIGTERM, "compute"),
                                            (signal.SIGKILL, "write")])
def test_pipeline_interrupted_or_killed_takes_its_stage_along(tmp_path, signum, moment):
    map_spec(tmp_path, moment)
    (tmp_path / "pipe.yaml").write_text(PIPELINE)
    out = tmp_path / "out"
    out.mkdir()
    (out / "map.h5").write_bytes(OLDER)
    run = Command("pipeline", "run", tmp_path / "pipe.yaml", "-o", out, pause=30, log=out / "logs" / "map.log")
    run.wait_for("building 20x20 cells" if moment == "compute" else PAUSING)
    code, family = run.signal(signum)
    assert code == EXIT[signum], run.text()
    assert len(family) >= 2  # the pipeline and its stage
    assert_all_gone(family)  # with SIGKILL: the stage died with the pipeline (parent-death signal)
    assert (out / "map.h5").read_bytes() == OLDER
    assert not (out / "report").exists()
    if signum != signal.SIGKILL:
        assert "Interrupted: stopped; nothing published" in run.text()
    if signum == signal.SIGKILL:
        assert len(temporaries(out)) == 1
        assert Command("pipeline", "run", tmp_path / "pipe.yaml", "-o", out, "-q").finish() == 0
        with open_artefact(out / "map.h5", kind="map"):
            pass
    assert temporaries(out) == []


@pytest.mark.parametrize("overwrite", [False, True])
def test_two_writers_to_one_new_path(tmp_path, overwrite):
    """Both pass the early "output exists" check, then pause before publishing; without
    --overwrite exactly one wins and the other exits 2, with it both succeed; the file is valid."""
    spec, output = map_spec(tmp_path, "write"), tmp_path / "map.h5"
    flags = ["--overwrite"] if overwrite else []
    writers = [Command("map", "build", spec, "-o", output, *flags, pause=2) for _ in range(2)]
    for writer in writers:
        writer.wait_for(PAUSING)
    codes = sorted(writer.finish() for writer in writers)
    assert codes == ([0, 0] if overwrite else [0, 2]), [w.text() for w in writers]
    if not overwrite:
        loser = next(w for w in writers if w.process.returncode == 2)
        assert loser.text().strip().splitlines()[-1] == (
            f"Error: {output}: output exists (use --overwrite to replace it)")
    with open_artefact(output, kind="map"):
        pass
    assert sorted(p.name for p in tmp_path.iterdir()) == ["map.h5", "spec.yaml"]


def test_figures_are_published_like_artefacts(scene, tmp_path):
    """A figure command (here `map show`) interrupted while writing keeps the older image."""
    png = tmp_path / "map.png"
    png.write_bytes(OLDER)
    show = Command("map", "show", scene[0], "-o", png, "--overwrite", pause=30)
    show.wait_for(PAUSING)
    code, family = show.signal(signal.SIGTERM)
    assert code == 143, show.text()
    assert_all_gone(family)
    assert png.read_bytes() == OLDER and sorted(p.name for p in tmp_path.iterdir()) == ["map.png"]
    assert Command("map", "show", scene[0], "-o", png, "--overwrite").finish() == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("error, code", [(KeyboardInterrupt, 130), (Terminated, 143)])
def test_an_interrupt_while_the_arguments_are_parsed_is_130_or_143_too(monkeypatch, error, code):
    """Not click's "Aborted!" and exit 1: the handling covers parsing as well as the command."""
    def interrupted(*args, **kwargs):
        raise error

    monkeypatch.setattr(click.Group, "make_context", interrupted)
    result = CliRunner().invoke(cli, ["map", "build", "x.yaml", "-o", "x.h5"])
    assert result.exit_code == code
    assert result.stderr.strip() == "Interrupted: stopped; nothing published"


def test_a_signal_turned_into_another_error_by_a_c_callback_is_an_interruption(tmp_path, monkeypatch):
    """h5py turns an exception raised inside its type converters into a TypeError: once a signal has
    arrived, any error is reported as the interruption (one line, exit 130), never a traceback."""
    import legplan.interrupts as interrupts
    import legplan.terrain as terrain

    def interrupted_inside_h5py(*args, **kwargs):
        interrupts._received.append(signal.SIGINT)       # what the handler records before it raises
        raise TypeError("Operation not defined for data type class")

    monkeypatch.setattr(terrain, "save_map", interrupted_inside_h5py)
    spec = Path(__file__).parents[2] / "maps" / "flat.yaml"
    try:
        result = CliRunner().invoke(cli, ["map", "build", str(spec), "-o", str(tmp_path / "map.h5"), "-q"])
    finally:
        interrupts._received.clear()
    assert result.exit_code == 130, result.output
    assert "Interrupted:" in result.stderr and "Traceback" not in result.stderr
    assert not (tmp_path / "map.h5").exists()
