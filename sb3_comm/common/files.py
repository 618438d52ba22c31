"""Files that are whole or absent, folders with one owner, and addresses without passwords.

* :func:`atomic_path` is how every file of a run is written (``model.zip``, checkpoints,
  ``config.yml``, ``result.json``, ``summary.json``, ``experiment.yml``, ``evaluations.json``,
  ``messages.npz``, videos): the writer fills a temporary file in the same folder, which then
  replaces the target with ``os.replace``. A reader, or a run that dies half-way (full disk,
  ``kill -9``), sees the old file or the new one, never half of one; a failed write removes its
  temporary file. :func:`write_text` and :func:`write_bytes` are built on it.
* :func:`folder_lock` gives an experiment folder a single runner: ``OUT/.lock`` is held with
  ``fcntl.flock`` (released by the kernel when the holder dies, even by ``kill -9``) and names its
  holder (pid, host, start time, command) for the message of a second runner.
* :func:`die_with_parent` makes a worker process end when the process that started it ends.
* :func:`mask_url` hides the password of a database URL or a cluster address before it is written
  or printed.
"""

from __future__ import annotations

import contextlib
import datetime as dt
import errno
import json
import os
import platform
import re
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

__all__ = [
    "FolderLockedError",
    "atomic_path",
    "die_with_parent",
    "folder_lock",
    "mask_url",
    "write_bytes",
    "write_text",
]


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A temporary path to write ``path`` through: on a clean exit it replaces ``path``.

    The temporary file lies in the same folder (so that ``os.replace`` is a rename on one file
    system), is hidden (``.name.<pid>.tmp.<suffix>``) and keeps the suffix, so that writers that
    pick a format or add an extension from it (SB3's ``save``, NumPy's ``savez``, Pillow, imageio)
    write the same bytes. Its contents are flushed to disk before the rename. If the writer raises
    (or the rename fails), the temporary file is removed and ``path`` is left as it was; an
    ``OSError`` is raised again naming ``path`` rather than the temporary file.

    >>> with atomic_path("runs/x/model.zip") as tmp:  # doctest: +SKIP
    ...     model.save(tmp)
    """
    path = Path(path)
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.tmp{path.suffix}")
    try:
        yield tmp
        _fsync(tmp)
        os.replace(tmp, path)
    except OSError as error:
        raise _naming(error, path) from error
    finally:
        with contextlib.suppress(OSError):
            tmp.unlink(missing_ok=True)


def _fsync(path: Path) -> None:
    """Flush a written file to disk (so that a rename after a crash does not expose an empty file)."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _naming(error: OSError, path: Path) -> OSError:
    """The same error, naming the file the user knows (not the temporary one)."""
    if error.errno is None:
        return error
    return OSError(error.errno, error.strerror or os.strerror(error.errno), str(path))


