"""The draws of the optional parts of a sample, each from a stream of its own (:mod:`deformsim.sampling.streams`, or
a render feature's: :mod:`deformsim.sampling.features`), so a config without the option draws exactly what it drew
without it, and turning one on moves no other draw."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from deformsim.config import Config
from deformsim.sampling.params import (
    AppearanceParams,
    CameraParams,
    LightParams,
    MaterialParams,
    PrintParams,
    ShapeParams,
    SurfaceParams,
)
from deformsim.sampling.photos import artwork_photos
from deformsim.sampling.streams import stream
from deformsim.sampling.tables import CAN_SIZES, CUT_SIDES, LIGHT_KINDS, SURFACE_COLOURS
from deformsim.spec.model import Finish, Material, Print, Spec


def draw_source(index: int, seed: int, cfg: Config, spec: Spec) -> tuple[str, str, float]:
    """(source, bank entry, amount) of a deformed sample: "lattice", "bank" or "both" by ``deform.sources``;
    a run that never uses the bank draws nothing here."""
    w = cfg.deform.sources
    if not w.uses_bank:
        return "lattice", "", 0.0
    rng = stream("source", seed, index)
    weights = np.array([w.lattice, w.bank, w.both])
    source = ("lattice", "bank", "both")[int(rng.choice(3, p=weights / weights.sum()))]
    scenario = spec.simulation.scenarios[int(rng.integers(len(spec.simulation.scenarios)))]
    entry = f"{scenario.name}/{int(rng.integers(scenario.variants))}"
    amount = float(rng.uniform(*cfg.deform.bank_amount))
    return (source, entry, amount) if source != "lattice" else (source, "", 0.0)


def draw_finish(rng: np.random.Generator, finish: Finish) -> MaterialParams:
    """A colour (by the finish's ``color_draw``) and a roughness from ``rng``: a spec material's or region's."""
    lo, hi = finish.color
    if finish.color_draw == "blend":  # three draws all the same, so later draws stay where they are
        t = float(rng.uniform(size=3)[0])
        color = tuple(float(a + t * (b - a)) for a, b in zip(lo, hi))
    else:
        color = _channels(rng, lo, hi)
    return MaterialParams(color=color, roughness=float(rng.uniform(*finish.roughness)))


def _channels(rng: np.random.Generator, lo, hi) -> tuple[float, ...]:
    """A colour with each channel drawn in its own range, from ``lo`` to ``hi``."""
    return tuple(float(rng.uniform(a, b)) for a, b in zip(lo, hi))


def draw_prints(index: int, seed: int, material: Material, params: MaterialParams) -> MaterialParams:
    """``params`` with the printed marks of the spec material and each region that has ``print`` (in that order, from
    stream "print"); a spec without ``print`` draws nothing here."""
    finishes = [material, *material.regions]
    if all(f.print is None for f in finishes):
        return params
    rng = stream("print", seed, index)
    marks = [_draw_print(rng, f.print) if f.print is not None else None for f in finishes]
    regions = tuple(replace(r, print=m) for r, m in zip(params.regions, marks[1:]))
    return replace(params, print=marks[0], regions=regions)


def _draw_print(rng: np.random.Generator, spec: Print) -> PrintParams | None:
    """Printed or not (by ``share``), then an ink range, its colour, a style and a layout seed: all drawn either way."""
    printed = rng.uniform() < spec.share
    ink = _channels(rng, *spec.inks[int(rng.integers(len(spec.inks)))])
    style = spec.styles[int(rng.integers(len(spec.styles)))]
    layout = int(rng.integers(2**31))
    return PrintParams(ink=ink, style=style, seed=layout) if printed else None


def draw_drop(rng: np.random.Generator, upright: float) -> tuple[float, float, float, float]:
    """``pose.mode`` drop: the start orientation (unit quaternion w, x, y, z). With probability ``upright`` the part
    starts standing on one of its ends (either, tilted up to 15 degrees, any turn about the vertical), else in a
    uniformly random orientation."""
    q = rng.normal(size=4)
    stand, flip = rng.uniform() < upright, rng.uniform() < 0.5
    yaw, tilt, axis = rng.uniform(0, 2 * np.pi), np.radians(rng.uniform(0, 15)), rng.uniform(0, 2 * np.pi)
    if stand:
        tilt = tilt + np.pi if flip else tilt
        a, t = yaw / 2, tilt / 2
        qz = np.array([np.cos(a), 0.0, 0.0, np.sin(a)])  # turn about the vertical, then tilt
        qt = np.array([np.cos(t), np.sin(t) * np.cos(axis), np.sin(t) * np.sin(axis), 0.0])
        w1, x1, y1, z1 = qt
        w2, x2, y2, z2 = qz
        q = np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                      w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])
    q = q / np.linalg.norm(q) * (1.0 if q[0] >= 0 else -1.0)
    return tuple(float(v) for v in q)


