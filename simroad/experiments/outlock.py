"""Lock a sweep's output directory so that only one process writes it at a time.

The lock is the file ``DIR/sweep.lock``, created atomically (a fully written temporary
file hard-linked into place, or ``O_CREAT | O_EXCL`` where hard links are not
supported) and holding the holder's PID, host name, start time and command line. A
second sweep on the same directory is refused with :class:`~simroad.errors.OutputInUseError` naming
the holder. A lock left by a process that has died on this host is taken over (with
a message); a lock held from another host is never taken over automatically — the
message says how to remove it. Works on a filesystem shared between machines as long
as it honours exclusive creation (local disks, NFSv3+).
"""

from __future__ import annotations

import json
import os
import socket
import sys
import time
import uuid
from collections.abc import Callable
from pathlib import Path
from types import TracebackType
from typing import Any

from simroad.errors import OutputInUseError

__all__ = ["LOCK_NAME", "OutputLock"]

LOCK_NAME = "sweep.lock"
#: A takeover guard older than this (s) was left by a process that died taking over.
_GUARD_STALE_S = 10.0


def _proc_start(pid: int) -> str | None:
    """The process's start time in clock ticks since boot (Linux), to tell a reused PID."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    fields = stat[stat.rfind(")") + 2 :].split()
    return fields[19] if len(fields) > 19 else None


def _alive(pid: int, start: str | None) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    stat = Path(f"/proc/{pid}/stat")
    try:
        state = stat.read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return True
    if state in ("Z", "X"):  # a zombie: dead, not yet reaped by its parent
        return False
    now = _proc_start(pid)
    return start is None or now is None or now == start


def _stderr(message: str) -> None:
    print(message, file=sys.stderr)


class OutputLock:
    """Exclusive lock on a sweep's output directory (a context manager).

    Parameters
    ----------
    directory : path
        The existing output directory.
    log : callable, optional
        Receives a message when a stale lock is taken over (default: stderr).

    Raises
    ------
    OutputInUseError
        On ``acquire`` when a live process holds the lock.
    """

    def __init__(self, directory: str | os.PathLike, *, log: Callable[[str], None] | None = None) -> None:
        self.dir = Path(directory)
        self.path = self.dir / LOCK_NAME
        self.log = log or _stderr
        self._token: str | None = None

    def _info(self) -> dict[str, Any]:
        return {
            "pid": os.getpid(),
            "host": socket.gethostname(),
            "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
            "proc_start": _proc_start(os.getpid()),
            "argv": sys.argv,
            "token": self._token,
        }

    def _create(self) -> bool:
        """Create the lock file atomically with our info; False if it exists."""
        text = json.dumps(self._info())
        tmp = self.dir / f".{LOCK_NAME}.{self._token}"
        tmp.write_text(text)
        try:
            os.link(tmp, self.path)
            return True
        except FileExistsError:
            return False
        except OSError:  # no hard links here: exclusive create, then write
            try:
                fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
            except FileExistsError:
                return False
            with os.fdopen(fd, "w") as fh:
                fh.write(text)
            return True
        finally:
            tmp.unlink(missing_ok=True)

    def _holder(self) -> dict[str, Any] | None:
        """The lock's content; None if it vanished. Retries briefly while it is being written."""
        for _ in range(20):
            try:
                info = json.loads(self.path.read_text())
                if isinstance(info, dict):
                    return info
            except FileNotFoundError:
                return None
            except (ValueError, UnicodeDecodeError):
                pass
            time.sleep(0.05)
        return {}

    def acquire(self) -> OutputLock:
        """Take the lock, taking over a stale one; raise :class:`~simroad.errors.OutputInUseError` if held."""
        self._token = uuid.uuid4().hex
        while True:
            if self._create():
                return self
            holder = self._holder()
            if holder is None:
                continue  # released meanwhile: try again
            if self._stale(holder):
                self._take_over(holder)
                continue
            raise OutputInUseError(self._refusal(holder))

    def _stale(self, holder: dict[str, Any]) -> bool:
        pid, host = holder.get("pid"), holder.get("host")
        if not isinstance(pid, int) or host != socket.gethostname():
            return False
        return not _alive(pid, holder.get("proc_start"))

    def _refusal(self, holder: dict[str, Any]) -> str:
        pid, host, started = holder.get("pid", "?"), holder.get("host", "?"), holder.get("started", "?")
        return (
            f"out: {str(self.dir)!r} is in use by another sweep (PID {pid} on host {host}, started {started}; "
            f"lock file {str(self.path)!r}). Wait for it to finish, stop it (kill -INT {pid}), or choose "
            "another --out; if that process no longer exists, delete the lock file and rerun."
        )

    def _take_over(self, holder: dict[str, Any]) -> None:
        """Remove a stale lock, guarded so that two processes cannot both remove one."""
        guard = self.dir / f"{LOCK_NAME}.takeover"
        try:
            fd = os.open(guard, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
        except FileExistsError:
            try:
                if time.time() - guard.stat().st_mtime > _GUARD_STALE_S:
                    guard.unlink(missing_ok=True)
            except FileNotFoundError:
                pass
            time.sleep(0.01)
            return
        try:
            current = self._holder()
            if current is not None and current.get("token") == holder.get("token") and current == holder:
                self.path.unlink(missing_ok=True)
                self.log(
                    f"simroad: took over the lock of {str(self.dir)!r} from PID {holder.get('pid')} "
                    f"(started {holder.get('started')}), which no longer runs"
                )
        finally:
            os.close(fd)
            guard.unlink(missing_ok=True)

    def release(self) -> None:
        """Remove the lock if it is still ours."""
        if self._token is None:
            return
        holder = self._holder()
        if holder is not None and holder.get("token") == self._token:
            self.path.unlink(missing_ok=True)
        self._token = None

    def __enter__(self) -> OutputLock:
        return self.acquire()

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.release()
