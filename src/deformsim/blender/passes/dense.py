"""Dense ground truth from the same Cycles render as the RGB image (``render.dense``).

The part's mesh carries a point attribute :data:`REST`: its rest shape, i.e. the Basis with the opening keys (tab,
seal) applied at the sample's values, so openings never count as deformation, and placed by a rigid fit
(:func:`deformsim.dataset.dense.rigid_fit`) where it matches the deformed part best, so that a bent or twisted part's
rigid motion does not count either. Every material of the part gets AOV outputs: ``deform`` = |world(Object coords -
rest)|, the displacement of the shaded point by the lattice and crinkle keys, ``across``, the length of its component
across the image (perpendicular to the line of sight), and ``across_xy`` (colour), that component in camera axes. A
second point attribute :data:`BEND` holds in x, per vertex, the angle its normal turned from the fitted rest shape's
(:func:`deformsim.dataset.dense.bend_deg`), shown through the AOV ``bend``; it is a vector because a float point
attribute moves Cycles' RGB render in the last bit. Under ``render.region_visible`` the rest shape also takes the
part's size along its axes, and ``across`` (or with ``view_fit``, ``across_xy``) and ``bend`` shape the region map.
After the RGBA render the render result (with the Depth, Normal and AOV passes) is saved once as multilayer EXR and
turned into the maps of :mod:`deformsim.dataset.dense`.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import bpy
import numpy as np
import OpenEXR

from deformsim.blender.feature import Feature
from deformsim.config import VisibleRegionConfig
from deformsim.dataset import dense as maps
from deformsim.dataset.layout import Layout
from deformsim.sampling import SampleParams
from deformsim.spec.model import Spec

REST = "deformsim_rest"
BEND = "deformsim_bend"
AOV = "deform"
ACROSS_AOV = "across"
ACROSS_XY_AOV = "across_xy"
COLOR_AOVS = (ACROSS_XY_AOV,)
BEND_AOV = "bend"
AOV_NODE = "DeformsimDeformAOV"
MM = 1000.0  # scene units (metres) to mm
_EXR = {"media_type": "MULTI_LAYER_IMAGE", "color_depth": "32", "exr_codec": "ZIP"}


def _co(seq, attr: str = "co") -> np.ndarray:
    flat = np.empty(len(seq) * 3, dtype=np.float32)
    seq.foreach_get(attr, flat)
    return flat.reshape(-1, 3)


def rest_positions(obj, spec: Spec, seal: float, tab: float) -> np.ndarray:
    """Object-space rest shape: the Basis plus the opening keys at ``seal`` and ``tab`` (float32, (N, 3))."""
    keys = obj.data.shape_keys.key_blocks if obj.data.shape_keys else None
    if keys is None:
        return _co(obj.data.vertices)
    co = _co(keys[0].data)
    for name, value in ((spec.openings.seal, seal), (spec.openings.tab, tab)):
        if name and value:
            block = keys[name]
            co += np.float32(value) * (_co(block.data) - _co(block.relative_key.data))
    return co


def prepare(scene, obj, spec: Spec, p: SampleParams, visible: bool = False) -> float:
    """Enable the passes, give every material of ``obj`` the AOV output and store sample ``p``'s rest shape;
    return the largest displacement of any vertex of the deformed mesh from it, in mm (world scale). ``visible``:
    the rest shape also takes the deformed part's size along its axes (:func:`deformsim.dataset.dense.scaled_fit`)
    and :data:`BEND` gets each vertex's turn angle (``render.region_visible``; zero otherwise)."""
    layer = scene.view_layers[0]
    layer.use_pass_z = layer.use_pass_normal = True
    for name in (AOV, ACROSS_AOV, ACROSS_XY_AOV, BEND_AOV):
        if name not in layer.aovs:
            aov = layer.aovs.add()
            aov.name, aov.type = name, "COLOR" if name in COLOR_AOVS else "VALUE"
    for mat in obj.data.materials:
        if mat is not None and AOV_NODE not in mat.node_tree.nodes:
            _add_aov(mat)
    mesh = obj.data
    attr = mesh.attributes.get(REST) or mesh.attributes.new(REST, "FLOAT_VECTOR", "POINT")
    bend = mesh.attributes.get(BEND) or mesh.attributes.new(BEND, "FLOAT_VECTOR", "POINT")
    rest = rest_positions(obj, spec, p.seal, p.tab)
    attr.data.foreach_set("vector", rest.ravel())
    bend.data.foreach_set("vector", np.zeros(rest.size, dtype=np.float32))
    mesh.update()
    evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    moved, rest_eval = _co(evaluated.vertices), _co(evaluated.attributes[REST].data, "vector")
    if not np.any(moved != rest_eval):
        return 0.0
    fit = maps.scaled_fit if visible else maps.rigid_fit
    r, t = fit(rest_eval, moved)  # deformed: measure from the rest shape placed where it fits best
    fitted = (rest @ r.T + t).astype(np.float32)
    mesh.attributes[REST].data.foreach_set("vector", fitted.ravel())
    world = np.array(obj.matrix_world)[:3, :3].T
    placed = (rest_eval @ r.T + t).astype(np.float32)  # what the fitted attribute holds, on the evaluated mesh
    if visible:  # the turn angles' only reader is render.region_visible
        tris = np.empty(len(evaluated.loop_triangles) * 3, dtype=np.int32)
        evaluated.loop_triangles.foreach_get("vertices", tris)
        turned = np.zeros_like(placed)
        turned[:, 0] = maps.bend_deg(placed.astype(float) @ world, moved.astype(float) @ world, tris.reshape(-1, 3))
        mesh.attributes[BEND].data.foreach_set("vector", turned.ravel())
    mesh.update()
    residual = (moved - placed).astype(float)
    return float(np.linalg.norm(residual @ world, axis=1).max() * MM)


