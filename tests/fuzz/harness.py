"""The fuzz test's driver: cases run in a child process (:mod:`tests.fuzz.child`), restarted after a case that
hangs or kills it; each outcome is checked against the command line's promises.

A case passes when it exits 0 with valid output (its ``valid`` check), or exits 1 or 2 with one ``error:`` line
on stderr (notes and warnings before it are allowed; a click usage error is too), no traceback and no line
longer than :data:`MAX_LINE`; the paths in ``keep`` are unchanged whatever the exit, those in ``keep_on_fail``
when it fails. A case marked ``absurd`` must be refused, and before any worker starts.
"""

from __future__ import annotations

import hashlib
import json
import os
import select
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
MAX_LINE = 300
NOTES = ("warning:", "hint:", "testing ", "real photos in ")  # lines the CLI prints on stderr before its work
GRACE = 30.0  # seconds past a case's own timeout before its child is killed


def fuzz_cases(default: int) -> int:
    """How many random cases a class runs: ``default``, or ``DEFORMSIM_FUZZ_CASES`` times more for a long run."""
    return default * int(os.environ.get("DEFORMSIM_FUZZ_CASES", "1"))


@dataclass
class Case:
    """One command line; ``cls`` groups it in the report (``"train: dataset manifest"``), ``tag`` names its input
    (``"truncated"``); ``env`` is set while it runs."""

    cls: str
    tag: str
    argv: list
    absurd: bool = False  # the input is invalid: exit 0, or a worker starting, is a fault
    keep: list[Path] = field(default_factory=list)
    keep_on_fail: list[Path] = field(default_factory=list)
    valid: Callable[[dict], str | None] | None = None  # on exit 0, given the outcome: None, or what is wrong
    timeout: float = 20.0
    render: str = "stop"  # or "fake": fake workers render and the command runs to its end
    env: dict = field(default_factory=dict)
    hashes: dict = field(default_factory=dict, repr=False)


def tree_hash(path: Path) -> str:
    """sha256 of every file, link and folder name under ``path`` (or of the file), with contents."""
    h = hashlib.sha256()
    if not path.exists() and not path.is_symlink():
        return "absent"
    items = [path] if not path.is_dir() or path.is_symlink() else [path, *sorted(path.rglob("*"))]
    for p in items:
        h.update(str(p.relative_to(path)).encode())
        if p.is_symlink():
            h.update(b"->" + os.readlink(p).encode())
        elif p.is_file():
            h.update(p.read_bytes())
    return h.hexdigest()


def longest(text: str, tmp: str | None) -> int:
    """The length of the longest line of ``text``, the temporary folder ``tmp`` (where every path of a case
    starts) counted as 5 characters."""
    return max((len(line) for line in (text.replace(tmp, "<tmp>") if tmp else text).splitlines()), default=0)