def draw_lights(rng: np.random.Generator, cfg: Config, cameras: tuple[CameraParams, ...]) -> tuple[LightParams, ...]:
    """``lighting.area_lights``: the sample's area lights. A ring light goes on the axis of one of ``cameras``."""
    a = cfg.lighting.area_lights
    lights = []
    for _ in range(int(rng.integers(a.count[0], a.count[1] + 1))):
        kind = a.kinds[int(rng.integers(len(a.kinds)))]
        g = LIGHT_KINDS[kind]
        size = float(rng.uniform(*g["size"]))
        size_y = size * float(rng.uniform(*g["aspect"]))
        spin = float(rng.uniform(0, 180)) if kind != "ring" else 0.0
        dist = float(rng.uniform(*g["distance"]))
        elevation = float(rng.uniform(*g["elevation"]))
        azimuth = float(rng.uniform(0, 360))
        if kind == "ring":  # behind camera k on its axis: distance and elevation relative to the camera's
            cam = cameras[int(rng.integers(len(cameras)))]
            azimuth = cam.azimuth + float(rng.uniform(-4.0, 4.0))
            elevation += 90.0 - cam.polar
            dist *= cam.radius
        power = float(rng.uniform(*a.power)) * dist**2  # watts at 1 m -> watts at this distance
        lights.append(LightParams(kind=kind, azimuth=azimuth % 360.0, elevation=elevation, distance=dist, size=size,
                                  size_y=size_y, spin=spin, power=power,
                                  temperature=float(rng.uniform(*a.temperature))))
    return tuple(lights)


def draw_surface(rng: np.random.Generator, cfg: Config, photos: list[str] | None) -> SurfaceParams:
    """``render.surface``: the sample's ground. ``photos``: :func:`surface_photos` of the config's folder (None
    without kind photo)."""
    s = cfg.render.surface
    kind = s.kinds[int(rng.integers(len(s.kinds)))]
    c = SURFACE_COLOURS[kind] if s.value is None else {**SURFACE_COLOURS[kind], "value": s.value}
    hue, sat, val, rough = (float(rng.uniform(*c[k])) for k in ("hue", "saturation", "value", "roughness"))
    scale = float(np.exp(rng.uniform(np.log(s.scale[0]), np.log(s.scale[1]))))
    rotation, offset = float(rng.uniform(0, 360)), (float(rng.uniform()), float(rng.uniform()))
    photo = ""
    if kind == "photo":
        photo = photos[int(rng.integers(len(photos)))]
    return SurfaceParams(kind=kind, hue=hue, saturation=sat, value=val, roughness=rough, scale=scale,
                         rotation=rotation, offset=offset, photo=photo)


