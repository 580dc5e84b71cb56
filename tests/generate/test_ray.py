"""`deformsim generate --backend ray --address HOST:PORT` on a cluster with Ray's token authentication on."""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import time
import uuid
from pathlib import Path

import pytest

from deformsim.dataset.manifest import read_manifest
from tests.util import ROOT

pytestmark = pytest.mark.blender


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_for_port(port: int, proc: subprocess.Popen, seconds: float = 120) -> bool:
    end = time.monotonic() + seconds
    while time.monotonic() < end and proc.poll() is None:
        with socket.socket() as s:
            if s.connect_ex(("127.0.0.1", port)) == 0:
                return True
        time.sleep(0.5)
    return False


def test_a_token_cluster_renders_through_its_address_and_a_missing_token_names_authentication(tmp_path):
    pytest.importorskip("ray", reason="Ray is not installed (pip install 'deformsim[ray]')")
    ray_cli = str(Path(sys.executable).parent / "ray")
    home = tmp_path / "home"  # no ~/.ray/auth_token of the user's leaks in
    home.mkdir()
    token = tmp_path / "token"
    token.write_text(uuid.uuid4().hex)
    base = {k: v for k, v in os.environ.items() if not k.startswith("RAY_")}
    base.update(HOME=str(home), PYTHONPATH=str(ROOT / "src"))
    cluster = {**base, "RAY_AUTH_MODE": "token", "RAY_AUTH_TOKEN_PATH": str(token)}
    port = free_port()
    address = f"127.0.0.1:{port}"
    head = subprocess.Popen([ray_cli, "start", "--head", "--block", "--port", str(port), "--node-ip-address",
                             "127.0.0.1", "--num-cpus", "2", "--include-dashboard", "false", "--disable-usage-stats"],
                            env=cluster, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        if not wait_for_port(port, head):  # pragma: no cover - depends on the machine
            pytest.skip("ray start --head did not come up on 127.0.0.1")
        time.sleep(5)  # the raylet registers after the GCS opens its port

        def generate(out: Path, env: dict) -> subprocess.CompletedProcess:
            return subprocess.run(
                [sys.executable, "-m", "deformsim.cli", "generate", "--out", str(out), "--n", "4", "--resolution",
                 "32", "--samples", "1", "--backend", "ray", "--address", address, "--no-progress"],
                cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)

        t0 = time.monotonic()
        refused = generate(tmp_path / "refused", base)
        assert refused.returncode == 2, refused.stderr
        assert "authentication token" in refused.stderr and "Traceback" not in refused.stderr
        assert "check the path" not in refused.stderr
        # one line, before Ray's 20 s of retries (each a log line, then its misleading "run `ray stop`" hint)
        assert "InvalidAuthToken" not in refused.stderr and "ray stop" not in refused.stderr, refused.stderr
        assert refused.stderr.strip().splitlines()[-1].startswith("error: Ray cluster at ") and time.monotonic() - t0 < 15

        done = generate(tmp_path / "out", {**base, "RAY_AUTH_TOKEN_PATH": str(token)})  # RAY_AUTH_MODE unset
        assert done.returncode == 0, done.stderr[-2000:]
        df = read_manifest(tmp_path / "out")
        assert len(df) == 4
        assert all((tmp_path / "out" / p).is_file() for p in df.rgba)
    finally:
        os.killpg(head.pid, signal.SIGTERM)  # --block: the head takes its cluster's processes down with it
        try:
            head.wait(timeout=60)
        except subprocess.TimeoutExpired:  # pragma: no cover
            os.killpg(head.pid, signal.SIGKILL)
        shutil.rmtree(home, ignore_errors=True)
