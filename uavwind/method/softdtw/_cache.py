"""numba's on-disk cache of the engine's kernels: the stamp of their sources, and the stale
entries it clears.

numba keys a cached kernel on its own source file only: a kernel of :mod:`._lockstep` that
inlines or calls :mod:`._lockstep_forward`, :mod:`._vlibm` or :mod:`._libm` is loaded from
the cache unchanged after any of those files changed, and runs the old code (seen: a
forward pass changed in :mod:`._lockstep_forward` was not what the held-out check timed
until the cache was cleared by hand). So the folder of the cache holds a stamp, the SHA-256
of every source file of this subpackage; where it differs from the sources present (or is
missing), every cached entry of this subpackage's modules is deleted before any kernel is
loaded, and the kernels compile again. Other packages' entries in the folder are left alone.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

#: The stamp's file name, in the folder numba caches this subpackage's kernels in.
STAMP = "uavwind-softdtw-sources.sha256"


def sources_digest(package: Path) -> str:
    """SHA-256 over the names and bytes of the subpackage's ``*.py`` files, in name order."""
    h = hashlib.sha256()
    for f in sorted(package.glob("*.py")):
        h.update(f.name.encode() + b"\0" + f.read_bytes() + b"\0")
    return h.hexdigest()


def clear_stale(folder: Path, package: Path, digest: str | None = None) -> list[Path]:
    """Delete the cached entries (``<module>.*.nbi`` / ``.nbc``) of the modules of
    ``package`` from ``folder`` unless its stamp equals ``digest`` (the sources' digest by
    default), then write the stamp; the deleted files. A folder that cannot be read or
    written (a read-only install) is left as it is."""
    digest = sources_digest(package) if digest is None else digest
    stamp = folder / STAMP
    try:
        if stamp.read_text().strip() == digest:
            return []
    except OSError:
        pass  # no stamp yet: a fresh cache, or one written before stamps
    stems = sorted(f.stem for f in package.glob("*.py"))
    gone = []
    try:
        folder.mkdir(parents=True, exist_ok=True)
        for stem in stems:
            for f in sorted(folder.glob(f"{stem}.*.nb[ic]")):
                f.unlink(missing_ok=True)
                gone.append(f)
        tmp = folder / f"{STAMP}.{os.getpid()}.tmp"  # one writer per process
        tmp.write_text(digest + "\n")
        tmp.replace(stamp)  # atomic: a reader sees the old stamp or the new one
    except OSError:
        pass  # read-only or vanished: what was deleted is reported, the stamp is not written
    return gone


def check(dispatcher) -> list[Path]:
    """:func:`clear_stale` on the folder numba caches ``dispatcher`` (one of this
    subpackage's kernels) in, for this subpackage's sources."""
    folder = getattr(getattr(dispatcher, "_cache", None), "_cache_path", None)
    if folder is None:  # numba caches nothing here (no writable folder): nothing to clear
        return []
    return clear_stale(Path(folder), Path(__file__).parent)
