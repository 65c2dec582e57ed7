"""Files a campaign or a training run can trust: atomic writes, an exclusive folder lock, damaged files moved aside.

Choices:

* **Atomic writes.** Every output is written to a temporary file with a unique name in the destination's folder
  (``tempfile.NamedTemporaryFile(dir=..., delete=False)``), flushed and ``fsync``-ed, then renamed over the
  destination with ``os.replace`` (atomic on POSIX within one file system). A reader sees the old file or the new
  one, never a part; two writers never share a temporary file; a writer killed mid-way leaves only a ``.*.tmp``
  file, which :func:`remove_stale_temporaries` deletes under the folder's lock.
* **The lock** is ``fcntl.flock(LOCK_EX | LOCK_NB)`` on ``<folder>/.lock``, which holds the holder's pid for the
  message of a refused second campaign. The kernel drops a ``flock`` when its holder dies (however it dies), so a
  lock left by a dead process is never in force: the file only remembers its pid, and the next campaign takes it
  over and says so. The lock is re-entrant within one process (a campaign that runs and then summarises holds it
  once), and forked workers close their inherited copy (:func:`FolderLock.close_inherited`).
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import pathlib
import sys
import tempfile
from collections.abc import Callable, Iterable, Iterator
from typing import IO

TMP_SUFFIX = ".tmp"


def atomic_write(path: pathlib.Path, write: Callable[[IO[bytes]], object]) -> pathlib.Path:
    """Call ``write(f)`` on a uniquely named temporary file beside ``path``, then rename it to ``path``."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.NamedTemporaryFile(dir=path.parent, prefix=f".{path.name}.", suffix=TMP_SUFFIX, delete=False) as f:
        tmp = pathlib.Path(f.name)
        try:
            os.fchmod(f.fileno(), 0o666 & ~_umask())  # a temporary file is 0600; the result gets the usual mode
            write(f.file)  # the underlying BufferedRandom (some writers check the type)
            f.flush()
            os.fsync(f.fileno())
        except BaseException:
            f.close()
            tmp.unlink(missing_ok=True)
            raise
    os.replace(tmp, path)
    return path


def _umask() -> int:
    """The process's umask (read by setting it and setting it back)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def atomic_write_text(path: pathlib.Path, text: str) -> pathlib.Path:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    return atomic_write(path, lambda f: f.write(text.encode()))


def remove_stale_temporaries(folders: Iterable[pathlib.Path]) -> list[pathlib.Path]:
    """Delete the ``.*.tmp`` files a killed writer left in ``folders`` (not below them; only under their lock)."""
    stale = sorted(p for folder in folders if folder.is_dir() for p in folder.glob(f".*{TMP_SUFFIX}") if p.is_file())
    for p in stale:
        p.unlink(missing_ok=True)
    return stale


def move_aside(path: pathlib.Path, reason: str, then: str = "recomputing") -> pathlib.Path:
    """Rename a damaged file to ``<name>.damaged`` (``.damaged-2``, ... when taken), say so on stderr; the new path."""
    target = path.with_name(path.name + ".damaged")
    n = 1
    while target.exists():
        n += 1
        target = path.with_name(f"{path.name}.damaged-{n}")
    os.replace(path, target)
    print(f"damaged file {path}: {reason}; moved to {target.name}, {then}", file=sys.stderr)
    return target


def pid_alive(pid: int) -> bool:
    """Whether a process ``pid`` exists (``kill(pid, 0)``; a process of another user counts as alive)."""
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


_HELD: dict[pathlib.Path, tuple[int, int]] = {}  # resolved folder -> (fd, depth): this process's locks


class FolderLocked(RuntimeError):
    """Another live process holds the folder's lock."""


class FolderLock:
    """An exclusive, re-entrant (within one process) lock on a folder; see the module docstring.

    Use ``with FolderLock(out, "campaign"):``. A second holder is refused with :class:`FolderLocked` naming the
    folder and the holder's pid.
    """

    def __init__(self, folder: pathlib.Path, what: str = "campaign") -> None:
        self.folder = pathlib.Path(folder)
        self.what = what
        self.path = self.folder / ".lock"
        self.took_over: int | None = None  # the dead holder's pid when a stale lock file was taken over

    def _key(self) -> pathlib.Path:
        return self.folder.resolve()

    def acquire(self) -> FolderLock:
        """Take the lock (or deepen this process's hold on it); raise :class:`FolderLocked` when another has it."""
        self.folder.mkdir(parents=True, exist_ok=True)
        key = self._key()
        if key in _HELD:
            fd, depth = _HELD[key]
            _HELD[key] = (fd, depth + 1)
            return self
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = _read_pid(fd)
            os.close(fd)
            who = f"pid {holder}" if holder else "another process"
            raise FolderLocked(
                f"{self.folder}: another {self.what} ({who}) is running on this folder (lock {self.path}); "
                f"wait for it to finish, stop it, or use another --out"
            ) from None
        old = _read_pid(fd)
        if old and old != os.getpid() and not pid_alive(old):
            self.took_over = old
            print(f"{self.path}: taking over the lock of pid {old}, which is no longer running", file=sys.stderr)
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        _HELD[key] = (fd, 1)
        return self

    def release(self) -> None:
        """Drop one level of this process's hold; the last clears the pid and unlocks (the file stays)."""
        key = self._key()
        fd, depth = _HELD[key]
        if depth > 1:
            _HELD[key] = (fd, depth - 1)
            return
        del _HELD[key]
        with contextlib.suppress(OSError):
            os.ftruncate(fd, 0)
        fcntl.flock(fd, fcntl.LOCK_UN)
        os.close(fd)

    def __enter__(self) -> FolderLock:
        return self.acquire()

    def __exit__(self, *exc: object) -> None:
        self.release()

    @classmethod
    def close_inherited(cls) -> None:
        """In a forked child: close the lock descriptors inherited from the parent (without unlocking theirs)."""
        for fd, _ in _HELD.values():
            with contextlib.suppress(OSError):
                os.close(fd)
        _HELD.clear()


def _read_pid(fd: int) -> int | None:
    """The pid written in a lock file (``None``: empty or unreadable)."""
    try:
        text = os.pread(fd, 32, 0).decode().strip()
        return int(text) if text else None
    except (OSError, ValueError):
        return None


@contextlib.contextmanager
def read_error(path: pathlib.Path, what: str) -> Iterator[None]:
    """Re-raise any error while reading ``path`` as ``ValueError`` naming the file and what it should hold."""
    try:
        yield
    except FileNotFoundError:
        raise
    except Exception as e:
        raise ValueError(f"{path}: cannot be read as {what} ({type(e).__name__}: {e})") from e