def _add_aov(mat) -> None:
    nodes, links = mat.node_tree.nodes, mat.node_tree.links

    def math(op: str, *inputs):
        node = nodes.new("ShaderNodeVectorMath")
        node.operation = op
        for k, socket in enumerate(inputs):
            links.new(socket, node.inputs[k])
        return node.outputs["Value" if op in ("LENGTH", "DOT_PRODUCT") else "Vector"]

    def aov(name: str, socket, node_name: str = "") -> None:
        out = nodes.new("ShaderNodeOutputAOV")
        out.aov_name = name
        if node_name:
            out.name = node_name
        links.new(socket, out.inputs["Color" if name in COLOR_AOVS else "Value"])

    coord = nodes.new("ShaderNodeTexCoord")
    rest = nodes.new("ShaderNodeAttribute")
    rest.attribute_type, rest.attribute_name = "GEOMETRY", REST
    world = nodes.new("ShaderNodeVectorTransform")
    world.vector_type, world.convert_from, world.convert_to = "VECTOR", "OBJECT", "WORLD"
    links.new(math("SUBTRACT", coord.outputs["Object"], rest.outputs["Vector"]), world.inputs["Vector"])
    moved = world.outputs["Vector"]
    aov(AOV, math("LENGTH", moved), AOV_NODE)
    view = nodes.new("ShaderNodeNewGeometry").outputs["Incoming"]  # world, unit, towards the viewer
    along = nodes.new("ShaderNodeVectorMath")
    along.operation = "SCALE"
    links.new(view, along.inputs[0])
    links.new(math("DOT_PRODUCT", moved, view), along.inputs["Scale"])
    across = math("SUBTRACT", moved, along.outputs["Vector"])
    aov(ACROSS_AOV, math("LENGTH", across))
    to_camera = nodes.new("ShaderNodeVectorTransform")
    to_camera.vector_type, to_camera.convert_from, to_camera.convert_to = "VECTOR", "WORLD", "CAMERA"
    links.new(across, to_camera.inputs["Vector"])
    aov(ACROSS_XY_AOV, to_camera.outputs["Vector"])
    bend = nodes.new("ShaderNodeAttribute")
    bend.attribute_type, bend.attribute_name = "GEOMETRY", BEND
    angle = nodes.new("ShaderNodeSeparateXYZ")
    links.new(bend.outputs["Vector"], angle.inputs["Vector"])
    aov(BEND_AOV, angle.outputs["X"])


def _passes(scene, target: Path) -> dict[str, np.ndarray]:
    """Save the last render result as multilayer EXR beside ``target``; return its channels by name (rows top-down)."""
    settings = scene.render.image_settings
    target.parent.mkdir(parents=True, exist_ok=True)
    saved = {k: getattr(settings, k) for k in ("media_type", "file_format", "color_mode", "color_depth", "compression")}
    fd, tmp = tempfile.mkstemp(prefix=f".{target.stem}.passes.", suffix=".exr", dir=target.parent)
    os.close(fd)
    try:
        for k, v in _EXR.items():
            setattr(settings, k, v)
        bpy.data.images["Render Result"].save_render(tmp, scene=scene)
        with OpenEXR.File(tmp, separate_channels=True) as f:
            return {name: ch.pixels.copy() for part in f.parts for name, ch in part.channels.items()}
    finally:
        for k, v in saved.items():
            setattr(settings, k, v)
        Path(tmp).unlink(missing_ok=True)


