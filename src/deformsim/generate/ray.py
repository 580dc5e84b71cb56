"""Render on a Ray cluster: the same Blender workers, each driven by a Ray actor on some node.

Actors write into the shared output folder, or, with ``generate.gather``, render into a node-local folder
and return the image bytes, which the driver writes. The driver alone writes sample records, so resume,
retries and the manifest work as with the local backend. Install with ``pip install deformsim[ray]``.
A cluster with token authentication (Ray 2.60's default) needs its token on the driver: ``RAY_AUTH_TOKEN``,
``RAY_AUTH_TOKEN_PATH`` or ``~/.ray/auth_token``; where ``RAY_AUTH_MODE`` is unset, a token found there turns it on.
"""

from __future__ import annotations

import contextlib
import logging
import os
import shutil
import socket
import sys
import tempfile
from pathlib import Path

from deformsim.atomic import write_bytes
from deformsim.config import Config
from deformsim.dataset.layout import RENDER_KINDS, Layout, image_id
from deformsim.dataset.rendered import Rendered
from deformsim.errors import UserError
from deformsim.extras import require
from deformsim.generate.backend import Retries, Todo, finish_sample, worker_setup
from deformsim.log import get_logger, progress_bar
from deformsim.parallel import cores_per_worker, worker_count

log = get_logger(__name__)

PROBE_S = 5  # longest wait for a cluster's port to answer


class RenderActor:
    """Holds one Blender worker process on its node; restarts it every ``recycle_every`` images."""

    def __init__(self, setup: dict, recycle_every: int, threads: int, gather: bool):
        self.setup, self.recycle_every, self.threads, self.gather = setup, recycle_every, threads, gather
        self.local = Path(tempfile.mkdtemp(prefix="deformsim-ray-")) if gather else None
        self.worker, self.rendered, self.ready = None, 0, {}

    def _ensure(self) -> None:
        from deformsim.generate.worker_client import WorkerProcess

        if self.worker is not None and self.rendered < self.recycle_every:
            return
        if self.worker is not None:
            self.worker.close()
        out = str(self.local) if self.gather else self.setup["out"]
        log_path = Path(out) / "logs" / f"ray-worker-{os.getpid()}.log"
        self.worker = WorkerProcess(log_path=log_path, threads=self.threads)
        self.ready = self.worker.start({**self.setup, "out": out})
        self.rendered = 0

    def render(self, params: dict) -> dict:
        from deformsim.generate.worker_client import WorkerCrashed

        try:
            self._ensure()
            reply = self.worker.render(params)
        except WorkerCrashed as exc:
            self.worker = None
            return {"error": params["index"], "message": f"worker crashed ({exc})"}
        self.rendered += len(params["cameras"])
        reply["camera_scale"] = self.ready.get("camera_scale", 1.0)
        reply["device"] = self.ready.get("device", "")
        if self.gather and "done" in reply:
            layout = Layout(self.local)
            files = {}
            kinds = RENDER_KINDS + Rendered.from_dict(reply).kinds
            for c in range(len(params["cameras"])):
                for kind in kinds:
                    path = layout.image(kind, image_id(params["index"], c))
                    files[layout.rel(path)] = path.read_bytes()
                    path.unlink()
            reply["files"] = files
        return reply

    def close(self) -> None:
        if self.worker is not None:
            self.worker.close()
        if self.local is not None:
            shutil.rmtree(self.local, ignore_errors=True)


def _use_token_if_present() -> None:
    """Send the cluster token when one is at hand: Ray turns token mode on by itself only for ``auto``."""
    try:
        from ray._private.authentication.authentication_token_setup import (
            maybe_enable_token_auth_if_token_available,
        )
    except ImportError:  # a Ray without token authentication
        return
    quiet = logging.getLogger("ray._private.authentication")  # its "token authentication is enabled" notice
    level = quiet.level
    quiet.setLevel(logging.ERROR)
    try:
        maybe_enable_token_auth_if_token_available(warn_if_disabled=False)
    finally:
        quiet.setLevel(level)


def _is_auth_failure(exc: BaseException | None) -> bool:
    while exc is not None:
        if type(exc).__name__ == "AuthenticationError" or "InvalidAuthToken" in str(exc):
            return True
        exc = exc.__cause__ or exc.__context__
    return False


def _token_source() -> str | None:
    """Where this driver's cluster token comes from (``RAY_AUTH_TOKEN``, ``RAY_AUTH_TOKEN_PATH`` or
    ``~/.ray/auth_token``); None when it has none."""
    if os.environ.get("RAY_AUTH_TOKEN"):
        return "RAY_AUTH_TOKEN"
    path = os.environ.get("RAY_AUTH_TOKEN_PATH")
    if path and Path(path).expanduser().is_file():
        return f"RAY_AUTH_TOKEN_PATH {path}"
    home = Path("~/.ray/auth_token").expanduser()
    return str(home) if home.is_file() else None


