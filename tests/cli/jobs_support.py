"""`--jobs 2` of a many-item command as its own process: its workers are forked from the command with
the task context the command built (`legplan.cli.batching.run_stage` → `legplan.batch.fork_workers`),
and its artefact is the `--jobs 1` one, clocks aside."""

import re
import subprocess
import sys
from pathlib import Path

from test_reproducible import assert_same

BIN = Path(sys.executable).parent
BUILT = re.compile(r"task context: (?:built|provided) in process (\d+)")
FORKED = re.compile(r"task context: (\d+) workers forked from process (\d+)")


def assert_forked_from_command(argv, output, reference, exit_code=0):
    """Run `legplan *argv -o output --jobs 2 -vv`: the context is made once (built, or provided from what
    the command read to check its inputs), in the command, the two
    workers are forked from it (none builds its own: a forked worker logs as the command does), and
    `output` holds `reference`'s contents."""
    process = subprocess.Popen([str(BIN / "legplan"), *map(str, argv), "-o", str(output), "--jobs", "2", "-vv"],
                               stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    _, stderr = process.communicate()
    assert process.returncode == exit_code, stderr[-2000:]
    shown = "\n".join(line for line in stderr.splitlines() if "task context" in line)
    assert BUILT.findall(stderr) == [str(process.pid)], (process.pid, shown)
    assert FORKED.findall(stderr) == [("2", str(process.pid))], (process.pid, shown)
    assert_same(reference, output)
