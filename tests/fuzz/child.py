"""Runs fuzz cases through the command line in this process (``python -m tests.fuzz.child``): each line on stdin
names a JSON file of cases and the first to run, ``{"cases": PATH, "start": I}``.

Each case (a dict: ``argv``, ``timeout`` in seconds, ``render``, ``env``) runs through click's ``CliRunner``, the
process's data segment capped (``FUZZ_MEMORY`` bytes), so a memory bomb fails here instead of on the machine.
Nothing renders: a Blender worker that would start raises :class:`RenderStarted` (``render: "stop"``, recorded as
``rendered``), or is a fake worker (``render: "fake"``) so the command runs on to its end. One JSON line per case
goes to the original stdout: ``{"start": i}`` before it, then its outcome; ``{"done": true}`` ends a batch.
"""

from __future__ import annotations

import importlib
import json
import os
import resource
import signal
import time
import traceback
from pathlib import Path

from tests.fuzz.harness import longest

LINES, LINE = 200, 1000  # the first and last LINES lines of stdout and stderr are kept, each cut to LINE characters


class RenderStarted(BaseException):
    """A Blender worker, a mesh probe or a bake would start here: validation is over."""


class CaseTimeout(BaseException):
    """The case ran past its time."""


def _raise(exc: type[BaseException]):
    def stop(*args, **kwargs):
        raise exc()

    return stop


# where generate, spec preview, bake and spec check would start Blender (each patched where it exists)
STOPS = (("deformsim.bank.stage", "bake"), ("deformsim.generate.stage", "bake"), ("deformsim.generate.stage", "probe_mesh"),
         ("deformsim.generate.probe", "probe_mesh"), ("deformsim.generate.ray", "run_ray"),
         ("deformsim.generate.spec_preview", "bake"))


def _patch_rendering() -> None:
    """Every way to Blender raises :class:`RenderStarted`, and a Blender worker's start always does; the local
    render pool renders with fake workers while ``FUZZ_FAKE`` is 1 (set per case)."""
    from deformsim.generate import local, stage, worker_client

    stop = _raise(RenderStarted)
    for name, attr in STOPS:
        module = importlib.import_module(name)
        if hasattr(module, attr):
            setattr(module, attr, stop)
    worker_client.WorkerProcess.start = stop
    real_local = stage.run_local

    def run_local(*args, **kwargs):
        if os.environ.get("FUZZ_FAKE") != "1":
            raise RenderStarted()
        from tests.generate.fakes import FakeWorker

        local.WorkerProcess = FakeWorker
        try:
            return real_local(*args, **kwargs)
        finally:
            local.WorkerProcess = worker_client.WorkerProcess

    stage.run_local = run_local


def _where(exc: BaseException) -> str:
    """The innermost frames of a traceback that are deformsim's own, as ``file:line function``."""
    frames = [f for f in traceback.extract_tb(exc.__traceback__) if "deformsim" in f.filename]
    return " <- ".join(f"{Path(f.filename).name}:{f.lineno} {f.name}" for f in frames[::-1][:3])


def _kept(text: str) -> str:
    """``text`` shortened to what an outcome keeps (see :data:`LINES`)."""
    lines = text.splitlines()
    if len(lines) > 2 * LINES:
        lines = [*lines[:LINES], f"[{len(lines) - 2 * LINES} lines left out]", *lines[-LINES:]]
    return "\n".join(line[:LINE] for line in lines)


def run_case(runner, command, case: dict) -> dict:
    """The outcome of one case: exit code, output, the exception that escaped and where, timings."""
    os.environ["FUZZ_FAKE"] = "1" if case.get("render") == "fake" else "0"
    signal.signal(signal.SIGALRM, _raise(CaseTimeout))
    signal.setitimer(signal.ITIMER_REAL, case["timeout"])
    out = {"exit": None, "stdout": "", "stderr": "", "max_line": 0, "exception": None, "where": "", "rendered": False,
           "timeout": False}
    t0 = time.perf_counter()
    try:
        res = runner.invoke(command, case["argv"], env=case["env"], catch_exceptions=True)
        out.update(exit=res.exit_code, stdout=_kept(res.stdout), stderr=_kept(res.stderr),
                   max_line=longest(res.stdout + res.stderr, os.environ.get("FUZZ_TMP")))
        if res.exception is not None and not isinstance(res.exception, SystemExit):
            out["exception"] = f"{type(res.exception).__name__}: {str(res.exception)[:300]}"
            out["where"] = _where(res.exception)
    except RenderStarted:
        out["rendered"] = True
    except CaseTimeout:
        out["timeout"] = True
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
    out["seconds"] = round(time.perf_counter() - t0, 3)
    return out


def main() -> None:
    limit = int(os.environ.get("FUZZ_MEMORY", 3 << 30))
    resource.setrlimit(resource.RLIMIT_DATA, (limit, limit))
    control, report = os.fdopen(os.dup(0), "r"), os.fdopen(os.dup(1), "w", buffering=1)
    import typer
    from click.testing import CliRunner

    from deformsim.cli import app

    _patch_rendering()
    runner, command = CliRunner(), typer.main.get_command(app)  # built once: typer rebuilds it per invoke
    for line in control:
        batch = json.loads(line)
        cases = json.loads(Path(batch["cases"]).read_text())
        for i in range(batch["start"], len(cases)):
            report.write(json.dumps({"start": i}) + "\n")
            report.write(json.dumps({"case": i, **run_case(runner, command, cases[i])}) + "\n")
        report.write(json.dumps({"done": True}) + "\n")


if __name__ == "__main__":
    main()
