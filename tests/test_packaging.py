"""pip install . gives a working uavwind without a checkout or the book stack."""
import os
import shutil
import subprocess
import sys
import tomllib

import pytest
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_an_installed_package_finds_its_data_and_runs_a_loop(tmp_path):
    # installed from a copy of the sources: setuptools builds in the source tree, and a
    # build/ left in the checkout would put modules deleted since into the installed package
    src = tmp_path / "src"
    shutil.copytree(ROOT / "uavwind", src / "uavwind",
                    ignore=shutil.ignore_patterns("__pycache__", "*.pyc", "*.nb[ic]"))
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(ROOT / name, src / name)
    target = tmp_path / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps",
                    "--no-build-isolation", "--disable-pip-version-check", "--target",
                    str(target), str(src)], check=True, capture_output=True,
                   env={**os.environ, "PIP_NO_INDEX": "1"})
    # every module of the sources is installed, and nothing else
    assert _modules(target / "uavwind") == _modules(ROOT / "uavwind")
    # numba keys its cache on a source file's content (a hash of its bytes), so the kernels
    # this session compiled (tests/conftest.py) serve the installed copy's identical files:
    # copied beside them, the loop below loads them instead of compiling every kernel again
    # (40 s on 2 cores). A file that differs would simply be compiled.
    _copy_numba_cache(ROOT / "uavwind", target / "uavwind")
    # and reading results imports neither the kernels nor scikit-learn (a page that only
    # reads cached results starts in about 1 s instead of 1.8 s): they load when a loop runs
    code = ("import sys, uavwind as uw\n"
            "from uavwind.study import run_experiment\n"
            "from uavwind.analysis import summary_table\n"
            "from uavwind.report import plotting\n"
            "bad = sorted(m for m in sys.modules if m.split('.')[0] == 'sklearn'\n"
            "             or m.startswith(('uavwind.method.softdtw', 'scipy.special')))\n"
            "assert not bad, bad[:5]\n"
            "from uavwind.study.paper import load_paper_values\n"
            "assert 'site' in uw.__file__, uw.__file__\n"
            "t4 = load_paper_values('exp1'); assert t4.loc[0, 'maximum'] == 85.86\n"
            "s = uw.table3_setting(); r = uw.score_loop(s.simulate(uw.PAPER_EXAMPLE), s.groups)\n"
            "assert r.correct and 'uavwind.method.softdtw' in sys.modules\n"
            "assert not any(m.split('.')[0] in ('papermill', 'jupyter_book', 'sphinx', 'plotly')\n"
            "               for m in sys.modules), 'the library imported the book stack'\n")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PYTHONPATH"] = str(target)
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env,
                         capture_output=True, text=True)
    assert out.returncode == 0, out.stderr[-2000:]


def _modules(package):
    return {p.relative_to(package).as_posix() for p in package.rglob("*.py")}


def _copy_numba_cache(src, dst):
    from uavwind.method.softdtw._cache import STAMP
    for f in src.rglob("__pycache__/*.nb[ic]"):
        rel = f.relative_to(src)
        if (dst / rel.parent.parent / f.name.split(".")[0]).with_suffix(".py").exists():
            (dst / rel.parent).mkdir(exist_ok=True)
            shutil.copy2(f, dst / rel)
    for f in src.rglob(f"__pycache__/{STAMP}"):  # the engine's sources' stamp goes along
        (dst / f.relative_to(src).parent).mkdir(exist_ok=True)
        shutil.copy2(f, dst / f.relative_to(src))


def _pins():
    """The package names environment.txt pins, lower case."""
    return {line.split("==")[0].lower() for line in (ROOT / "environment.txt").read_text().split()
            if "==" in line}


def test_runtime_dependencies_are_declared_and_pinned():
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    declared = {d.split("[")[0].split("=")[0].split(">")[0].split("<")[0].strip().lower()
                for d in meta["dependencies"]}
    pins = _pins()
    assert {"numpy", "scipy", "pandas", "numba", "tslearn", "control", "pyarrow"} <= declared
    assert declared <= pins, declared - pins
    assert (ROOT / "CITATION.cff").exists()


def test_the_page_runner_does_not_build_jsonschemas_iri_grammar():
    # rfc3987-syntax (jsonschema's optional format-nongpl extra) compiles a Lark grammar on
    # import, 2.2 CPU-s in every process that imports nbformat: each of the book's page
    # runners paid it. environment.txt leaves it (and lark) out, and nothing pulls it back.
    assert not {"rfc3987-syntax", "lark"} & _pins()
    code = ("import sys, papermill, jupytext, nbformat\n"
            "bad = sorted(m for m in sys.modules if m.split('.')[0] in ('rfc3987_syntax', 'lark'))\n"
            "assert not bad, bad\n")
    subprocess.run([sys.executable, "-c", code], check=True, timeout=120)


@pytest.mark.slow
def test_the_venv_holds_the_checkout_editable_and_warmup_names_its_parts(tmp_path):
    """``make venv`` installs the package editable: a script outside the checkout, without
    PYTHONPATH, imports this checkout's sources; ``python -m uavwind.warmup`` refuses a part
    it does not know."""
    import importlib.metadata

    try:
        importlib.metadata.version("uavwind")
    except importlib.metadata.PackageNotFoundError:
        pytest.skip("this venv was built before make venv installed the package: "
                    "rm .venv/.installed && make venv")
    if (ROOT / ".venv").is_symlink():  # a clone beside another checkout's venv (make bench)
        pytest.skip(f"this checkout's .venv links to {(ROOT / '.venv').resolve()}, whose "
                    "editable install is its own checkout's")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    out = subprocess.run([sys.executable, "-c", "import uavwind; print(uavwind.__file__)"],
                         cwd=tmp_path, env=env, capture_output=True, text=True, check=True)
    assert Path(out.stdout.strip()) == ROOT / "uavwind" / "__init__.py"
    from uavwind import warmup
    assert warmup.main(["bogus"]) == 2
    assert warmup.PARTS == ("engine", "sim", "reference")
    assert warmup.warm("reference") > 0  # tslearn's kernels, cached where numba can
    with pytest.raises(ValueError, match="part must be one of"):
        warmup.warm("bogus")
