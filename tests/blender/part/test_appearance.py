"""render.appearance and object.shapes in a whole run, and a user mesh's texture photos (Blender renders, 32 px)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from PIL import Image

from tests.blender.conftest import TINY_RENDER, run_blender
from tests.util import CARTON_SPEC

pytestmark = pytest.mark.blender


@pytest.fixture(scope="module")
def photos(tmp_path_factory):
    folder = tmp_path_factory.mktemp("art")
    rng = np.random.default_rng(0)
    for i in range(2):
        Image.fromarray(rng.integers(0, 255, (48, 64, 3), dtype=np.uint8)).save(folder / f"p{i}.png")
    return folder


def test_a_run_records_the_drawn_shapes_and_appearance(tmp_path, photos):
    from deformsim.config import load_config
    from deformsim.generate.stage import generate
    from deformsim.hdri import list_hdris
    from deformsim.sampling import sample_params
    from deformsim.spec.model import load_spec

    cfg = load_config("quick", {"generate.n": 8, "render.resolution": 32, "render.samples": 2, "generate.preview": 0,
                                "render.creases": True, "object.shapes": {"sizes": ["slim250", "tall568"]},
                                "render.appearance": {"photos": str(photos), "photo_share": 0.5}})
    generate(cfg, tmp_path / "data", progress=False)
    df = pd.read_parquet(tmp_path / "data" / "manifest.parquet")
    assert len(df) == 8
    for sample, rows in df.groupby("sample"):
        p = sample_params(int(sample), cfg.generate.seed, cfg, load_spec(None), list_hdris(None))
        assert set(rows["shape_size"]) == {p.shape.size} and set(rows["appearance_style"]) == {p.appearance.style}
        assert rows["shape_height_mm"].iloc[0] == pytest.approx(p.shape.height)
        assert rows["appearance_photo"].iloc[0] == p.appearance.photo
    for path in df["rgba"]:
        assert np.asarray(Image.open(tmp_path / "data" / path))[..., 3].max() == 255


MESH = """
import dataclasses, json, tempfile
from pathlib import Path
import numpy as np
from deformsim.blender import worker
from deformsim.blender.cycles import render_to_array
from deformsim.blender.passes.render import apply_state
from deformsim.blender.scene import cameras as cams
from deformsim.config import load_config
from deformsim.hdri import list_hdris
from deformsim.sampling import sample_params

cfg = load_config("quick", {**%(tiny)r, "render.resolution": 32, "object.mesh": %(mesh)r, "object.spec": %(spec)r,
                            "render.appearance": {"photos": %(photos)r, "photo_share": 1.0}})
tmp = Path(tempfile.mkdtemp())
ctx, _, _ = worker.setup({"config": cfg.model_dump(mode="json"), "spec_path": %(spec)r, "out": str(tmp)})
p = sample_params(1, 2, cfg, ctx.spec, list_hdris(None))
out = {"style": p.appearance.style}

def render(look, name):
    target = apply_state(ctx, dataclasses.replace(p, appearance=look))
    cams.place(ctx.cameras[0], p.cameras[0], target, ctx.camera_scale, ctx.obj)
    ctx.scene.camera = ctx.cameras[0]
    return render_to_array(ctx.scene, tmp / f"{name}.png")[0].astype(float)

plain = render(dataclasses.replace(p.appearance, photo="", style="plain"), "plain")
photo = render(p.appearance, "photo")
plain2 = render(dataclasses.replace(p.appearance, photo="", style="plain"), "plain2")
cover = (plain[..., 3] == 255) & (photo[..., 3] == 255)
out["diff"] = float(np.abs(plain[cover][:, :3] - photo[cover][:, :3]).mean())
out["back"] = float(np.abs(plain[cover][:, :3] - plain2[cover][:, :3]).mean())
out["covered"] = int(cover.sum())
print(json.dumps(out))
"""


def test_a_mesh_wears_a_texture_photo_per_sample(carton, photos):
    out = run_blender(MESH % {"tiny": TINY_RENDER, "mesh": str(carton), "spec": str(CARTON_SPEC),
                              "photos": str(photos)})
    assert out["style"] == "photo" and out["covered"] > 50
    assert out["diff"] > 5 * max(out["back"], 0.5), "the photo changes the part; without it, it is as before"
