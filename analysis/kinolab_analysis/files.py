"""Writing into a report or export directory without following links: a link planted there
(`index.html` -> someone's file, `figures` -> another directory) is refused, never written
through, as the C++ side refuses a linked lock file or results database."""

import errno
import os
import stat
from pathlib import Path


def _refuse_link(path: Path) -> None:
    raise ValueError(f"{path}: is a symbolic link; kinolab does not write through links: "
                     "remove it, or choose another directory")


def directory(path: Path) -> Path:
    """`path` made a directory (with its parents) when it is none; a link is refused."""
    if path.is_symlink():
        _refuse_link(path)
    path.mkdir(parents=True, exist_ok=True)
    return path


def write_bytes(path: Path, data: bytes) -> None:
    """Writes `data` to `path`, a regular file (created or truncated); a link, a pipe or a
    device at `path` is refused before anything is written."""
    flags = os.O_WRONLY | os.O_CREAT | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC
    not_regular = ValueError(f"{path}: is not a regular file: remove it, or choose another "
                             "directory")
    try:
        descriptor = os.open(path, flags, 0o644)
    except OSError as error:
        if error.errno == errno.ELOOP:
            _refuse_link(path)
        if error.errno == errno.ENXIO:  # a pipe nobody reads
            raise not_regular from error
        raise
    with os.fdopen(descriptor, "wb") as out:
        if not stat.S_ISREG(os.fstat(descriptor).st_mode):
            raise not_regular
        out.truncate(0)
        out.write(data)


def write_text(path: Path, text: str) -> None:
    """Writes `text` (UTF-8) to `path` as write_bytes() does."""
    write_bytes(path, text.encode("utf-8"))
