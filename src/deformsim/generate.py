"""`deformsim generate`: render a labelled intact/deformed dataset with a pool of Blender workers.

The orchestrator never imports bpy. It validates every input before work starts, draws each sample's
parameters (pure, by index), hands indices to worker processes, writes each finished sample's record
atomically, and consolidates the manifest at the end. Rerunning on the same folder resumes: finished samples
are skipped, so the result is the same as an uninterrupted run's whatever the number of workers.
"""

from __future__ import annotations

import os
import platform
import queue
import threading
import time
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path

import yaml

from deformsim import __version__
from deformsim.atomic import write_json, write_text
from deformsim.config import Config, dump_config
from deformsim.errors import UserError
from deformsim.layout import RENDER_KINDS, Layout
from deformsim.log import get_logger, progress_bar
from deformsim.manifest import consolidate, read_record, rows_for, write_record
from deformsim.sampling import SampleParams, allowed_families, sample_params
from deformsim.spec import Spec, check_mesh_file, load_spec

log = get_logger(__name__)

# Settings that do not change what is rendered: a resumed run may differ in these.
_RUN_ONLY = {"generate": {"n", "workers", "recycle_every", "max_retries", "backend", "address", "gather", "preview"}}
_DATA_SECTIONS = ("object", "camera", "pose", "lighting", "deform", "render", "generate")
_PACKAGES = ("bpy", "numpy", "pydantic", "pandas", "pyarrow", "pillow", "opencv-python-headless", "torch", "torchvision")


@dataclass
class GenerateResult:
    root: Path
    images: int
    rendered: int  # samples rendered by this run (the rest were resumed)
    failed: dict[int, str] = field(default_factory=dict)
    seconds: float = 0.0
    device: str = ""


def data_settings(cfg: Config) -> dict:
    """The part of a config that determines the rendered data."""
    d = cfg.model_dump(mode="json")
    out = {k: d[k] for k in _DATA_SECTIONS}
    for section, keys in _RUN_ONLY.items():
        out[section] = {k: v for k, v in out[section].items() if k not in keys}
    return out


def n_samples(cfg: Config) -> int:
    return cfg.generate.n // len(cfg.camera.azimuth_quadrants)