def draw_framing(index: int, seed: int, cfg: Config, cameras: tuple[CameraParams, ...]) -> tuple[CameraParams, ...]:
    """``camera.fill`` (or ``fill_views``), ``offset``, ``partial``, a ``lens_mm`` range and ``fstop``: each image's
    framing; ``cameras`` unchanged when all are off. Every image takes the same draws whichever options are on, so
    turning one on leaves the others' values as they were. f-numbers are drawn log-uniformly (stops are a ratio scale)."""
    c = cfg.camera
    if not c.framing:
        return cameras
    rng = stream("framing", seed, index)
    out = []
    for cam, fills in zip(cameras, c.fills):
        u = rng.uniform(size=8)
        fill = float(fills[0] + (fills[1] - fills[0]) * u[0]) if fills is not None else 0.0
        sx, sy = (float(c.offset * (2 * v - 1)) if c.offset > 0 else 0.0 for v in u[1:3])
        cut, side = 0.0, ""
        if c.partial > 0:
            cut_now = u[3] < c.partial
            cut = float(0.1 + 0.3 * u[4]) if cut_now else 0.0
            side = CUT_SIDES[min(int(u[5] * 4), 3)] if cut_now else "none"
        lens = float(c.lens_mm[0] + (c.lens_mm[1] - c.lens_mm[0]) * u[6]) if isinstance(c.lens_mm, tuple) else 0.0
        fstop = 0.0
        if c.fstop is not None:
            fstop = float(np.exp(np.log(c.fstop[0]) + (np.log(c.fstop[1]) - np.log(c.fstop[0])) * u[7]))
        out.append(replace(cam, fill=fill, shift_x=sx, shift_y=sy, cut=cut, cut_side=side, lens=lens, fstop=fstop))
    return tuple(out)


def draw_shape(index: int, seed: int, cfg: Config, spec: Spec) -> ShapeParams | None:
    """``object.shapes``: the part's shape. The built-in can takes a named size, or in a share ``continuous`` a
    point drawn between two sizes (every dimension blended); any part then takes the scale, taper and bulge. Every
    value is drawn for every part, so a change of one option moves no other draw."""
    s = cfg.object.shapes
    if s is None:
        return None
    rng = stream("shape", seed, index)
    a, b = (s.sizes[int(rng.integers(len(s.sizes)))] for _ in range(2))
    blend, t = bool(rng.uniform() < s.continuous), float(rng.uniform())
    neck, dome = float(rng.uniform(*s.neck)), float(rng.uniform(*s.dome))
    scale = tuple(float(rng.uniform(*r)) for r in s.scale)
    scale = (scale[0], scale[0], scale[2]) if s.round else scale
    taper, bulge = float(rng.uniform(*s.taper)), float(rng.uniform(*s.bulge))
    if spec.builtin != "can":
        return ShapeParams(size="", diameter=0.0, height=0.0, rim=1.0, neck=1.0, dome=1.0, scale=scale, taper=taper,
                           bulge=bulge)
    t = t if blend and a != b else 0.0
    dims = {k: (1 - t) * CAN_SIZES[a][k] + t * CAN_SIZES[b][k] for k in CAN_SIZES[a]}
    return ShapeParams(size=f"{a}~{b}" if t > 0 else a, diameter=dims["diameter"], height=dims["height"],
                       rim=dims["rim"], neck=dims["neck"] * neck, dome=dims["dome"] * dome, scale=scale, taper=taper,
                       bulge=bulge)


def draw_appearance(index: int, seed: int, cfg: Config, spec: Spec,
                    photos: list[str] | None = None) -> AppearanceParams | None:
    """``render.appearance``: the sample's artwork style, photo and crop, metallic inks, gloss and ink roughness.
    ``photos``: :func:`artwork_photos` of the config's folder (listed here when None and needed)."""
    a = cfg.render.appearance
    if a is None:
        return None
    rng = stream("appearance", seed, index)
    u = rng.uniform(size=3)
    design_seed = int(rng.integers(2**31))
    crop = (float(rng.uniform()), float(rng.uniform()), float(rng.uniform(1.0, 2.0)))
    gloss, roughness = float(rng.uniform(*a.gloss)), float(rng.uniform(*a.roughness))
    pick = float(rng.uniform())
    photo = ""
    if a.photos is not None and u[0] < a.photo_share:
        photos = photos if photos is not None else artwork_photos(a.photos)
        photo = photos[min(int(pick * len(photos)), len(photos) - 1)]
    can = spec.builtin == "can"
    if photo:
        style = "photo"
    elif can and a.designer:
        style = "bare" if u[1] < a.bare_share else "designer"
    else:
        style = "plain"
    metallic = bool(can and style != "plain" and u[2] < a.metallic_share)
    return AppearanceParams(style=style, seed=design_seed, metallic=metallic, photo=photo,
                            crop=crop if photo else (0.0, 0.0, 1.0), gloss=gloss, roughness=roughness)
