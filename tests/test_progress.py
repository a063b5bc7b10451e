"""Progress bar: draws on a terminal, silent on pipes and with quiet."""

from __future__ import annotations

import io

import pytest

from robocal.core import progress
from robocal.core.progress import Progress, track


class FakeTTY(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_draws_on_a_terminal_with_info():
    out = FakeTTY()
    with Progress(4, "lsq", stream=out, min_interval=0.0) as bar:
        for k in range(4):
            bar.update(info=f"rms {0.5 / (k + 1):.3f} mm")
    text = out.getvalue()
    assert text.endswith("\n")
    last = text.rstrip("\n").split("\r")[-1]
    assert last.startswith("lsq: [" + "#" * 30 + "] 4/4 100%")
    assert last.rstrip().endswith("rms 0.125 mm")
    assert "1/4" in text and "2/4" in text


def test_silent_on_a_pipe_and_with_quiet():
    pipe = io.StringIO()
    with Progress(3, "x", stream=pipe, min_interval=0.0) as bar:
        bar.update(3, info="done")
    assert pipe.getvalue() == ""
    tty = FakeTTY()
    with Progress(3, "x", quiet=True, stream=tty) as bar:
        bar.update(3)
    assert tty.getvalue() == ""


def test_default_quiet_follows_set_quiet():
    tty = FakeTTY()
    progress.set_quiet(True)
    try:
        with Progress(2, "x", stream=tty) as bar:
            bar.update(2)
    finally:
        progress.set_quiet(False)
    assert tty.getvalue() == ""
    with Progress(2, "x", stream=tty, min_interval=0.0) as bar:
        bar.update(2)
    assert "2/2" in tty.getvalue()


def test_track_yields_everything_and_counts():
    tty = FakeTTY()
    items = list(track(range(5), "mc", stream=tty))
    assert items == [0, 1, 2, 3, 4]
    assert "5/5 100%" in tty.getvalue()


def test_unknown_total_and_throttling():
    tty = FakeTTY()
    with Progress(None, "scan", stream=tty, min_interval=3600.0) as bar:
        for _ in range(100):
            bar.update()
    frames = tty.getvalue().rstrip("\n").split("\r")[1:]
    # throttled: the opening frame and the closing frame only
    assert len(frames) == 2
    assert frames[-1].startswith("scan: 100 ")


@pytest.mark.parametrize("total", [0, 1])
def test_small_totals(total):
    tty = FakeTTY()
    with Progress(total, stream=tty, min_interval=0.0) as bar:
        bar.update(total)
    assert tty.getvalue().endswith("\n")


def test_every_command_help_has_an_example(capsys):
    from robocal.cli import COMMANDS, main

    assert COMMANDS
    for command in COMMANDS:
        with pytest.raises(SystemExit) as exit_info:
            main([command, "--help"])
        assert exit_info.value.code == 0
        text = capsys.readouterr().out
        assert "Example" in text, f"`robocal {command} --help` shows no example"
        assert f"robocal {command}" in text.split("Example", 1)[1], f"{command}: example does not run it"
