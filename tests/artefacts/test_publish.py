"""`legplan.artefacts.publish`: temporaries of our naming, publishing without clobbering, the sweep of
dead writers' temporaries, and no publishing after a signal (in-process; the real-signal runs are in
tests/cli/test_interrupts.py)."""

import os
import signal
import subprocess
import sys

import pytest

from legplan import interrupts
from legplan.artefacts.publish import _rename_checked, make_temp, remove_stale_temps, staged_output, temp_path
from legplan.errors import ArtefactError


def dead_pid() -> int:
    """The PID of a process that has ended and been reaped."""
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


def test_temp_names_hold_our_pid_and_sit_beside_the_target(tmp_path):
    temp = temp_path(tmp_path / "map.h5")
    assert temp.parent == tmp_path
    assert temp.name.startswith(f".map.h5.{os.getpid()}-") and temp.name.endswith(".tmp")
    assert temp_path(tmp_path / "map.h5") != temp


def test_only_dead_writers_temporaries_are_swept(tmp_path):
    target = tmp_path / "map.h5"
    dead_file = tmp_path / f".map.h5.{dead_pid()}-0123abcd.tmp"
    dead_dir = tmp_path / f".map.h5.{dead_pid()}-89abcdef.tmp"
    live = tmp_path / f".map.h5.{os.getpid()}-0123abcd.tmp"
    other = tmp_path / f".other.h5.{dead_pid()}-0123abcd.tmp"
    foreign = tmp_path / ".map.h5.x1y2z3.tmp"  # not our naming: never touched
    for path in (dead_file, live, other, foreign):
        path.write_text("x")
    dead_dir.mkdir()
    (dead_dir / "index.html").write_text("x")
    assert sorted(remove_stale_temps(target)) == sorted([dead_file, dead_dir])
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(p.name for p in (live, other, foreign))
    make_temp(tmp_path / "other.h5")  # making a temporary sweeps first
    assert not other.exists()


def test_a_file_is_published_without_clobbering_unless_overwrite(tmp_path):
    target = tmp_path / "out.txt"
    with staged_output(target, overwrite=False) as temp:
        temp.write_text("first")
    with pytest.raises(ArtefactError, match=f"{target}: output exists"):
        with staged_output(target, overwrite=False) as temp:
            temp.write_text("second")  # written, then refused at the rename: an existing output stays
    assert target.read_text() == "first"
    with staged_output(target, overwrite=True) as temp:
        temp.write_text("third")
    assert target.read_text() == "third"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.txt"]


def test_a_directory_is_published_without_clobbering_unless_overwrite(tmp_path):
    target = tmp_path / "report"
    for text, overwrite in (("first", False), ("second", True)):
        with staged_output(target, overwrite=overwrite, directory=True) as temp:
            (temp / "index.html").write_text(text)
        assert (target / "index.html").read_text() == text
    with pytest.raises(ArtefactError, match="output exists"):
        with staged_output(target, overwrite=False, directory=True) as temp:
            (temp / "index.html").write_text("third")
    assert (target / "index.html").read_text() == "second"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report"]  # the replaced one is gone too


def test_checked_renames_where_renameat2_is_missing(tmp_path):
    target, new = tmp_path / "report", tmp_path / "new"
    new.mkdir()
    (new / "a").write_text("new")
    assert not _rename_checked(new, target, 2)  # exchange: no target yet
    assert _rename_checked(new, target, 1)
    again = tmp_path / "again"
    again.mkdir()
    assert not _rename_checked(again, target, 1)  # no-replace: the target exists
    assert _rename_checked(again, target, 2)
    assert not (target / "a").exists() and (again / "a").read_text() == "new"


def test_nothing_is_published_after_a_signal_even_a_swallowed_one(tmp_path):
    target = tmp_path / "out.txt"
    with interrupts.handle_interrupts():
        try:
            signal.raise_signal(signal.SIGTERM)
        except interrupts.Terminated:
            pass  # as h5py does with the exception raised while it writes
        with pytest.raises(interrupts.Terminated):
            with staged_output(target, overwrite=True) as temp:
                temp.write_text("late")
        assert interrupts.interrupted_message() == "stopped; nothing published"
    assert list(tmp_path.iterdir()) == []
    assert interrupts.received() is None  # the record ends with the block


def test_the_message_names_what_was_published_before_the_signal(tmp_path):
    with interrupts.handle_interrupts():
        with staged_output(tmp_path / "out.txt", overwrite=False) as temp:
            temp.write_text("done")
        with pytest.raises(KeyboardInterrupt):
            signal.raise_signal(signal.SIGINT)
        assert interrupts.received() == signal.SIGINT
        assert interrupts.interrupted_message() == f"stopped after publishing {tmp_path / 'out.txt'}"
        assert interrupts.exit_code(KeyboardInterrupt()) == 130
        assert interrupts.exit_code(interrupts.Terminated()) == 143
