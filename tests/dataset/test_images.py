"""The one image loader: every PIL mode reads as the same 8-bit sRGB RGB, in every stage."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from PIL import Image

from deformsim.composite.backgrounds import load_photo
from deformsim.dataset.images import open_rgb
from deformsim.errors import UserError

GREY = 128


def _palette(path, transparent: bool) -> None:
    im = Image.new("P", (6, 4), 1)
    im.putpalette([0, 0, 0] + [GREY] * 3 + [0, 0, 0] * 254)
    im.save(path, **({"transparency": 0} if transparent else {}))


# name -> (file name, writer): each file shows a flat grey 128 (or says what it shows instead)
FILES = {
    "L": ("l.png", lambda p: Image.new("L", (6, 4), GREY).save(p)),
    "1": ("one.png", lambda p: Image.new("1", (6, 4), 1).save(p)),  # white
    "I;16 png": ("g16.png", lambda p: Image.fromarray(np.full((4, 6), GREY * 257, np.uint16)).save(p)),
    "I;16 tiff": ("g16.tif", lambda p: Image.fromarray(np.full((4, 6), GREY * 257, np.uint16)).save(p)),
    "I (32-bit)": ("i32.tif", lambda p: Image.fromarray(np.full((4, 6), GREY * 257, np.int32)).save(p)),
    "F 0-1": ("f01.tif", lambda p: Image.fromarray(np.full((4, 6), GREY / 255, np.float32)).save(p)),
    "F 0-255": ("f255.tif", lambda p: Image.fromarray(np.full((4, 6), float(GREY), np.float32)).save(p)),
    "RGB 16-bit": ("rgb16.png", lambda p: cv2.imwrite(str(p), np.full((4, 6, 3), GREY * 257, np.uint16))),
    "P": ("p.png", lambda p: _palette(p, False)),
    "CMYK jpeg": ("cmyk.jpg", lambda p: Image.new("CMYK", (6, 4), (0, 0, 0, 255 - GREY)).save(p, quality=100)),
    "CMYK tiff": ("cmyk.tif", lambda p: Image.new("CMYK", (6, 4), (0, 0, 0, 255 - GREY)).save(p)),
    "YCbCr": ("ycc.jpg", lambda p: Image.new("YCbCr", (6, 4), (GREY, 128, 128)).save(p, quality=100)),
    "LAB": ("lab.tif", lambda p: Image.new("LAB", (6, 4), (137, 128, 128)).save(p)),  # L* 53.7 = sRGB 128
    "LA opaque": ("la.png", lambda p: Image.new("LA", (6, 4), (GREY, 255)).save(p)),
    "RGBA opaque": ("rgba.png", lambda p: Image.new("RGBA", (6, 4), (GREY, GREY, GREY, 255)).save(p)),
    "RGBA 16-bit": ("rgba16.png", lambda p: cv2.imwrite(str(p), np.full((4, 6, 4), [GREY * 257] * 3 + [65535], np.uint16))),
    "webp": ("w.webp", lambda p: Image.new("RGB", (6, 4), (GREY,) * 3).save(p, lossless=True)),
}
EXPECTED = {"1": 255}


@pytest.mark.parametrize("name", sorted(FILES))
def test_every_mode_reads_as_8bit_rgb(tmp_path, name):
    file, write = FILES[name]
    write(tmp_path / file)
    rgb = np.asarray(open_rgb(tmp_path / file))
    assert rgb.dtype == np.uint8 and rgb.shape == (4, 6, 3)
    want = EXPECTED.get(name, GREY)
    assert np.abs(rgb.astype(int) - want).max() <= 1, (name, Image.open(tmp_path / file).mode, rgb[0, 0])


def _transparent_palette(path) -> None:
    im = Image.new("P", (6, 4), 0)  # every pixel is the transparent index 0, whose colour is grey
    im.putpalette([GREY] * 3 + [255, 255, 255] * 255)
    im.save(path, transparency=0)


@pytest.mark.parametrize("writer", [
    lambda p: Image.new("LA", (6, 4), (200, 0)).save(p),
    lambda p: Image.new("RGBA", (6, 4), (200, 100, 50, 0)).save(p),
    _transparent_palette,
], ids=["LA", "RGBA", "P"])
def test_transparency_is_composited_over_black(tmp_path, writer):
    writer(tmp_path / "t.png")
    assert np.asarray(open_rgb(tmp_path / "t.png")).max() == 0


def test_half_alpha_is_premultiplied_like_the_black_variant(tmp_path):
    Image.new("RGBA", (2, 2), (200, 100, 51, 128)).save(tmp_path / "a.png")
    assert np.asarray(open_rgb(tmp_path / "a.png"))[0, 0].tolist() == [100, 50, 26]  # rgb*a/255, rounded


def test_exif_orientation_is_applied(tmp_path):
    im = Image.new("RGB", (6, 4), (0, 0, 0))
    im.putpixel((0, 0), (255, 255, 255))
    exif = Image.Exif()
    exif[0x0112] = 6  # rotate 90 degrees clockwise to view
    im.save(tmp_path / "o.jpg", exif=exif, quality=100)
    rgb = np.asarray(open_rgb(tmp_path / "o.jpg"))
    assert rgb.shape == (6, 4, 3) and rgb[0, -1].min() > 200  # the top-left corner is now top-right


def test_stages_share_the_loader(tmp_path):
    """Training/prediction (load_image) and background photos (load_photo) read a 16-bit PNG as grey, not white."""
    torch = pytest.importorskip("torch")
    from deformsim.learn.data import load_image

    path = tmp_path / "g16.png"
    Image.fromarray(np.full((8, 8), GREY * 257, np.uint16)).save(path)
    x = load_image(path, 8)
    assert torch.allclose(x, torch.full_like(x, GREY / 255))
    assert np.asarray(load_photo(str(path), 8, 8)).max() == GREY


def test_unreadable_files_are_named(tmp_path):
    (tmp_path / "bad.png").write_bytes(b"not an image")
    with pytest.raises(UserError, match="bad.png"):
        open_rgb(tmp_path / "bad.png")
    with pytest.raises(UserError, match="missing.png"):
        open_rgb(tmp_path / "missing.png")
