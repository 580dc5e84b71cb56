"""A stand-in for ``python -m deformsim.blender.worker``: the same JSON-lines protocol, no Blender.

``FAKE_WORKER_MODE`` picks what a render does: ``ok`` writes flat PNGs (their colour from the sample index and
the mesh file's first byte), ``slow`` leaves a partial render file and sleeps, ``full`` fails as Blender does on
a full disk (the reason in the log, an unreadable image in the reply), ``flaky`` fails sample 1 once and sample 2
every time, ``nostart`` exits before it is ready.
"""

import json
import os
import sys
import time
from pathlib import Path

from PIL import Image

from deformsim.dataset.rendered import Rendered


def main() -> int:
    proto = os.fdopen(os.dup(1), "w", buffering=1)
    os.dup2(2, 1)
    mode = os.environ.get("FAKE_WORKER_MODE", "ok")
    setup = None
    for line in sys.stdin:
        msg = json.loads(line)
        if msg.get("quit"):
            return 0
        if "setup" in msg:
            if mode == "nostart":
                print("Error: no GPU here", file=sys.stderr, flush=True)
                return 1
            setup = msg["setup"]
            proto.write(json.dumps({"ready": True, "device": "fake", "camera_scale": 1.0, "pid": os.getpid()}) + "\n")
            continue
        p = msg["render"]
        out = Path(setup["out"])
        mesh = setup["config"]["object"]["mesh"]
        shade = Path(mesh).read_bytes()[0] if mesh else 0
        if mode == "slow":
            tmp = out / "images" / "rgba" / f".{p['index']:06d}_c0.render.partial.png"
            tmp.parent.mkdir(parents=True, exist_ok=True)
            tmp.write_bytes(b"partial")
            time.sleep(120)
        first_try = out / f".tried-{p['index']}"  # beside the dataset's files, counted across workers
        if mode == "flaky" and (p["index"] == 2 or (p["index"] == 1 and not first_try.exists())):
            first_try.touch()
            proto.write(json.dumps({"error": p["index"], "message": f"flaky sample {p['index']}"}) + "\n")
            continue
        if mode == "full":
            print("Error: writing render result: No space left on device", file=sys.stderr, flush=True)
            proto.write(json.dumps({"error": p["index"], "message": "UnidentifiedImageError: cannot identify image "
                                    "file '/x/.000000_c0.render.png'"}) + "\n")
            continue
        for c in range(len(p["cameras"])):
            for kind in ("rgba", "black", "green"):
                path = out / "images" / kind / f"{p['index']:06d}_c{c}.png"
                path.parent.mkdir(parents=True, exist_ok=True)
                colour = (p["index"] % 256, shade, c * 40)
                Image.new("RGBA" if kind == "rgba" else "RGB", (16, 16), colour + ((255,) if kind == "rgba" else ())
                          ).save(path)
        proto.write(json.dumps(Rendered(p["index"], [0.01] * len(p["cameras"])).to_dict()) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