def write_bytes(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically (see :func:`atomic_path`); returns the path."""
    path = Path(path)
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return path


def write_text(path: str | Path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically (see :func:`atomic_path`); returns the path."""
    return write_bytes(path, text.encode("utf-8"))


def describe_os_error(error: OSError) -> str:
    """One line for a failed file operation, e.g. ``no space left on device: runs/x/model.zip``."""
    reason = error.strerror or str(error)
    if error.errno == errno.ENOSPC:
        reason = "no space left on device"
    return f"{reason}: {error.filename}" if error.filename else reason


# --- Secrets -------------------------------------------------------------------------------------

_USERINFO = re.compile(r"^(?P<head>(?:[A-Za-z][A-Za-z0-9+.-]*://)?[^:/@\s]*:)(?P<password>[^@/\s]+)@")
_SECRET_QUERY = re.compile(r"(?P<head>[?&](?:password|passwd|pwd|token|secret)=)(?P<value>[^&#\s]*)", re.I)


def mask_url(url: str) -> str:
    """``url`` with its password shown as ``***``: ``postgresql://user:***@host/db``.

    Covers the password of the user information (``scheme://user:password@host``, also without a
    scheme) and ``password=``/``token=``/``secret=`` query parameters. Other text, a plain
    ``host:port`` included, is returned unchanged.
    """
    masked = _USERINFO.sub(lambda m: f"{m['head']}***@", url)
    return _SECRET_QUERY.sub(lambda m: f"{m['head']}***", masked)


def mask_command(argv: list[str]) -> list[str]:
    """A command line with the password of every URL in it masked (:func:`mask_url`)."""
    return [mask_url(arg) for arg in argv]


# --- One runner per folder -----------------------------------------------------------------------


class FolderLockedError(RuntimeError):
    """Another live process holds the folder (the message names it)."""


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # someone else's live process
        return True
    return True


def _describe_holder(holder: dict[str, Any]) -> str:
    return (
        f"pid {holder.get('pid', '?')} on {holder.get('host', '?')} since {holder.get('started', '?')} "
        f"({holder.get('command', '?')})"
    )


def _read_holder(fd: int) -> dict[str, Any]:
    os.lseek(fd, 0, os.SEEK_SET)
    raw = b""
    while chunk := os.read(fd, 65536):
        raw += chunk
    try:
        holder = json.loads(raw.decode("utf-8")) if raw.strip() else {}
    except (UnicodeDecodeError, ValueError):
        return {}
    return holder if isinstance(holder, dict) else {}


@contextlib.contextmanager
def folder_lock(
    folder: str | Path, command: str | None = None, echo: Callable[[str], None] = print
) -> Iterator[Path]:
    """Hold ``folder/.lock`` for the duration of the block: one runner per folder.

    The lock is a ``fcntl.flock`` on the file (the kernel releases it when the holder ends, even by
    ``kill -9``); the file's contents (JSON: ``pid``, ``host``, ``started``, ``command``) are only
    there to name the holder. Contents left by a holder that is gone mark a stale lock: it is
    taken over, and ``echo`` says so. On exit the contents are cleared (the file stays: removing it
    would let two later runners lock two different files).

    :param folder: the folder to own (created).
    :param command: the command line to record (default: ``sys.argv``, passwords masked).
    :param echo: where the take-over notice goes.
    :raises FolderLockedError: another live process holds it; the message names the process.
    """
    import fcntl

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / ".lock"
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = _read_holder(fd)
            raise FolderLockedError(
                f"{folder} is in use by another runner: {_describe_holder(holder)}. "
                f"Wait for it to finish, stop it, or give another --out folder."
            ) from None
        holder = _read_holder(fd)
        host = platform.node()
        if holder:
            pid = holder.get("pid")
            # A file system without working flock (some network mounts): trust a live pid here.
            if holder.get("host") == host and isinstance(pid, int) and pid != os.getpid() and _pid_alive(pid):
                raise FolderLockedError(
                    f"{folder} is in use by another runner: {_describe_holder(holder)}. "
                    f"Wait for it to finish, stop it, or give another --out folder."
                )
            echo(f"Taking over the stale lock {path}: its holder is gone ({_describe_holder(holder)})")
        me = {
            "pid": os.getpid(),
            "host": host,
            "started": dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds"),
            "command": command or " ".join(mask_command(sys.argv)),
        }
        os.ftruncate(fd, 0)
        os.lseek(fd, 0, os.SEEK_SET)
        os.write(fd, (json.dumps(me) + "\n").encode("utf-8"))
        os.fsync(fd)
        try:
            yield path
        finally:
            with contextlib.suppress(OSError):
                os.ftruncate(fd, 0)  # a clean release: nothing stale is left
    finally:
        os.close(fd)  # releases the flock


# --- Workers end with their parent ---------------------------------------------------------------

_PR_SET_PDEATHSIG = 1


def die_with_parent(poll_seconds: float = 1.0) -> None:
    """Make this (worker) process end when its parent ends, even by ``kill -9``.

    On Linux the kernel sends SIGKILL at the parent's death (``prctl(PR_SET_PDEATHSIG)``); as a
    fallback elsewhere (and for a parent that died before the call), a daemon thread polls the
    parent's pid and ends the process when it changes. A process forked by multiprocessing's fork
    server has the server as its parent, which outlives the process that asked for it: the thread
    polls that process's sentinel instead (``multiprocessing.parent_process().is_alive()``), and
    ends this one within ``poll_seconds`` of its death. Meant as a process-pool ``initializer``.
    """
    import multiprocessing

    started_by = multiprocessing.parent_process()
    parent = started_by.pid if started_by is not None and started_by.pid else os.getppid()
    through_server = parent != os.getppid() and started_by is not None and started_by.is_alive()
    if sys.platform.startswith("linux") and not through_server:
        with contextlib.suppress(OSError, AttributeError):
            import ctypes

            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)

    def gone() -> bool:
        if through_server:
            return not started_by.is_alive()  # type: ignore[union-attr]
        return os.getppid() != parent

    def watch() -> None:
        while True:
            if gone():
                os._exit(1)
            time.sleep(poll_seconds)

    if gone():  # it died before prctl took effect
        os._exit(1)
    threading.Thread(target=watch, name="die-with-parent", daemon=True).start()