def write_maps(scene, camera, alpha8: np.ndarray, layout: Layout, iid: str, threshold_mm: float,
               visible: VisibleRegionConfig | None = None) -> dict:
    """Write the five maps of image ``iid`` from the last render; return its manifest columns (bbox, disp, region).
    ``visible`` (``render.region_visible``): the region keeps only what shows in the image."""
    ch = _passes(scene, layout.image("mask", iid))
    layer = scene.view_layers[0].name
    mask = alpha8 >= 128
    coverage = np.maximum(ch[f"{layer}.Combined.A"], 1e-6)
    # Passes are averaged over every camera sample, misses counting 0: divide the AOVs by the part's coverage.
    deform = np.where(mask, ch[f"{layer}.{AOV}.X"] / coverage, 0.0) * MM
    depth = _fill(np.where(mask & (ch[f"{layer}.Depth.Z"] < 1e9), ch[f"{layer}.Depth.Z"], 0.0) * MM, mask)
    normal = np.stack([ch[f"{layer}.Normal.{a}"] for a in "XYZ"], axis=-1)
    cam = np.array(camera.matrix_world)[:3, :3]
    normal = normal @ (cam / np.linalg.norm(cam, axis=0))  # world -> camera axes
    normal /= np.maximum(np.linalg.norm(normal, axis=-1, keepdims=True), 1e-9)
    shown = None
    if visible is not None:
        # a pixel's width in mm at the surface's depth (square images: the sensor's width spans the frame)
        px_mm = np.maximum(depth, 1e-6) * camera.data.sensor_width / (camera.data.lens * alpha8.shape[1])
        if visible.view_fit:
            xy = [np.where(mask, ch[f"{layer}.{ACROSS_XY_AOV}.{c}"] / coverage, 0.0) * MM / px_mm for c in "RG"]
            moved_px = maps.beyond_affine(*xy, mask)
        else:
            moved_px = np.where(mask, ch[f"{layer}.{ACROSS_AOV}.X"] / coverage, 0.0) * MM / px_mm
        turned = np.where(mask, ch[f"{layer}.{BEND_AOV}.X"] / coverage, 0.0)
        shown = maps.shown(moved_px, turned, visible.across_px, visible.turn_deg)
    region = maps.region_mask(deform, mask, threshold_mm, shown)
    maps.save_png(layout.image("mask", iid), maps.mask_image(mask))
    maps.save_png(layout.image("depth", iid), maps.encode_u16(depth, 1.0))
    maps.save_png(layout.image("normal", iid), maps.encode_normal(normal, mask))
    encoded = maps.encode_u16(deform, maps.DEFORM_SCALE)
    maps.save_png(layout.image("deform", iid), encoded)
    maps.save_png(layout.image("region", iid), maps.mask_image(region))
    return maps.map_stats(mask, encoded / maps.DEFORM_SCALE, region)


def _fill(depth: np.ndarray, mask: np.ndarray, steps: int = 4) -> np.ndarray:
    """Depth is taken from the first camera sample: give covered pixels it missed their nearest neighbour's depth."""
    h, w = depth.shape
    for _ in range(steps):
        hole = mask & (depth == 0)
        if not hole.any():
            break
        pad = np.pad(np.where(depth > 0, depth, np.inf), 1, constant_values=np.inf)
        near = np.min([pad[dy:dy + h, dx:dx + w] for dy in range(3) for dx in range(3)], axis=0)
        depth = np.where(hole & np.isfinite(near), near, depth)
    return depth


def family_flags(spec: Spec, p: SampleParams) -> dict[str, int]:
    return {f"family_{name}": int(name in p.families) for name in [f.name for f in spec.families] + spec.scenario_names}


class Dense(Feature):
    """``render.dense``: the five maps of :data:`~deformsim.dataset.layout.DENSE_KINDS` per camera, with each
    image's columns: the sample's largest displacement and families, the image's bounding box, displacement and
    region (:func:`deformsim.dataset.dense.map_stats`)."""

    def __init__(self, ctx):
        super().__init__(ctx)
        self.sample: dict = {}  # the sample's columns, shared by its images
        self.images: list[dict] = []  # each image's columns

    def apply(self, p, target) -> None:
        ctx = self.ctx
        disp = prepare(ctx.scene, ctx.obj, ctx.spec, p, visible=ctx.cfg.render.region_visible is not None)
        self.sample = {"max_disp_mm": disp, **family_flags(ctx.spec, p)}
        self.images = []

    def image(self, c: int, iid: str, rgba: np.ndarray, layout: Layout) -> None:
        ctx = self.ctx
        render = ctx.cfg.render
        stats = write_maps(ctx.scene, ctx.cameras[c], rgba[..., 3], layout, iid, render.region_threshold_mm,
                           render.region_visible)
        self.images.append({**self.sample, **stats})

    def image_columns(self, c: int) -> dict:
        return self.images[c]
