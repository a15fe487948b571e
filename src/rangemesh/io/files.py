"""Writing files atomically: a temporary file beside the target, renamed into place.

The file gets the mode a plain write would give; its temporary name carries the writer's tag.
"""

from __future__ import annotations

import errno
import os
import tempfile
from contextlib import contextmanager
from pathlib import Path


def _umask() -> int:
    """The process's umask, read without changing it where Linux allows."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    old = os.umask(0o022)  # elsewhere: the only portable way, set and put back at once
    os.umask(old)
    return old


def _new_file_mode(path: Path) -> int:
    """The mode a plain ``open(path, 'w')`` would give: the old file's, else 0666 less the umask."""
    try:
        return path.stat().st_mode & 0o7777
    except OSError:
        return 0o666 & ~_umask()


def part_owner() -> str:
    """The tag of this process in its temporary files' names: host and process id.

    `rangemesh.batch` removes another run's leftovers only when the process
    that owns them is gone, never the files of a batch still running.
    """
    import socket

    host = "".join(ch if ch.isalnum() or ch == "-" else "-" for ch in socket.gethostname())
    return f"{host or 'host'}.{os.getpid()}"


@contextmanager
def atomic_path(path: str | os.PathLike):
    """Yield a temporary path beside `path`; rename it to `path` only on success.

    The file gets the mode a plain write would give it: an existing file's
    mode is kept, a new file follows the umask (0644 under umask 022). The
    temporary file is removed whatever happens, Ctrl-C included.

    Raises
    ------
    FileNotFoundError
        If the target folder does not exist.
    OSError
        If the file cannot be written (permissions, a full disk, a folder in
        the way); its ``filename`` is `path`, not the temporary name.
    """
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise FileNotFoundError(f"{folder}: folder does not exist")
    if path.is_dir():
        raise IsADirectoryError(errno.EISDIR, "is a folder, not a file to write", str(path))
    tmp = None
    try:
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=f".{path.name}.{part_owner()}.",
                                   suffix=".part" + path.suffix)
        os.close(fd)
        os.chmod(tmp, _new_file_mode(path))  # mkstemp makes it 0600
        yield Path(tmp)
        os.replace(tmp, path)
    except OSError as exc:
        if exc.filename == str(path):
            raise
        raise type(exc)(exc.errno, exc.strerror or str(exc), str(path)) from exc
    finally:
        if tmp is not None:
            Path(tmp).unlink(missing_ok=True)
