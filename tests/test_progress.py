"""The progress indicator (stages on their own lines, a tqdm bar for fractions)."""

import io

from kanedyn._progress import NO_PROGRESS, Progress, as_progress


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def test_stages_and_bar():
    stream = _Terminal()
    progress = Progress(stream=stream, interval=0.0)
    progress.stage("deriving")
    for k in range(1, 5):
        progress.update("simulating", k / 4)
    progress.update("simulating", 0.5)  # a trial point behind: the bar stays
    progress.stage("writing")
    text = stream.getvalue()
    assert "] deriving\n" in text and "] writing\n" in text
    assert "simulating  25.0%" in text and "simulating 100.0%" in text
    assert text.index("deriving") < text.index("100.0%") < text.index("writing")
    assert progress._bar is None  # closed by the next stage


def test_updates_are_throttled():
    stream = _Terminal()
    progress = Progress(stream=stream, interval=3600.0)
    progress.update("simulating", 0.1)
    progress.update("simulating", 0.9)
    assert "10.0%" in stream.getvalue() and "90.0%" not in stream.getvalue()
    progress.done()  # the last state is shown when the bar closes
    assert "90.0%" in stream.getvalue()


def test_disabled_writes_nothing():
    stream = io.StringIO()
    progress = Progress(enabled=False, stream=stream, interval=0.0)
    progress.stage("x")
    progress.update("y", 0.5)
    progress.done()
    assert stream.getvalue() == ""
    assert as_progress(False).enabled is False and as_progress(NO_PROGRESS) is NO_PROGRESS


def test_no_bar_and_no_carriage_return_off_a_terminal():
    """A log file or a pipe gets plain lines: the first state of a step, then at
    most one line per line_interval, and the last state when the step ends."""
    stream = io.StringIO()
    progress = Progress(stream=stream, interval=0.0, line_interval=3600.0)
    progress.stage("deriving")
    for k in range(1, 5):
        progress.update("simulating", k / 4)
    progress.update("simulating", 0.5)  # a trial point behind: the state stays
    progress.stage("writing")
    text = stream.getvalue()
    assert "\r" not in text and "|" not in text
    lines = [line.split("] ", 1)[1] for line in text.splitlines()]
    assert lines == ["deriving", "simulating  25.0%", "simulating 100.0%", "writing"]
    progress.update("more", 0.3)
    progress.update("more", 0.3)
    progress.done()
    assert stream.getvalue().splitlines()[-1].endswith("] more  30.0%")
    assert stream.getvalue().count("more") == 1  # the same line is not written twice