def child_env(cache: Path) -> dict:
    """The environment of a case: this checkout's code, its own cache, one thread, paths measured from the
    temporary folder above ``cache``."""
    return {**os.environ, "PYTHONPATH": f"{ROOT}{os.pathsep}{ROOT / 'src'}", "DEFORMSIM_CACHE": str(cache),
            "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "COLUMNS": "200", "FUZZ_TMP": str(cache.parents[1])}


class Child:
    """A :mod:`tests.fuzz.child` process kept for many batches of cases (torch is imported once), started again
    after a case that kills it or hangs."""

    def __init__(self, work: Path):
        self.work, self.proc = work, None

    def _start(self) -> None:
        self.log = open(self.work / "child.log", "a")
        self.proc = subprocess.Popen([sys.executable, "-m", "tests.fuzz.child"], cwd=self.work,
                                     env=child_env(self.work / "cache"), stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=self.log, start_new_session=True)
        self.buffer = b""

    def close(self) -> None:
        if self.proc is not None:
            os.killpg(self.proc.pid, signal.SIGKILL)  # with the workers it started
            self.proc.wait()
            self.proc.stdin.close()
            self.proc.stdout.close()
            self.log.close()
            self.proc = None

    def _log_tail(self) -> str:
        self.log.flush()
        lines = (self.work / "child.log").read_text(errors="replace").strip().splitlines()
        return lines[-1][:200] if lines else "nothing on stderr"

    def run(self, cases: list[Case], work: Path) -> list[dict]:
        """Each case's outcome."""
        spec = work / "cases.json"
        spec.write_text(json.dumps([{"argv": [str(a) for a in c.argv], "timeout": c.timeout, "render": c.render,
                                     "env": c.env} for c in cases]))
        outcomes: list[dict | None] = [None] * len(cases)
        start = 0
        while start < len(cases):
            if self.proc is None:
                self._start()
            self.proc.stdin.write(json.dumps({"cases": str(spec), "start": start}).encode() + b"\n")
            self.proc.stdin.flush()
            start = self._read(cases, outcomes, start)
        return outcomes

    def _line(self, deadline: float) -> str | None:
        """The child's next line; "" when it has exited, None when it is silent past ``deadline``."""
        while b"\n" not in self.buffer:
            ready, _, _ = select.select([self.proc.stdout], [], [], max(0.0, deadline - time.monotonic()))
            if not ready:
                return None
            chunk = os.read(self.proc.stdout.fileno(), 1 << 16)
            if not chunk:
                return ""
            self.buffer += chunk
        line, self.buffer = self.buffer.split(b"\n", 1)
        return line.decode()

    def _read(self, cases: list[Case], outcomes: list, current: int) -> int:
        """Read outcomes until the batch is done (returns its length) or the child is lost (returns the next case)."""
        deadline = time.monotonic() + 120 + cases[current].timeout  # a fresh child's imports included
        while True:
            line = self._line(deadline)
            if not line:
                why = f"hung: killed after {cases[current].timeout + GRACE:.0f} s" if line is None else \
                    f"died: exit {self.proc.wait()}, {self._log_tail()}"
                if outcomes[current] is None:
                    outcomes[current] = _lost(why)
                self.close()
                return current + 1
            msg = json.loads(line)
            if "done" in msg:
                return len(cases)
            if "start" in msg:
                current, deadline = msg["start"], time.monotonic() + cases[msg["start"]].timeout + GRACE
            else:
                outcomes[msg.pop("case")] = msg


def _lost(why: str) -> dict:
    return {"exit": None, "stdout": "", "stderr": "", "max_line": 0, "exception": None, "where": "", "rendered": False,
            "timeout": False, "lost": why}


def run_cli(argv: list[str], work: Path, timeout: float = 120) -> dict:
    """``python -m deformsim.cli ARGV`` as a user runs it (exit codes at interpreter exit, real stderr)."""
    env = child_env(work / "cache")
    cmd = [sys.executable, "-c", "import resource,runpy,sys; resource.setrlimit(resource.RLIMIT_DATA, (3 << 30,) * 2);"
           "sys.argv[0] = 'deformsim'; runpy.run_module('deformsim.cli', run_name='__main__')", *argv]
    try:
        proc = subprocess.run(cmd, cwd=work, env=env, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return _lost(f"hung: killed after {timeout:.0f} s")
    return {"exit": proc.returncode, "stdout": proc.stdout, "stderr": proc.stderr, "exception": None, "where": "",
            "max_line": longest(proc.stdout + proc.stderr, env["FUZZ_TMP"]), "rendered": False, "timeout": False}


def problems(case: Case, out: dict) -> list[str]:
    """What is wrong with ``out``, the outcome of ``case`` (empty: it kept every promise)."""
    found = []
    if out.get("lost"):
        return [out["lost"]]
    if out["timeout"]:
        return [f"timeout: still running after {case.timeout:.0f} s"]
    if out["rendered"]:
        if case.absurd:
            found.append("accepted: a worker started on absurd input")
    elif out["exception"]:
        kind, _, message = out["exception"].partition(": ")
        found.append(f"traceback {kind}: {message} at {out['where']}")
    elif out["exit"] not in (0, 1, 2):
        found.append(f"exit code: {out['exit']}")
    else:
        found += _lines(case, out)
    if "Traceback" in out["stdout"] + out["stderr"] and not out["exception"]:
        found.append("traceback: printed")
    if out["max_line"] > MAX_LINE:
        found.append(f"long line: {out['max_line']} characters")
    failed = out["exit"] != 0 and not out["rendered"]
    for path in case.keep + (case.keep_on_fail if failed else []):
        if tree_hash(path) != case.hashes[path]:
            found.append(f"changed: {path.name}")
    return found


def _lines(case: Case, out: dict) -> list[str]:
    lines = [line for line in out["stderr"].splitlines() if line.strip()]
    if out["exit"] == 0:
        if case.absurd:
            return ["accepted: exit 0 on absurd input"]
        bad = case.valid(out) if case.valid is not None else None
        return [f"exit 0, invalid output: {bad}"] if bad else []
    if any(line.startswith("Usage:") for line in lines) and out["exit"] == 2:
        return []  # click's own refusal of a malformed option
    errors = [line for line in lines if line.startswith("error:")]
    others = [line for line in lines if not line.startswith(("error:", *NOTES))]
    if len(errors) != 1 or others:
        return [f"not one line: {len(errors)} error line(s), {len(others)} other(s): {(others or lines or [''])[0][:120]}"]
    if lines[-1] is not errors[0]:
        return ["not one line: the error line is not the last"]
    return []


def prepare(cases: list[Case]) -> None:
    """Hash what each case must leave unchanged."""
    for case in cases:
        case.hashes = {p: tree_hash(p) for p in case.keep + case.keep_on_fail}


def check(cases: list[Case], outcomes: list[dict], seconds: float) -> None:
    """Fail with every failing case, grouped by class and problem, and the count and time of the run."""
    found = [problems(case, out) for case, out in zip(cases, outcomes)]
    report = os.environ.get("DEFORMSIM_FUZZ_REPORT")
    if report:
        with open(report, "a") as f:
            for case, out, bad in zip(cases, outcomes, found):
                record = {"cls": case.cls, "tag": case.tag, "argv": [str(a) for a in case.argv], "problems": bad,
                          **{k: out.get(k) for k in ("exit", "exception", "where", "rendered", "seconds")},
                          "stderr": out["stderr"][-600:]}
                f.write(json.dumps(record) + "\n")
    groups: dict[tuple[str, str], list[tuple[str, str]]] = {}
    for case, bad in zip(cases, found):
        for problem in bad:
            groups.setdefault((case.cls, problem.split(":")[0]), []).append((case.tag, problem))
    lines = [f"{cls} [{kind}] x{len(items)} ({', '.join(sorted({t for t, _ in items}))[:200]}): {items[0][1][:200]}"
             for (cls, kind), items in sorted(groups.items())]
    summary = f"{len(cases)} cases in {seconds:.1f} s"
    assert not groups, f"{summary}; failing:\n" + "\n".join(lines)
    print(summary)


def fuzz(child: Child, cases: list[Case], work: Path) -> None:
    """Run ``cases`` in ``child`` and check them (see the module docstring)."""
    prepare(cases)
    t0 = time.perf_counter()
    outcomes = child.run(cases, work)
    check(cases, outcomes, time.perf_counter() - t0)
