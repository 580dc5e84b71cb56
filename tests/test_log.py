"""Logs and progress: plain unwrapped lines during a stage off a terminal, live bars on one, the verbosity levels."""

from __future__ import annotations

import io
import os
import re
import subprocess
import sys

import pytest
from rich.console import Console

from deformsim import log
from tests.util import ROOT

LINE = re.compile(r"^\d{4}-\d\d-\d\d \d\d:\d\d:\d\d INFO render: (\d+)/200 \(\d+%\), [\d.]+(/s| s each), (eta|done in) \S+$")


@pytest.fixture(autouse=True)
def normal():
    yield
    log.set_verbosity("normal")


def slow_bake() -> None:
    now = [0.0]
    with log.progress_bar(2, "bake", clock=lambda: now[0]) as bar:
        for _ in range(2):
            now[0] += 60.0
            bar.update()


def test_progress_off_a_terminal_is_logged_during_the_stage(capsys):
    now = [0.0]
    bar = log.progress_bar(200, "render", clock=lambda: now[0])
    for _ in range(100):  # half the work at 0.3 s an image: a line every 10 %
        now[0] += 0.3
        bar.update()
    during = capsys.readouterr().err.splitlines()
    assert all(LINE.match(line) for line in during), during
    assert [int(LINE.match(line)[1]) for line in during] == [20, 40, 60, 80, 100]
    assert during[-1].endswith("render: 100/200 (50%), 3.33/s, eta 0m30s")
    for _ in range(100):
        now[0] += 0.3
        bar.update()
    bar.close()
    assert capsys.readouterr().err.splitlines()[-1].endswith("200/200 (100%), 3.33/s, done in 1m00s")


def test_slow_progress_is_logged_every_few_seconds(capsys):
    now = [0.0]
    with log.progress_bar(200, "render", clock=lambda: now[0]) as bar:
        for _ in range(3):  # 40 s an image: far from the next 10 %, a line each time
            now[0] += 40.0
            bar.update()
        lines = capsys.readouterr().err.splitlines()
        assert [int(LINE.match(line)[1]) for line in lines] == [1, 2, 3]
        assert lines[-1].endswith("render: 3/200 (1%), 40.0 s each, eta 2h11m20s")


def test_work_done_within_seconds_leaves_no_progress_line(capsys):
    now = [0.0]
    with log.progress_bar(200, "render", clock=lambda: now[0]) as bar:
        for _ in range(200):
            now[0] += 0.001
            bar.update()
    assert capsys.readouterr().err == ""


def test_a_long_log_line_is_not_wrapped_in_a_log_file(tmp_path):
    value = "/data/" + "very-long-folder-name/" * 12 + "image.png"
    code = ("from deformsim.log import get_logger\n"
            f"get_logger('deformsim.t').warning('mesh %s: set units: mm', {value!r})\n"
            f"get_logger('deformsim.t').info('rendering 6000 images (3000 samples x 2 cameras) to %s', {value!r})\n")
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src"), "COLUMNS": "80"}
    with open(tmp_path / "run.log", "w") as f:
        subprocess.run([sys.executable, "-c", code], env=env, stdout=subprocess.DEVNULL, stderr=f, check=True,
                       timeout=120)
    lines = (tmp_path / "run.log").read_text().splitlines()
    assert len(lines) == 2, lines
    assert lines[0].endswith(f"WARNING mesh {value}: set units: mm")
    assert lines[1].endswith(f"INFO rendering 6000 images (3000 samples x 2 cameras) to {value}")


def test_logs_and_progress_go_to_stderr(capsys):
    log.get_logger("deformsim.t").info("rendering with 2 worker(s)")
    slow_bake()
    out, err = capsys.readouterr()
    assert out == "" and "rendering with 2 worker(s)" in err and "bake: 2/2" in err


def test_verbosity_levels(capsys):
    logger = log.get_logger("deformsim.t")

    def shown() -> str:
        logger.debug("epoch 1/2")
        logger.info("trained 2 epochs")
        logger.warning("variant holds 3 of 4 images")
        slow_bake()
        return capsys.readouterr().err

    log.set_verbosity("quiet")
    quiet = shown()
    assert "variant holds" in quiet and "trained" not in quiet and "bake" not in quiet and "epoch 1/2" not in quiet
    log.set_verbosity("normal")
    normal = shown()
    assert "trained" in normal and "bake: 2/2" in normal and "epoch 1/2" not in normal
    log.set_verbosity("verbose")
    assert "DEBUG epoch 1/2" in shown()
    with pytest.raises(ValueError, match="quiet, normal, verbose"):
        log.set_verbosity("loud")


def test_a_terminal_gets_a_live_bar_and_no_progress_lines(monkeypatch, capsys):
    screen = io.StringIO()
    monkeypatch.setattr(log, "_console", Console(file=screen, force_terminal=True, width=100))
    with log.progress_bar(4, "render") as bar:
        bar.update(4)
    assert "render" in screen.getvalue() and "4/4" in screen.getvalue()
    assert capsys.readouterr().err == ""


def test_a_terminal_shows_iso_times_as_the_log_files_do(monkeypatch):
    import logging

    screen = Console(file=io.StringIO(), force_terminal=True, width=200, color_system=None)
    monkeypatch.setattr(log, "_console", screen)
    handler = log._Handler()
    handler.emit(logging.LogRecord("deformsim.x", logging.INFO, __file__, 1, "stage %s", ("report",), None))
    handler.emit(logging.LogRecord("deformsim.x", logging.INFO, __file__, 2, "again", (), None))
    lines = screen.file.getvalue().splitlines()
    assert all(re.match(r"^\[\d{4}-\d\d-\d\d \d\d:\d\d:\d\d\] INFO +(stage report|again)", line) for line in lines), lines
