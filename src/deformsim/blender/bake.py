"""Bake process: ``python -m deformsim.blender.bake``, driven by :func:`deformsim.bank.stage.bake`.

Reads one JSON request on stdin, ``{"spec_path": str|null, "mesh": str|null, "out": str}``, builds the part
as the render worker does, simulates every variant of every scenario of the spec into ``out/NNNN.npy``
(render-mesh vertex positions) and writes one JSON line per entry on stdout:
``{"entry": "SCENARIO/I", "file": str, "stats": {...}, "variant": {...}}``. A failed simulation ends it with
``{"error": "one line"}`` and exit code 2.
"""

from __future__ import annotations

import json
import os
import sys

import numpy as np


def main() -> int:
    req = json.loads(sys.stdin.readline())
    proto = os.fdopen(os.dup(1), "w", buffering=1)
    os.dup2(2, 1)  # Blender's own prints go to stderr

    from deformsim.blender import cycles
    from deformsim.blender.motion.simulate import SimulationError, simulate
    from deformsim.spec.model import load_spec
    from deformsim.spec.simulation import variants

    spec = load_spec(req.get("spec_path"))
    cycles.reset()
    if req.get("mesh"):
        from deformsim.blender.part.mesh_import import import_mesh

        part = import_mesh(req["mesh"], spec)
    else:
        from deformsim.blender.part.can import build_can

        part = build_can()
    out = req["out"]
    k = 0
    for scenario in spec.simulation.scenarios:
        for v in variants(scenario):
            try:
                positions, stats = simulate(part, spec.simulation, scenario, v)
            except SimulationError as exc:
                proto.write(json.dumps({"error": str(exc)}) + "\n")
                return 2
            path = os.path.join(out, f"{k:04d}.npy")
            np.save(path, positions)
            proto.write(json.dumps({"entry": f"{scenario.name}/{v.index}", "file": path, "stats": stats,
                                    "variant": v.to_dict(), "vertices": len(positions)}) + "\n")
            k += 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
