"""Writing files all at once, or not at all.

This module owns :func:`atomic_write`, the one way the project writes a file another process
or a later run may read (cache chunks, the explorer's grid, the ``--times`` record): the
content goes to a temporary file with a unique name in the same folder (so concurrent
writers never share one), is flushed to disk, and is renamed over the target; if anything
fails, the temporary file is removed and the target is untouched. It refuses to replace
anything but a regular file (a device or a named pipe at the path is an error, never
replaced by a file).
"""

from __future__ import annotations

import contextlib
import os
import stat
import tempfile
from collections.abc import Callable
from pathlib import Path

__all__ = ["atomic_write", "check_target", "READ_ONLY_ENV", "refuse_to_compute"]

#: Set (to 1) while the book's pages run: a page reads what the fill computed and never
#: computes it itself, so a result missing from the cache is an error naming it.
READ_ONLY_ENV = "UAVWIND_PAGES_READ_ONLY"


def refuse_to_compute(what: str) -> None:
    """``RuntimeError`` naming ``what`` when :data:`READ_ONLY_ENV` is set (a page would
    compute a result the fill should have made); nothing otherwise."""
    if os.environ.get(READ_ONLY_ENV, "") not in ("", "0"):
        raise RuntimeError(f"a page tried to compute {what}, which is not in the result cache: "
                           f"pages read what `make results` computed ({READ_ONLY_ENV} is set); "
                           f"run the fill first, or add this result to it")


def check_target(path: os.PathLike | str, name: str = "path") -> Path:
    """``path`` as a Path if it is a regular file or does not exist yet (in an existing
    folder); ``ValueError`` naming ``name`` for a folder, a device, a pipe or a socket."""
    path = Path(path).expanduser()
    try:
        st = os.stat(path)
    except FileNotFoundError:
        return path
    except OSError as exc:
        raise ValueError(f"{name} {str(path)!r} cannot be used ({exc.strerror or exc})") from None
    if not stat.S_ISREG(st.st_mode):
        what = "a folder" if stat.S_ISDIR(st.st_mode) else "not a regular file"
        raise ValueError(f"{name} must be a regular file or a new path, got {str(path)!r} "
                         f"({what})")
    return path


def atomic_write(path: os.PathLike | str, write: Callable[[Path], None] | str | bytes,
                 name: str = "path") -> Path:
    """Write ``path`` atomically.

    Parameters
    ----------
    path : path-like
        The target: a regular file (replaced) or a new path; its folder is created.
    write : callable, str or bytes
        ``write(tmp_path)`` writes the content to the temporary path it is given (e.g.
        ``lambda p: df.to_parquet(p, index=False)``); a ``str`` or ``bytes`` is written as is.
    name : str
        The parameter named in errors.

    Returns
    -------
    Path
        The target.
    """
    path = check_target(path, name)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    tmp = Path(tmp)
    try:
        if isinstance(write, str):
            tmp.write_text(write)
        elif isinstance(write, bytes):
            tmp.write_bytes(write)
        else:
            write(tmp)
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise
    return path
