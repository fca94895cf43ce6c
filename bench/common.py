"""What every benchmark shares: the machine it ran on, its JSON result, and its own section of
BENCHMARKS.md (replaced on each run, so a rerun updates its rows instead of piling up new ones)."""

from __future__ import annotations

import json
import os
import platform
import subprocess
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BENCHMARKS = ROOT / "BENCHMARKS.md"


def cpu_model() -> str:
    for line in Path("/proc/cpuinfo").read_text().splitlines():
        if line.startswith("model name"):
            return line.split(":", 1)[1].strip()
    return "unknown CPU"


def machine() -> str:
    """CPU model, architecture and core count, e.g. 'AMD EPYC 7B13, x86_64, 2 cores'."""
    return f"{cpu_model()}, {platform.machine()}, {os.cpu_count()} cores"


def code_version() -> str:
    """The commit the benchmarked code is at, and whether legplan/ has uncommitted changes."""
    git = ["git", "-C", str(ROOT)]
    sha = subprocess.run([*git, "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    dirty = subprocess.run([*git, "status", "--porcelain", "--", "legplan"], capture_output=True, text=True).stdout.strip()
    return f"{sha or 'unknown commit'}{' + uncommitted changes in legplan/' if dirty else ''}"


def load_average() -> float:
    """One-minute load average: the machine is shared, so every result records it."""
    return os.getloadavg()[0]


def callgrind_instructions(command: list[str], env: dict, tmp: Path, label: str) -> int:
    """Callgrind's "Collected" count of the part of `command` between its READY and DONE lines: the
    child runs under `valgrind --tool=callgrind --instr-atstart=no`, says READY and waits for a line,
    the instrumentation is switched on (`callgrind_control -i on`), the child does the counted work,
    says DONE and waits, the instrumentation is switched off, the child finishes."""
    import re

    valgrind = ["valgrind", "--tool=callgrind", "--instr-atstart=no", f"--callgrind-out-file={tmp / 'callgrind.out'}"]
    proc = subprocess.Popen(valgrind + command, env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    for expected, switch in (("READY", "on"), ("DONE", "off")):
        line = proc.stdout.readline()
        if line.strip() != expected:
            proc.kill()
            raise RuntimeError(f"{label}: expected {expected}, got {line!r}: {proc.stderr.read()[-2000:]}")
        subprocess.run(["callgrind_control", "-i", switch, str(proc.pid)], check=True, capture_output=True)
        proc.stdin.write("\n")
        proc.stdin.flush()
    _, err = proc.communicate()
    if proc.returncode != 0:
        raise RuntimeError(f"{label}: exit {proc.returncode}: {err[-2000:]}")
    (tmp / "callgrind.out").unlink(missing_ok=True)
    return int(re.search(r"Collected : (\d+)", err).group(1))


def write_result(name: str, result: dict) -> Path:
    """bench/results/<name>.json."""
    path = ROOT / "bench" / "results" / f"{name}.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(result, indent=1, default=float) + "\n")
    return path


def update_benchmarks(name: str, markdown: str) -> None:
    """Replace the `name` section of BENCHMARKS.md (between its markers), or append it."""
    begin, end = f"<!-- bench:{name} -->", f"<!-- /bench:{name} -->"
    block = f"{begin}\n{markdown.strip()}\n{end}"
    text = BENCHMARKS.read_text() if BENCHMARKS.exists() else "# Benchmarks\n"
    if begin in text and end in text:
        head, rest = text.split(begin, 1)
        text = head + block + rest.split(end, 1)[1]
    else:
        text = text.rstrip() + "\n\n" + block + "\n"
    BENCHMARKS.write_text(text)


def reap_orphans(timeout: float = 10.0) -> None:
    """Wait (up to `timeout` s) for the processes left to this child subreaper to end, and reap them."""
    deadline = time.monotonic() + timeout
    while True:
        try:
            pid, _ = os.waitpid(-1, os.WNOHANG)
        except ChildProcessError:  # none left
            return
        if pid == 0:
            if time.monotonic() > deadline:
                return
            time.sleep(0.01)


def become_subreaper() -> None:
    """Orphans of the commands run from here come back to this process (Linux `PR_SET_CHILD_SUBREAPER`)."""
    import ctypes

    ctypes.CDLL(None, use_errno=True).prctl(36, 1)  # PR_SET_CHILD_SUBREAPER
