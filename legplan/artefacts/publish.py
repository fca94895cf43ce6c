"""Publishing an output: built under a temporary name of ours beside it, then renamed into place in
one step that never replaces an existing output unless asked to.

    with staged_output("map.h5", overwrite=False) as temp:     # or directory=True: temp is a directory
        write(temp)
    # published: "map.h5" now holds what was written to temp

or by hand: `temp = make_temp(target)`, write, `publish(temp, target, overwrite)`, finally `discard(temp)`.

Temporary names hold the writer's PID, `.NAME.PID-XXXXXXXX.tmp` (8 random hex digits), so the next
run for the same output removes the temporaries whose process is dead (`remove_stale_temps`), e.g.
left by a SIGKILL. `publish(temp, target, overwrite)` is the last step of every writer:

- it raises `KeyboardInterrupt` / `Terminated` instead if SIGINT or SIGTERM arrived, even one whose
  exception was swallowed on the way (`legplan.interrupts.raise_if_interrupted`);
- a file without `overwrite`: `os.link(temp, target)`, which fails if the target exists (created by
  a concurrent writer since the early `check_output`, say) → `ArtefactError` "output exists", exit 2;
  the temporary name is unlinked afterwards by `discard`. With `overwrite`: `os.replace`;
- a directory without `overwrite`: renameat2(RENAME_NOREPLACE); with `overwrite`: RENAME_EXCHANGE
  with the existing directory (the old one, now under the temporary name, is removed afterwards).
  Where the file system lacks these flags (EINVAL), the target is checked and moved aside first.

Test hook: with `LEGPLAN_TEST_PAUSE_BEFORE_PUBLISH=SECONDS` in the environment, `publish` says so on
stderr ("pausing before publishing TARGET") and sleeps that long before its last check and rename, so
tests can signal a command "during the write" deterministically.
"""

from __future__ import annotations

import ctypes
import errno
import os
import re
import secrets
import shutil
import sys
import time
from contextlib import contextmanager
from pathlib import Path

from legplan.errors import ArtefactError
from legplan.interrupts import note_published, raise_if_interrupted

PAUSE_ENV = "LEGPLAN_TEST_PAUSE_BEFORE_PUBLISH"
_AT_FDCWD = -100
_RENAME_NOREPLACE = 1
_RENAME_EXCHANGE = 2


def temp_path(target: str | os.PathLike) -> Path:
    """A fresh temporary name of ours beside `target`: `.NAME.PID-XXXXXXXX.tmp`."""
    target = Path(target)
    return target.with_name(f".{target.name}.{os.getpid()}-{secrets.token_hex(4)}.tmp")


def _temp_pattern(target: Path) -> re.Pattern:
    return re.compile(rf"\.{re.escape(target.name)}\.(\d+)-[0-9a-f]{{8}}\.tmp")


def remove_stale_temps(target: str | os.PathLike) -> list[Path]:
    """Remove the temporaries of `target` (files or directories) whose writing process is dead;
    returns what was removed. Another live process's temporaries are left alone."""
    target = Path(target)
    pattern, removed = _temp_pattern(target), []
    try:
        entries = list(target.parent.iterdir())
    except OSError:
        return removed
    for entry in entries:
        match = pattern.fullmatch(entry.name)
        if match and not _alive(int(match.group(1))):
            discard(entry)
            removed.append(entry)
    return removed


