"""The command line: one-line usage errors, --jobs, --times."""
import json

import pytest

from uavwind import study as ex
from uavwind.cli import main
from uavwind.study import fill

TINY = {"loops": 2, "long_loops": 2, "fit_loops": 2,
        "cem": {"n_samples": 3, "n_elite": 1, "max_iter": 2}}


@pytest.mark.parametrize("argv, option", [
    (["run", "exp1", "--jobs", "0"], "--jobs"), (["run", "exp1", "--seed", "-5"], "--seed"),
    (["run", "exp1", "--engine", "bogus"], "--engine"), (["run", "exp99"], "exp99"),
])
def test_cli_usage_errors_are_one_line(argv, option, capsys):
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "error" in err and option in err and "Traceback" not in err


def test_cli_caps_jobs_and_reports_an_unwritable_folder(tmp_path, monkeypatch, capsys):
    blocker = tmp_path / "f"
    blocker.write_text("x")
    monkeypatch.setenv("UAVWIND_RESULTS", str(blocker))
    assert main(["run", "exp5", "--jobs", "999", "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "using" in err and "cannot be written" in err


def test_cli_times_file_records_every_computed_entry(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(ex.PROFILES, "tiny", ex.get_profile({**TINY, "name": "tiny"}))
    monkeypatch.setenv("UAVWIND_RESULTS", str(tmp_path / "r"))
    out = tmp_path / "times.json"
    assert main(["run", "exp5", "--profile", "tiny", "--jobs", "1", "--no-progress",
                 "--no-tables", "--times", str(out)]) == 0
    rec = json.loads(out.read_text())
    assert rec["profile"] == "tiny"
    assert len(rec["entries"]) == len(fill.needed_entries(["exp5"], "tiny")) > 0
    assert {e["experiment"] for e in rec["entries"]} == {"exp5"}
    assert "by experiment and reading" in capsys.readouterr().out
    # a second run computes nothing and says so in the file
    assert main(["run", "exp5", "--profile", "tiny", "--jobs", "1", "--no-progress",
                 "--no-tables", "--times", str(out)]) == 0
    assert json.loads(out.read_text())["entries"] == []
    with pytest.raises(SystemExit) as stop:
        main(["run", "exp5", "--profile", "tiny", "--times", str(tmp_path / "no" / "t.json")])
    assert stop.value.code == 2 and "--times" in capsys.readouterr().err


def test_cli_keeps_the_times_of_finished_entries_when_interrupted(tmp_path, monkeypatch):
    import uavwind.cli as cli

    def interrupted(*args, times=None, **kwargs):
        times.append({"experiment": "exp5", "reading": "inferred", "rows": 2,
                      "cpu_seconds": 1.5})
        raise KeyboardInterrupt
    monkeypatch.setattr(cli, "fill_cache", interrupted)
    out = tmp_path / "times.json"
    assert main(["run", "exp5", "--no-progress", "--times", str(out)]) == 130
    rec = json.loads(out.read_text())
    assert rec["complete"] is False and rec["entries"][0]["cpu_seconds"] == 1.5
    assert [p.name for p in tmp_path.iterdir()] == ["times.json"]  # no temporary file left
