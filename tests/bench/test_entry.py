"""Benchmark scripts meet bad input as the CLI does: one ``error:`` line, no traceback."""

import subprocess
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[2] / "bench"


@pytest.mark.parametrize("script, flag", [("beside_real.py", "--real"), ("composite.py", "--backgrounds")])
def test_a_missing_folder_ends_in_one_line_naming_it(script, flag, tmp_path):
    missing = tmp_path / "no-such-folder"
    args = [tmp_path, "--variant", "backgrounds"] if script == "beside_real.py" else [tmp_path]
    done = subprocess.run([sys.executable, BENCH / script, *map(str, args), flag, str(missing)], capture_output=True,
                          text=True, cwd=BENCH.parent)
    assert done.returncode != 0
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and str(missing) in lines[0], done.stderr


def test_every_script_imports():
    """A module the scripts import that moves or is renamed breaks them here, not on a user's machine."""
    code = ("import runpy, sys; sys.path.insert(0, 'bench')\n"
            "for s in sys.argv[1:]: runpy.run_path(s, run_name='imported')")
    scripts = sorted(str(p.relative_to(BENCH.parent)) for p in BENCH.glob("*.py"))
    done = subprocess.run([sys.executable, "-c", code, *scripts], capture_output=True, text=True, cwd=BENCH.parent)
    assert done.returncode == 0, done.stderr