def _alive(pid: int) -> bool:
    """Whether process `pid` runs: it exists and is not a zombie (a killed writer whose new parent
    does not reap it, e.g. in a container without an init)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):  # no /proc: trust kill()
        return True
    return state != "Z"


def discard(path: Path) -> None:
    """Remove a temporary file or directory (nothing if it is gone)."""
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        path.unlink(missing_ok=True)


def make_temp(target: str | os.PathLike, *, directory: bool = False) -> Path:
    """A new temporary beside `target` (an empty directory with `directory`, else a name with no
    file yet), after removing the stale temporaries of dead writers of `target`."""
    target = Path(target)
    target.parent.mkdir(parents=True, exist_ok=True)
    remove_stale_temps(target)
    temp = temp_path(target)
    if directory:
        temp.mkdir()
    return temp


@contextmanager
def staged_output(target: str | os.PathLike, *, overwrite: bool, directory: bool = False):
    """Yield `make_temp(target)`; publish it to `target` when the block ends without an exception.
    The temporary is removed in every case."""
    temp = make_temp(target, directory=directory)
    try:
        yield temp
        publish(temp, Path(target), overwrite)
    except OSError as exc:
        raise _named_for_user(exc, temp, Path(target)) from None
    finally:
        discard(temp)


def _named_for_user(error: OSError, temp: Path, target: Path) -> Exception:
    """An OS error about our temporary as the user's output: an `ArtefactError` naming `target`
    (the temporary's name is ours, not the user's); any other OS error unchanged."""
    text = " ".join(str(error).split())
    if temp.name not in text:
        return error
    reason = error.strerror or ""
    if not reason or temp.name in reason:  # h5py puts the whole HDF5 message, temporary name included, there
        reason = os.strerror(error.errno) if error.errno else text.replace(str(temp.parent), "").replace(temp.name, target.name)
    return ArtefactError(f"{target}: cannot write the output in {target.parent} ({reason})")


def save_figure(figure, path: str | os.PathLike, *, overwrite: bool = False, **options) -> None:
    """`figure.savefig(path, **options)` published like any output (format from `path`'s suffix)."""
    path = Path(path)
    with staged_output(path, overwrite=overwrite) as temp:
        figure.savefig(temp, format=path.suffix.lstrip(".").lower() or "png", **options)


def publish(temp: Path, target: Path, overwrite: bool) -> None:
    """Rename `temp` (a file or directory) to `target` as the last step (module docstring)."""
    _pause_for_tests(target)
    raise_if_interrupted()
    if temp.is_dir():
        _publish_directory(temp, target, overwrite)
    elif overwrite:
        os.replace(temp, target)
    else:
        try:
            os.link(temp, target)
        except FileExistsError:
            raise ArtefactError(f"{target}: output exists (use --overwrite to replace it)") from None
    note_published(target)  # the temporary name (a second link, or a replaced directory): `discard`


def _pause_for_tests(target: Path) -> None:
    """The `LEGPLAN_TEST_PAUSE_BEFORE_PUBLISH` hook: say so, then wait (ending early on a signal)."""
    pause = float(os.environ.get(PAUSE_ENV) or 0)
    if pause <= 0:
        return
    sys.stderr.write(f"pausing before publishing {target}\n")
    sys.stderr.flush()
    deadline = time.monotonic() + pause
    while time.monotonic() < deadline:
        raise_if_interrupted()
        time.sleep(0.05)


def _publish_directory(temp: Path, target: Path, overwrite: bool) -> None:
    """Move directory `temp` to `target`; with `overwrite` an existing target ends up at `temp`."""
    for _ in range(3):  # with overwrite, a target that appears or vanishes in between: try again
        if overwrite and _rename(temp, target, _RENAME_EXCHANGE):
            return
        if _rename(temp, target, _RENAME_NOREPLACE):
            return
        if not overwrite:
            raise ArtefactError(f"{target}: output exists (use --overwrite to replace it)")
    raise ArtefactError(f"{target}: output kept appearing and vanishing while it was replaced")


def _rename(source: Path, target: Path, flags: int) -> bool:
    """renameat2(source, target, flags); False when the target is missing (exchange) or exists (no
    replace). Falls back to checked plain renames where renameat2 or its flags are missing."""
    try:
        call = ctypes.CDLL(None, use_errno=True).renameat2
    except AttributeError:
        return _rename_checked(source, target, flags)
    if call(_AT_FDCWD, os.fsencode(source), _AT_FDCWD, os.fsencode(target), flags) == 0:
        return True
    error = ctypes.get_errno()
    if error in ((errno.ENOENT,) if flags & _RENAME_EXCHANGE else (errno.EEXIST, errno.ENOTEMPTY)):
        return False
    if error in (errno.EINVAL, errno.ENOSYS):
        return _rename_checked(source, target, flags)
    raise OSError(error, os.strerror(error), str(target))


def _rename_checked(source: Path, target: Path, flags: int) -> bool:
    """Without renameat2: check, then rename (a concurrent writer can slip in between)."""
    if flags & _RENAME_EXCHANGE:
        if not target.exists():
            return False
        aside = temp_path(target)
        os.rename(target, aside)
        os.rename(source, target)
        os.rename(aside, source)
        return True
    if target.exists():
        return False
    os.rename(source, target)
    return True
