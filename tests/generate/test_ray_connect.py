"""Connecting to a Ray cluster: a refused token or a closed port is one line at once, before Ray's retries."""

from __future__ import annotations

import socket
import time

import pytest

from deformsim.errors import UserError

ray = pytest.importorskip("ray", reason="Ray is not installed (pip install 'deformsim[ray]')")

from deformsim.generate import ray as backend  # noqa: E402


class AuthenticationError(Exception):
    """What Ray's GCS client raises for a missing or wrong token."""


@pytest.fixture
def listening():
    with socket.socket() as server:
        server.bind(("127.0.0.1", 0))
        server.listen()
        yield f"127.0.0.1:{server.getsockname()[1]}"


@pytest.fixture
def no_init(monkeypatch, tmp_path):
    monkeypatch.setenv("HOME", str(tmp_path))
    for name in ("RAY_AUTH_TOKEN", "RAY_AUTH_TOKEN_PATH", "RAY_AUTH_MODE"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setattr(ray, "init", lambda **kw: pytest.fail("ray.init ran: its retries take 20 s"))


def refuse(monkeypatch):
    def client(address):
        raise AuthenticationError("RPC error: InvalidAuthToken: Authentication token is missing or incorrect")

    monkeypatch.setattr(ray._raylet, "GcsClient", client)


def test_a_cluster_that_wants_a_token_is_refused_in_one_line_naming_where_it_goes(listening, no_init, monkeypatch):
    refuse(monkeypatch)
    t0 = time.monotonic()
    with pytest.raises(UserError) as err:
        backend.connect(listening)
    line = str(err.value)
    assert time.monotonic() - t0 < 5
    assert line.startswith(f"Ray cluster at {listening} refused this driver's authentication token: it has none")
    assert "~/.ray/auth_token" in line and "RAY_AUTH_TOKEN_PATH" in line and "RAY_AUTH_MODE=token" not in line


def test_a_wrong_token_is_named_by_where_it_came_from(listening, no_init, monkeypatch, tmp_path):
    refuse(monkeypatch)
    token = tmp_path / "token"
    token.write_text("not the cluster's")
    monkeypatch.setenv("RAY_AUTH_TOKEN_PATH", str(token))
    with pytest.raises(UserError, match=f"token \\(from RAY_AUTH_TOKEN_PATH {token}\\): it is not the cluster's"):
        backend.connect(listening)


def test_a_closed_port_is_refused_at_once(no_init):
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]  # closed again when the test connects
    with pytest.raises(UserError, match=f"could not connect to the Ray cluster at 127.0.0.1:{port}: is Ray running"):
        backend.connect(f"127.0.0.1:{port}")
