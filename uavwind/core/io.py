"""Two rules about files: what a target may be, and when nothing may be computed.

This module owns :func:`check_target` (a path that is a regular file or a new one, never a
folder, a device or a named pipe: what :func:`uavwind.core.store.atomic_write`, the one
atomic write, may replace) and :func:`refuse_to_compute` with :data:`READ_ONLY_ENV` (while
the book's pages run, a result missing from the cache is an error naming it, never computed).
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

__all__ = ["check_target", "READ_ONLY_ENV", "refuse_to_compute"]

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
