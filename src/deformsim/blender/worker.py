"""Render worker: ``python -m deformsim.blender.worker``, driven by :class:`deformsim.generate.worker_client.WorkerProcess`.

JSON lines on stdin, one reply line each on the real stdout (Blender's own prints go to stderr):

- ``{"setup": {"config": {...}, "spec_path": str|null, "out": str, "threads": int, "bank": str|null}}`` builds the
  scene once (``bank``: a baked bank folder, its entries become shape keys) and sets up the render features the
  config turns on (:mod:`deformsim.blender.features`)
  -> ``{"ready": true, "device": str, "camera_scale": float, "object_size": [dx, dy, dz], "pid": int}``
- ``{"render": SampleParams.to_dict()}`` -> :meth:`deformsim.dataset.rendered.Rendered.to_dict` (``done``: the
  index, render seconds, the features' image kinds and manifest columns) or
  ``{"error": index, "message": str, "traceback": str}`` (the worker lives on)
- ``{"configure": RenderConfig dict}`` -> ``{"configured": device}``: new Cycles settings, same scene and features
- ``{"quit": true}`` -> exit 0 (so does the end of stdin)
"""

from __future__ import annotations

import json
import os
import sys
import time
import traceback


def _protocol_stream():
    """Keep the real stdout for replies and point fd 1 (Blender's prints) at stderr."""
    proto = os.fdopen(os.dup(1), "w", buffering=1)
    os.dup2(2, 1)
    return proto


def _log(msg: str) -> None:
    print(f"[worker {os.getpid()} {time.strftime('%H:%M:%S')}] {msg}", file=sys.stderr, flush=True)


def setup(msg: dict):
    """Build the scene once: object, materials, rig, world, cameras, Cycles, then the render features.
    Returns (ctx, layout, reply)."""
    import bpy
    import numpy as np

    from deformsim.blender import cycles
    from deformsim.blender.feature import RenderContext
    from deformsim.blender.features import set_up
    from deformsim.blender.motion.pose import make_pivot
    from deformsim.blender.motion.rig import build_rig, mesh_bounds
    from deformsim.blender.part import materials
    from deformsim.blender.scene.cameras import make_cameras
    from deformsim.blender.scene.world import World
    from deformsim.config import REFERENCE_SIZE, validate_config
    from deformsim.dataset.layout import Layout
    from deformsim.spec.model import load_spec

    cfg = validate_config(msg["config"], "worker config")
    spec = load_spec(msg.get("spec_path"))
    cycles.reset()
    scene = bpy.context.scene
    if cfg.object.mesh is None:
        from deformsim.blender.part import can

        obj = can.build_can()  # with its materials: label on the side wall, aluminium lid and bottom
    else:
        from deformsim.blender.part.mesh_import import import_mesh

        obj = import_mesh(cfg.object.mesh, spec)
        materials.assign_regions(obj, spec)
    materials.enable_appearance(obj, cfg.render.appearance is not None)  # before the crease layer, which follows it
    materials.enable_creases(obj, cfg.render.creases)
    lo, hi = mesh_bounds(obj)
    size = hi - lo
    camera_scale = 1.0 if cfg.object.mesh is None else float(size.max() / REFERENCE_SIZE)
    rig = build_rig(obj, spec)
    if msg.get("bank"):
        from deformsim.bank.store import load_bank

        bank = load_bank(msg["bank"])
        rig.load_bank(bank.names, bank.positions)
    pivot = make_pivot(scene, (lo + hi) / 2, [obj, rig.lattice])
    ctx = RenderContext(
        cfg=cfg,
        spec=spec,
        scene=scene,
        obj=obj,
        rig=rig,
        world=World(scene, cfg.lighting.hdri_dir),
        cameras=make_cameras(scene, len(cfg.camera.azimuth_quadrants), cfg.camera.lens_fixed, camera_scale),
        target=tuple(float(v) for v in (lo + hi) / 2),
        camera_scale=camera_scale,
        pivot=pivot,
        ground=float(lo[2]),
    )
    if cfg.object.shapes is not None:  # after the bank: its entries are shape keys too
        from deformsim.blender.part.shapes import Shaper

        ctx.shaper = Shaper(obj, rig.lattice, pivot, spec.lattice.margin, cfg.object.mesh is None)
    device = cycles.configure_cycles(scene, cfg.render, int(msg.get("threads") or cfg.render.threads))
    ctx.features = set_up(ctx)
    reply = {
        "ready": True,
        "device": device,
        "camera_scale": camera_scale,
        "object_size": [float(v) for v in np.round(size, 6)],
        "pid": os.getpid(),
    }
    return ctx, Layout(msg["out"]), reply


def render(ctx, layout, params: dict) -> dict:
    import bpy

    from deformsim.blender.passes.render import render_sample
    from deformsim.sampling import SampleParams

    rendered = render_sample(ctx, SampleParams.from_dict(params), layout)
    bpy.data.orphans_purge(do_local_ids=True, do_linked_ids=True, do_recursive=True)
    return rendered.to_dict()


def configure(ctx, render: dict) -> dict:
    from deformsim.blender.cycles import configure_cycles

    ctx.cfg.render = render  # validated by the config model
    r = ctx.scene.render
    return {"configured": configure_cycles(ctx.scene, ctx.cfg.render, r.threads if r.threads_mode == "FIXED" else 0)}


def main() -> int:
    proto = _protocol_stream()

    def reply(obj: dict) -> None:
        proto.write(json.dumps(obj) + "\n")
        proto.flush()

    ctx = layout = None
    for line in sys.stdin:
        if not line.strip():
            continue
        msg = json.loads(line)
        if msg.get("quit"):
            break
        if "setup" in msg:
            try:
                ctx, layout, ready = setup(msg["setup"])
            except Exception as exc:
                _log(traceback.format_exc())
                reply({"error": None, "message": f"setup failed: {exc}", "traceback": traceback.format_exc()})
                return 1
            _log(f"ready on {ready['device']}")
            reply(ready)
        elif "configure" in msg and ctx is not None:
            reply(configure(ctx, msg["configure"]))
        elif "render" in msg:
            index = msg["render"].get("index")
            try:
                if ctx is None:
                    raise RuntimeError("render before setup")
                t0 = time.perf_counter()
                out = render(ctx, layout, msg["render"])
                _log(f"sample {index}: {time.perf_counter() - t0:.2f} s")
                reply(out)
            except Exception as exc:
                _log(f"sample {index} failed:\n{traceback.format_exc()}")
                reply({"error": index, "message": f"{type(exc).__name__}: {exc}", "traceback": traceback.format_exc()})
        else:
            reply({"error": None, "message": f"unknown request {sorted(msg)}"})
    return 0


if __name__ == "__main__":
    sys.exit(main())
