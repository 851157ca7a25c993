"""Progress without a terminal (CI, nohup, a pipe): a plain ``done/total, rate, ETA`` line at
least every ``--progress-every`` seconds (30 by default, 1 at least), for ``run``, ``sweep``,
the tune's screen and race rounds and the report's videos (issue 36)."""

from __future__ import annotations

import io
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

from harness.runs import progress as progress_module
from harness.runs.progress import (
    EVERY_S,
    ProgressLines,
    SweepProgress,
    duration,
    progress_interval,
    set_progress_interval,
)

ROOT = Path(__file__).resolve().parents[1]
LINE = re.compile(
    r"^(?P<label>[a-z ]+\w*): (?P<done>\d+)/(?P<total>\d+) episodes \(\d+%\), "
    r"[\d.]+ episodes/s, ETA \S+"
)


def _wait_for(condition, timeout_s: float = 10.0) -> None:
    deadline = time.monotonic() + timeout_s
    while not condition() and time.monotonic() < deadline:
        time.sleep(0.01)


def test_lines_come_on_time_even_when_nothing_finishes() -> None:
    stream = io.StringIO()
    lines = ProgressLines("sweep", 10, already=2, every_s=0.05, stream=stream).start()
    _wait_for(lambda: lines.printed >= 1)
    assert "sweep: 2/10 episodes (20%), 0.00 episodes/s, ETA - (none finished" in stream.getvalue()
    lines.advance(3, note="success 1/3")
    _wait_for(lambda: "5/10" in stream.getvalue())
    lines.stop()
    text = stream.getvalue().splitlines()
    later = [line for line in text if "5/10" in line]
    assert later and LINE.match(later[0]) and later[0].endswith("success 1/3")
    assert re.fullmatch(r"sweep: 5/10 episodes in \d+s", text[-1])  # the last line: time taken


def test_a_job_done_before_the_first_line_prints_nothing() -> None:
    stream = io.StringIO()
    with ProgressLines("report videos", 3, unit="clips", every_s=30, stream=stream) as lines:
        lines.advance(3)
    assert stream.getvalue() == ""


def _every(monkeypatch: pytest.MonkeyPatch, seconds: float) -> None:
    """This process's progress interval for one test (below the flag's 1 s floor, to be quick)."""
    monkeypatch.setattr(progress_module, "_EVERY_S", [seconds])


def test_the_interval_is_the_flags(monkeypatch: pytest.MonkeyPatch) -> None:
    from harness.cli import build_parser

    _every(monkeypatch, EVERY_S)
    assert progress_interval() == EVERY_S == 30.0
    set_progress_interval(0.5)
    assert progress_interval() == 0.5
    with pytest.raises(ValueError, match="positive number of seconds"):
        set_progress_interval(0.0)
    args = build_parser().parse_args(["sweep", "x.yaml", "--progress-every", "5"])
    assert args.progress_every == 5.0
    assert [duration(s) for s in (47, 185, 3720)] == ["47s", "3m05s", "1h02m"]


@pytest.mark.parametrize(
    ("value", "says"),
    [
        ("0.5", "0.5 s is below the shortest, 1 s"),
        ("nan", "'nan' is not a finite number"),
        ("soon", "'soon' is not a number"),
    ],
)
def test_a_bad_progress_interval_is_one_usage_line(
    value: str, says: str, capsys: pytest.CaptureFixture[str]
) -> None:
    from harness.cli import main

    with pytest.raises(SystemExit) as stop:
        main(["run", "task.yaml", "--progress-every", value])
    assert stop.value.code == 2
    assert capsys.readouterr().err.splitlines()[-1].endswith(f"--progress-every: {says}")


def test_sweep_progress_without_a_terminal_prints_lines(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    _every(monkeypatch, 0.05)  # capsys' stdout is no terminal
    progress = SweepProgress(4, 1, enabled=True, workers=2, label="race round 2")
    on_row = progress.__enter__()
    assert progress.lines is not None
    on_row({"success": True})
    on_row({"success": False})
    _wait_for(lambda: progress.lines is not None and progress.lines.printed >= 1)
    progress.__exit__(None, None, None)
    out = capsys.readouterr().out.splitlines()
    ticks = [line for line in out if LINE.match(line)]
    assert ticks and ticks[0].startswith("race round 2: 3/4 episodes (75%)")
    assert ticks[0].endswith("success 1/2")
    assert out[-1].startswith("race round 2: 3/4 episodes in ")


def test_a_sweep_names_its_progress_lines(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``run_sweep(progress="tune screen")``: the tune's screening sweep says what it is."""
    from harness.runs.sweep import run_sweep

    _every(monkeypatch, 0.05)
    sweep = tmp_path / "one.yaml"
    task = str(ROOT / "tasks" / "pick" / "fr3.yaml")
    sweep.write_text(yaml.safe_dump({"name": "one", "tasks": [task], "episodes_per_point": 1}))
    run_sweep(sweep, out=tmp_path / "run", backend="serial", progress="tune screen")
    out = capsys.readouterr().out.splitlines()
    ticks = [m for m in map(LINE.match, out) if m]
    assert ticks and {m["label"] for m in ticks} == {"tune screen"}
    assert out[-1].startswith("tune screen: 1/1 episodes in ")


def _cli(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    """The command with stdout on a pipe, as under CI or ``| tee``, and the shortest interval."""
    return subprocess.run(
        [sys.executable, "-m", "harness.cli", *args, "--progress-every", "1"],
        cwd=cwd,
        capture_output=True,  # stdout and stderr on pipes
        text=True,
        check=False,
        timeout=600,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )


@pytest.mark.slow
def test_run_and_sweep_print_progress_lines_into_a_pipe(tmp_path: Path) -> None:
    task = str(ROOT / "tasks" / "pick" / "fr3.yaml")
    run = _cli("run", task, "--episodes", "2", "--record", "none", "--out", "r", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    ticks = [m for m in map(LINE.match, run.stdout.splitlines()) if m]
    assert ticks and {m["label"] for m in ticks} == {"run"}
    assert all(m["total"] == "2" for m in ticks)
    assert re.search(r"^run: 2/2 episodes in \d+s$", run.stdout, flags=re.M)
    sweep = tmp_path / "small.yaml"
    sweep.write_text(
        yaml.safe_dump(
            {
                "name": "small",
                "tasks": [task],
                "axes": {"pick.approach_filter": [["downward", 120], ["downward", 160]]},
                "episodes_per_point": 1,
                "record": "none",
            }
        ),
        encoding="utf-8",
    )
    made = _cli("sweep", str(sweep), "--workers", "1", "--out", "s", cwd=tmp_path)
    assert made.returncode == 0, made.stderr
    ticks = [m for m in map(LINE.match, made.stdout.splitlines()) if m]
    assert ticks and {m["label"] for m in ticks} == {"sweep"}
    assert all(m["total"] == "2" for m in ticks)
    assert re.search(r"^sweep: 2/2 episodes in \d+s$", made.stdout, flags=re.M)
