"""One page of the book, executed in one process: the build step ``make book`` runs per page.

This module owns :func:`run_page`: a MyST notebook (``notebooks/<page>.md``) read with
jupytext, executed by papermill with the build's parameters (profile, workers) under a
per-cell timeout, its injected parameter cell hidden (the page's provenance lines say the
same, readably), written to ``output`` only when every cell ran. A cell tagged
``needs-env:VAR`` is left out of the page (not run, not shown) when the environment variable
``VAR`` is unset or empty: a page whose data the build does not have shows only what it can.
A cell tagged ``exercise-computes`` (an exercise's solution: a few loops a reader would run
themselves) may compute although the page is read-only: hidden cells around it lift
``UAVWIND_PAGES_READ_ONLY`` for that cell alone, so the solution a reader sees is the code
that ran, with its output under it. The Makefile wraps it in
the page timeout and names the page when it fails; papermill names the cell. Before, the
same three steps were three programs per page (jupytext's, papermill's and a small
script), each paying its own start-up: about 2 CPU-s a page.

``python -m uavwind.report.pages SOURCE OUTPUT --profile quick --jobs 2
--execution-timeout 600 --start-timeout 120 --cwd DIR``

The Makefile runs this file as a script instead (``python uavwind/report/pages.py ...``, the
same arguments): as a module of the package it would import the package first (pandas,
numpy, the registry: about 1.1 of the driver's 2.2 CPU-s of start-up a page), which the
page's kernel imports and the driver never uses. As a script it imports nothing of
uavwind, blocks what its libraries import only when they can (jupytext's notebook-server
contents managers, papermill's Arrow file system: :data:`NOT_NEEDED`), and writes its
output to a temporary file renamed into place, as :func:`uavwind.core.store.atomic_write`
does (the Makefile then moves it to the page's target).
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
from pathlib import Path

#: What a page's driver run as a script keeps its libraries from importing: they import it
#: only when they can, for what the driver never does (serve notebooks, read HDFS).
NOT_NEEDED = ("jupyter_server", "pyarrow")

if __package__:  # a module of the package
    from ..core.io import READ_ONLY_ENV
    from ..core.store import atomic_write
else:  # run as a script (the Makefile): uavwind is not imported (tests/test_build_timeouts.py
    # runs a page this way, and checks this name against uavwind.core.io's)
    READ_ONLY_ENV = "UAVWIND_PAGES_READ_ONLY"
    atomic_write = None
    # this file's folder is not a folder of modules: its names (display, plotting) would
    # shadow any library's of the same name
    sys.path[:] = [q for q in sys.path
                   if Path(q or ".").resolve() != Path(__file__).resolve().parent]
    for _name in NOT_NEEDED:
        sys.modules.setdefault(_name, None)

__all__ = ["run_page", "KERNEL", "NEEDS_ENV", "COMPUTES", "NOT_NEEDED", "main"]

#: The tag prefix of a cell that needs an environment variable (``needs-env:VAR``).
NEEDS_ENV = "needs-env:"

#: The tag of a cell that may compute on a read-only page (an exercise's solution).
COMPUTES = "exercise-computes"

#: The kernel every page runs on.
KERNEL = {"name": "python3", "display_name": "Python 3", "language": "python"}


def run_page(source: os.PathLike | str, output: os.PathLike | str, profile: str, n_jobs: int,
             execution_timeout: float | None = None, start_timeout: float = 60,
             cwd: os.PathLike | str | None = None) -> Path:
    """Execute the MyST notebook ``source`` with the parameters ``profile`` and ``n_jobs``
    (a cell over ``execution_timeout`` seconds fails it) and write the executed notebook to
    ``output``, atomically, with the injected parameter cell tagged ``remove-cell``.

    Raises papermill's ``PapermillExecutionError`` (naming the cell) when a cell fails, and
    writes nothing then.
    """
    import jupytext
    import nbformat
    import papermill

    source, output = Path(source), Path(output)
    if not source.is_file():
        raise ValueError(f"source must be an existing MyST notebook, got {str(source)!r}")
    nb = jupytext.read(source)
    nb.metadata["kernelspec"] = dict(KERNEL)
    nb.cells = [c for c in nb.cells if all(
        os.environ.get(t[len(NEEDS_ENV):]) for t in c.metadata.get("tags", [])
        if t.startswith(NEEDS_ENV))]
    nb.cells = _lift_read_only(nb.cells, nbformat)
    nb = papermill.execute_notebook(
        nb, None, parameters={"profile": profile, "n_jobs": n_jobs}, kernel_name=KERNEL["name"],
        execution_timeout=execution_timeout, start_timeout=start_timeout, log_output=True,
        progress_bar=False, cwd=None if cwd is None else str(cwd))
    for cell in nb.cells:
        tags = cell.metadata.setdefault("tags", [])
        if "injected-parameters" in tags and "remove-cell" not in tags:
            tags.append("remove-cell")
    if atomic_write is not None:
        return atomic_write(output, lambda tmp: nbformat.write(nb, str(tmp)), name="output")
    tmp = output.with_name(f".{output.name}.{os.getpid()}.tmp")  # a script: all or nothing
    try:
        nbformat.write(nb, str(tmp))
        os.replace(tmp, output)
    finally:
        tmp.unlink(missing_ok=True)
    return output


def _lift_read_only(cells: list, nbformat) -> list:
    """``cells`` with a hidden cell before each :data:`COMPUTES` cell that lifts the
    read-only flag, and one after it that restores it (pages run read-only: see the Makefile)."""
    def hidden(source):
        return nbformat.v4.new_code_cell(source, metadata={"tags": ["remove-cell"]})
    out = []
    for cell in cells:
        if cell.cell_type == "code" and COMPUTES in cell.metadata.get("tags", []):
            out.append(hidden(f"import os as _os\n_read_only = _os.environ.pop({READ_ONLY_ENV!r}, None)"))
            out.append(cell)
            out.append(hidden(f"if _read_only is not None:\n    _os.environ[{READ_ONLY_ENV!r}] = _read_only"))
        else:
            out.append(cell)
    return out


def main(argv: list[str] | None = None) -> int:
    """The command line of :func:`run_page`; exit status 0 when every cell ran."""
    p = argparse.ArgumentParser(prog="python -m uavwind.report.pages",
                                description="Execute one page of the book.")
    p.add_argument("source")
    p.add_argument("output")
    p.add_argument("--profile", required=True)
    p.add_argument("--jobs", type=int, required=True)
    p.add_argument("--execution-timeout", type=float, default=None, help="per cell [s]")
    p.add_argument("--start-timeout", type=float, default=60, help="kernel start [s]")
    p.add_argument("--cwd", default=None)
    args = p.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s", stream=sys.stderr)
    run_page(args.source, args.output, args.profile, args.jobs, args.execution_timeout,
             args.start_timeout, args.cwd)
    return 0


if __name__ == "__main__":  # pragma: no cover - the Makefile's entry point
    sys.exit(main())
