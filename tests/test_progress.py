"""What a run prints: a quiet run nothing on success, a run in a log (not a terminal) a line
every few seconds rather than one per step."""

from __future__ import annotations

import io

from rftfem.outputs import progress as output


class _Comm:
    rank = 0


class _Clock:
    def __init__(self):
        self.now = 0.0

    def __call__(self):
        return self.now


def _updates(progress, clock, steps: int, step_seconds: float):
    for k in range(1, steps + 1):
        clock.now += step_seconds
        progress.update(k * 0.001, k, 3 * k, 1e-12)


def test_piped_run_of_2000_steps_prints_a_line_every_interval(monkeypatch):
    clock = _Clock()
    monkeypatch.setattr(output._time, "perf_counter", clock)
    stream = io.StringIO()  # not a terminal
    p = output.Progress(2.0, _Comm(), stream=stream, interval=5.0)
    p.log("opening line")
    _updates(p, clock, 2000, 0.05)  # 100 s of steps
    p.final("done: 2000 steps")
    lines = stream.getvalue().splitlines()
    assert lines[0] == "opening line" and lines[-1] == "done: 2000 steps"
    progress_lines = lines[1:-1]
    # the first step, then one line per 5 s of a 100 s run
    assert 19 <= len(progress_lines) <= 21, len(progress_lines)
    assert progress_lines[-1].startswith("t = 1.9")


def test_quiet_run_prints_nothing_on_success(monkeypatch):
    clock = _Clock()
    monkeypatch.setattr(output._time, "perf_counter", clock)
    stream = io.StringIO()
    p = output.Progress(2.0, _Comm(), quiet=True, stream=stream, interval=0.0)
    p.log("opening line")
    p.log("step 3 at t = 0.003: halving dt")
    _updates(p, clock, 2000, 0.05)
    p.final("done: 2000 steps")
    assert stream.getvalue() == ""


def test_other_ranks_print_nothing(monkeypatch):
    class Rank1:
        rank = 1

    stream = io.StringIO()
    p = output.Progress(2.0, Rank1(), stream=stream, interval=0.0)
    p.log("x")
    p.update(1.0, 1, 1, 0.0)
    p.final("done")
    assert stream.getvalue() == ""


def test_warnings_are_kept_and_go_to_stderr_when_quiet(monkeypatch, capsys):
    """Every warning is kept in order (summary.json's `warnings`); a quiet run writes
    it to stderr, a run that is not quiet to its own stream."""
    stream = io.StringIO()
    p = output.Progress(2.0, _Comm(), quiet=True, stream=stream, interval=0.0)
    p.warn("warning: one")
    p.warn("warning: two")
    assert p.warnings == ["warning: one", "warning: two"]
    assert stream.getvalue() == "" and capsys.readouterr().err == "warning: one\nwarning: two\n"
    loud = output.Progress(2.0, _Comm(), stream=stream, interval=0.0)
    loud.warn("warning: three")
    assert stream.getvalue() == "warning: three\n" and loud.warnings == ["warning: three"]