@contextlib.contextmanager
def _stderr_silenced():
    """File descriptor 2 to /dev/null for the block: Ray's C++ client writes its warnings there directly."""
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 2)
            yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


def _probe(address: str) -> None:
    """Refuse at once, in one line, a cluster at ``address`` that is unreachable or turns this driver's token
    down, before ``ray.init`` retries for many seconds and logs each retry."""
    host, _, port = address.rpartition(":")
    if not host or not port.isdigit():
        return  # not HOST:PORT: left to ray.init
    try:
        socket.create_connection((host, int(port)), timeout=PROBE_S).close()
    except OSError:
        raise UserError(f"could not connect to the Ray cluster at {address}: is Ray running there (`ray status`) "
                        "and its port open?") from None
    try:
        from ray._raylet import GcsClient
    except ImportError:  # pragma: no cover - a Ray without it
        return
    try:
        with _stderr_silenced():
            GcsClient(address=address)
    except Exception as exc:  # Ray's own error types; only an authentication refusal is decided here
        if _is_auth_failure(exc):
            raise UserError(_auth_line(address)) from None


def _auth_line(address: str) -> str:
    source = _token_source()
    if source is None:
        return (f"Ray cluster at {address} refused this driver's authentication token: it has none; copy the head "
                "node's ~/.ray/auth_token to the same place here, or set RAY_AUTH_TOKEN or RAY_AUTH_TOKEN_PATH "
                "(docs/scaling.md; RAY_AUTH_MODE is not needed on the driver)")
    return (f"Ray cluster at {address} refused this driver's authentication token (from {source}): it is not the "
            "cluster's; copy the head node's ~/.ray/auth_token here, or point RAY_AUTH_TOKEN_PATH at it (docs/scaling.md)")


def connect(address: str | None) -> None:
    """``ray.init`` at ``address`` with the cluster's token; a refusal for want of it names authentication."""
    import ray

    _use_token_if_present()
    if address not in (None, "auto"):
        _probe(address)
    try:
        ray.init(address=address, include_dashboard=False, log_to_driver=False)
    except Exception as exc:
        if _is_auth_failure(exc):
            raise UserError(_auth_line(str(address))) from None
        if isinstance(exc, ConnectionError):
            raise UserError(f"could not connect to the Ray cluster at {address}: is Ray running there "
                            "(`ray status`) and its port open?") from None
        raise


def run_ray(cfg: Config, layout: Layout, todo: Todo, progress: bool) -> tuple[dict[int, str], str]:
    """Render the samples of ``todo`` on Ray actors; returns (failed samples with reasons, device)."""
    require("ray", what="generate.backend ray")
    import ray
    from ray.exceptions import RayActorError

    started_here = not ray.is_initialized()
    if started_here:
        connect(cfg.generate.address)
    try:
        cpus = int(ray.cluster_resources().get("CPU", 1))
        n_actors = worker_count(len(todo), cfg.generate.workers, cores=cpus, cores_each=2)
        cpus_per = 1 if cfg.generate.workers else cores_per_worker(n_actors, cpus)
        actor_cls = ray.remote(num_cpus=cpus_per, max_restarts=0)(RenderActor)
        setup = worker_setup(cfg, layout)
        threads = cfg.render.threads or cpus_per

        def new_actor():
            return actor_cls.remote(setup, cfg.generate.recycle_every, threads, cfg.generate.gather)

        views = len(cfg.camera.azimuth_quadrants)
        retries = Retries(cfg.generate.max_retries)
        device = ""
        running: dict = {}  # future -> (actor, sample parameters)
        idle = [new_actor() for _ in range(n_actors)]
        log.info("rendering on Ray: %d actor(s), %d CPU(s) each", n_actors, cpus_per)
        with progress_bar(len(todo) * views, "render (ray)", progress) as bar:
            while True:
                while idle and (i := todo.take()) is not None:
                    actor, params = idle.pop(), todo.draw(i)
                    running[actor.render.remote(params.to_dict())] = (actor, params)
                if not running:
                    break
                ready, _ = ray.wait(list(running), num_returns=1)
                actor, params = running.pop(ready[0])
                i = params.index
                try:
                    reply = ray.get(ready[0])
                except RayActorError as exc:
                    reply = {"error": i, "message": f"actor died: {exc}"}
                    actor = new_actor()
                idle.append(actor)
                if "error" in reply:
                    if retries.retry(i, reply["message"]):
                        todo.again(i)
                    continue
                for rel, data in reply.get("files", {}).items():
                    write_bytes(layout.root / rel, data)
                finish_sample(layout, params, Rendered.from_dict(reply), reply["camera_scale"])
                device = reply.get("device", device)
                bar.update(views)
        ray.get([a.close.remote() for a in idle])
        return retries.failed, device
    finally:
        if started_here:
            ray.shutdown()