def default_workers(cfg: Config) -> int:
    if cfg.generate.workers:
        return cfg.generate.workers
    if cfg.render.device == "gpu":
        return 1
    # two processes hide each other's per-render fixed costs (bench/scale.py: 1.23x on 2 cores)
    cores = os.cpu_count() or 1
    return 1 if cores < 2 else max(2, cores // 4)


def prepare(cfg: Config, out: Path) -> tuple[Spec, list[str]]:
    """Every check that can fail on user input, before any work and before touching ``out``."""
    from deformsim.worker_client import list_hdris, probe_mesh

    spec = load_spec(cfg.object.spec)
    if cfg.object.mesh is not None:
        check_mesh_file(cfg.object.mesh)
        if spec.builtin:
            raise UserError(f"spec '{spec.name}' is for the built-in {spec.builtin}, not for mesh {cfg.object.mesh}")
        probe_mesh(cfg.object.mesh, cfg.object.spec)
    elif not spec.builtin:
        raise UserError(f"spec '{spec.name}' describes a mesh part: pass the mesh with --object")
    allowed_families(cfg, spec)
    hdris = list_hdris(cfg.lighting.hdri_dir)
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise UserError(f"output {out} exists and is not a folder")
    layout = Layout(out)
    if layout.config.is_file():
        try:
            old = yaml.safe_load(layout.config.read_text())
            old_settings = data_settings(Config.model_validate(old))
        except Exception:
            raise UserError(f"{out} holds an unreadable {layout.config.name}: use a new output folder") from None
        new = data_settings(cfg)
        if old_settings != new:
            diff = _first_difference(old_settings, new)
            raise UserError(f"{out} was generated with other settings ({diff}): use a new output folder")
    return spec, hdris


def _first_difference(a: dict, b: dict, prefix: str = "") -> str:
    for k in sorted(set(a) | set(b)):
        va, vb = a.get(k), b.get(k)
        if isinstance(va, dict) and isinstance(vb, dict):
            if va != vb:
                return _first_difference(va, vb, f"{prefix}{k}.")
        elif va != vb:
            return f"{prefix}{k}: {va!r} there, {vb!r} now"
    return "?"


def versions() -> dict:
    out = {"deformsim": __version__, "python": platform.python_version()}
    for name in _PACKAGES:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            pass
    return out


def generate(cfg: Config, out: str | Path, progress: bool = True,
             prepared: tuple[Spec, list[str]] | None = None) -> GenerateResult:
    """Render ``cfg.generate.n`` images into ``out`` (resuming what is there) and write the manifest.

    ``prepared`` is what :func:`prepare` returned for the same ``cfg`` and ``out``, when the caller already ran it.
    """
    t0 = time.perf_counter()
    out = Path(out)
    spec, hdris = prepared or prepare(cfg, out)
    layout = Layout(out)
    layout.samples_dir.mkdir(parents=True, exist_ok=True)
    write_text(layout.config, dump_config(cfg))
    write_json(layout.versions, versions())
    _remove_partial_files(layout)

    indices = list(range(n_samples(cfg)))
    todo = [i for i in indices if read_record(layout, i) is None]
    params = {i: sample_params(i, cfg.generate.seed, cfg, spec, hdris) for i in todo}
    views = len(cfg.camera.azimuth_quadrants)
    log.info(
        "generate: %d images (%d samples x %d cameras), %d samples to render, %d already done",
        len(indices) * views, len(indices), views, len(todo), len(indices) - len(todo),
    )
    result = GenerateResult(root=out, images=len(indices) * views, rendered=0)
    if todo:
        if cfg.generate.backend == "ray":
            from deformsim.ray_backend import run_ray

            failed, device = run_ray(cfg, layout, params, progress)
        else:
            failed, device = run_local(cfg, layout, params, progress)
        result.failed, result.device = failed, device
        result.rendered = len(todo) - len(failed)
    done = [i for i in indices if i not in result.failed]
    consolidate(layout, done)
    if cfg.generate.preview:
        from deformsim.preview import contact_sheet

        contact_sheet(layout, cfg.generate.preview, cfg.generate.seed)
    result.images = len(done) * views
    result.seconds = time.perf_counter() - t0
    if result.failed:
        write_json(out / "failures.json", {str(k): v for k, v in result.failed.items()})
    return result


def _remove_partial_files(layout: Layout) -> None:
    """Temporary files of an interrupted run (never valid output) are removed before resuming."""
    for kind in RENDER_KINDS:
        for tmp in (layout.root / "images" / kind).glob(".*"):
            tmp.unlink(missing_ok=True)


def finish_sample(layout: Layout, p: SampleParams, render_seconds: list[float], camera_scale: float) -> None:
    write_record(layout, p, rows_for(p, layout, render_seconds, camera_scale))


def worker_setup(cfg: Config, layout: Layout) -> dict:
    return {
        "config": cfg.model_dump(mode="json"),
        "spec_path": str(cfg.object.spec) if cfg.object.spec else None,
        "out": str(layout.root),
    }


def run_local(cfg: Config, layout: Layout, params: dict[int, SampleParams], progress: bool) -> tuple[dict[int, str], str]:
    """Render ``params`` with local worker processes; returns (failed samples with reasons, device)."""
    from deformsim.worker_client import WorkerCrashed, WorkerProcess

    n_workers = min(default_workers(cfg), len(params))
    threads = cfg.render.threads or max(1, (os.cpu_count() or 1) // n_workers)
    views = len(cfg.camera.azimuth_quadrants)
    tasks: queue.Queue = queue.Queue()
    for i in sorted(params):
        tasks.put(i)
    attempts: dict[int, int] = {}
    failed: dict[int, str] = {}
    stop = threading.Event()
    lock = threading.Lock()
    remaining = [len(params)]
    device = [""]
    errors: list[str] = []
    live: dict[int, object] = {}  # worker slot -> running WorkerProcess, killed on Ctrl-C
    logs = layout.root / "logs"
    logs.mkdir(exist_ok=True)
    bar = progress_bar(total=len(params) * views, desc="render", enabled=progress)

    def retry_or_fail(i: int, reason: str) -> None:
        with lock:
            attempts[i] = attempts.get(i, 0) + 1
            if attempts[i] > cfg.generate.max_retries:
                failed[i] = reason
                remaining[0] -= 1
                log.error("sample %d failed %d times, giving up: %s", i, attempts[i], reason)
            else:
                log.warning("sample %d: %s; retrying (%d/%d)", i, reason, attempts[i], cfg.generate.max_retries)
                tasks.put(i)

    def run_worker(w: int) -> None:
        proc = None
        rendered = 0
        try:
            while not stop.is_set():
                with lock:
                    if remaining[0] <= 0:
                        return
                try:
                    i = tasks.get(timeout=0.2)
                except queue.Empty:
                    continue
                if proc is None or rendered >= cfg.generate.recycle_every:
                    if proc is not None:
                        proc.close()
                    proc = WorkerProcess(log_path=logs / f"worker{w}.log", threads=threads)
                    live[w] = proc
                    ready = proc.start(worker_setup(cfg, layout))
                    device[0] = ready.get("device", "")
                    camera_scale = float(ready.get("camera_scale", 1.0))
                    rendered = 0
                try:
                    reply = proc.render(params[i].to_dict())
                except WorkerCrashed as exc:
                    proc = None
                    if not stop.is_set():  # else we killed it ourselves (Ctrl-C)
                        retry_or_fail(i, f"worker crashed ({exc})")
                    continue
                if "error" in reply:
                    retry_or_fail(i, reply.get("message", "render error"))
                    continue
                finish_sample(layout, params[i], reply["render_seconds"], camera_scale)
                rendered += views
                with lock:
                    remaining[0] -= 1
                bar.update(views)
        except WorkerCrashed as exc:  # crashed while starting: a setup problem, not a sample's
            stop.set()
            errors.append(f"worker failed to start: {exc}")
        except Exception as exc:  # pragma: no cover - surfaced to the caller below
            stop.set()
            errors.append(repr(exc))
        finally:
            if proc is not None:
                proc.kill() if stop.is_set() else proc.close()

    threads_ = [threading.Thread(target=run_worker, args=(w,), daemon=True) for w in range(n_workers)]
    log.info("rendering with %d worker(s), %d Cycles thread(s) each", n_workers, threads)
    try:
        for t in threads_:
            t.start()
        for t in threads_:
            while t.is_alive():
                t.join(timeout=0.5)
    except KeyboardInterrupt:
        stop.set()
        for proc in list(live.values()):
            proc.kill()
        for t in threads_:
            t.join(timeout=10)
        bar.close()
        _remove_partial_files(layout)
        raise
    bar.close()
    if errors:
        raise RuntimeError(errors[0] + f" (see {logs})")
    if device[0]:
        log.info("Cycles device: %s", device[0])
    return failed, device[0]

