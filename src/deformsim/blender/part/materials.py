"""Materials: the can's printed label and brushed aluminium, and randomised user-mesh surfaces (one per spec region).

Everything is created once and updated in place on later calls, so memory stays bounded over thousands
of samples: one label image ("LabelImage") whose pixels are overwritten, one material per role. With
``render.appearance`` (:func:`enable_appearance`) the label also gets a finish image ("LabelFinish": where the
metal shows) driving its metallic and roughness, and a user mesh's material a box-projected texture photo
("ObjectTexture"), each overwritten per sample too. A finish with ``print`` gets an ink mask ("Print:" + its
material's name), box-projected from the generated coordinates and overwritten per sample.
"""

from __future__ import annotations

import bpy
import numpy as np

from deformsim.blender.part.can_label import make_label
from deformsim.blender.part.label_art import _photo_pixels, make_artwork
from deformsim.blender.part.print_art import make_print
from deformsim.blender.part.selection import selected
from deformsim.sampling import AppearanceParams, CanDesign, MaterialParams, PrintParams
from deformsim.spec.model import Finish, Material, Spec

LABEL_IMAGE = "LabelImage"
OBJECT_MATERIAL = "ObjectMaterial"
_KINDS = {  # Principled settings per spec material kind
    "metal": {"Metallic": 1.0, "Coat Weight": 0.0, "Anisotropic": 0.3},
    "plastic": {"Metallic": 0.0, "Coat Weight": 0.0, "Anisotropic": 0.0},
    "painted": {"Metallic": 0.0, "Coat Weight": 0.6, "Anisotropic": 0.0},
}
# Crease layer (Cycles' Geometry "Pointiness": 0.5 flat, above convex, below concave), see add_creases.
CREASE_GEOMETRY = "CreaseGeometry"  # its Geometry node; present = the material has the layer
CREASE_IN = "Crease In "  # + BSDF input name: the mix whose A input takes that input's (per-sample) value
RIDGE = (0.53, 0.58)  # pointiness from which a ridge starts to show bare metal, and where it is fully bare
FOLD = (0.485, 0.44)  # pointiness from which a fold starts to darken, and where it is fully dark
FOLD_DARKEN = 0.3  # base colour factor in a full fold
BARE = {"Base Color": (0.8, 0.8, 0.82, 1.0), "Metallic": 1.0, "Roughness": 0.45, "Coat Weight": 0.0}
SCUFF_SCALE = 350.0  # noise scale (per metre, object space) breaking the ridge mask into scuffs
_creases = False  # set by enable_creases: OBJECT_MATERIAL gets the layer when it is created
FINISH_IMAGE = "LabelFinish"  # render.appearance: 1 where the label shows metal (bare or metallic ink)
TEXTURE_IMAGE = "ObjectTexture"  # render.appearance: a user mesh's texture photo
INK_METALLIC, METAL_ROUGHNESS = 0.2, 0.22  # printed basecoat and ink; bare or metallic-inked aluminium
TEXTURE_SIZE = 512
PRINT_IMAGE = "Print:"  # + material name: a finish's ink mask (spec print)
PRINT_INK = {"Metallic": 0.0, "Roughness": 0.35}  # printed ink: a satin dielectric layer over the finish
_appearance = False  # set by enable_appearance: OBJECT_MATERIAL gets the texture photo when it is created
_part_size = 1.0  # metres: the user mesh's largest dimension (the texture's projection scale)
_faces: np.ndarray | None = None  # set by assign_regions: each face's material slot (None: all the spec material's)


def _material(name: str) -> tuple[bpy.types.Material, bool]:
    """The material called ``name`` and whether it was just created (5.0: always node based)."""
    mat = bpy.data.materials.get(name)
    return (mat, False) if mat else (bpy.data.materials.new(name), True)


def _bsdf(mat: bpy.types.Material) -> bpy.types.Node:
    return next(n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED")


def _set(bsdf: bpy.types.Node, values: dict) -> None:
    """Set BSDF inputs; where the crease layer sits in front of one, its entry mix takes the value."""
    for name, value in values.items():
        bsdf.inputs[name].default_value = value
        entry = bsdf.id_data.nodes.get(CREASE_IN + name)
        if entry is not None:
            _socket(entry.inputs, "A_Color" if entry.data_type == "RGBA" else "A_Float").default_value = value


def _socket(sockets, identifier: str):
    """The socket with this identifier (Mix nodes have several sockets of each name)."""
    return next(s for s in sockets if s.identifier == identifier)


def _bump(mat: bpy.types.Material, bsdf: bpy.types.Node, scale: float, strength: float) -> None:
    """Fine noise bump in object space (metres): brushing and rolling marks."""
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    coord = nodes.new("ShaderNodeTexCoord")
    noise = nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = scale
    noise.inputs["Detail"].default_value = 4.0
    bump = nodes.new("ShaderNodeBump")
    bump.inputs["Strength"].default_value = strength
    bump.inputs["Distance"].default_value = 0.0002
    links.new(coord.outputs["Object"], noise.inputs["Vector"])
    links.new(noise.outputs["Fac"], bump.inputs["Height"])
    links.new(bump.outputs["Normal"], bsdf.inputs["Normal"])


def _map_range(nodes, value, lo: float, hi: float) -> bpy.types.NodeSocket:
    """Clamped linear 0..1 ramp of ``value`` from ``lo`` to ``hi`` (``hi < lo``: a falling ramp)."""
    ramp = nodes.new("ShaderNodeMapRange")
    ramp.clamp = True
    ramp.inputs["From Min"].default_value, ramp.inputs["From Max"].default_value = lo, hi
    value.id_data.links.new(value, ramp.inputs["Value"])
    return ramp.outputs["Result"]


def _mix_into(bsdf: bpy.types.Node, name: str, factor, target, blend: str = "MIX") -> bpy.types.Node:
    """Put a Mix (A = what fed input ``name`` so far, B = ``target``, by ``factor``) in front of that input; return it."""
    tree = bsdf.id_data
    sock = bsdf.inputs[name]
    color = sock.type == "RGBA"
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type, mix.blend_type = ("RGBA" if color else "FLOAT"), blend
    kind = "Color" if color else "Float"
    a, b = _socket(mix.inputs, f"A_{kind}"), _socket(mix.inputs, f"B_{kind}")
    b.default_value = target
    tree.links.new(factor, _socket(mix.inputs, "Factor_Float"))
    if sock.is_linked:
        tree.links.new(sock.links[0].from_socket, a)
    else:  # a constant: this mix becomes the input's entry, where _set writes later values
        a.default_value = sock.default_value
        mix.name = CREASE_IN + name
    tree.links.new(_socket(mix.outputs, f"Result_{kind}"), sock)
    return mix


def add_creases(mat: bpy.types.Material, ridges: bool = True) -> None:
    """Insert the crease layer in front of ``mat``'s Principled BSDF (once; no-op if it is there).

    Folds (pointiness below :data:`FOLD`) darken the base colour towards :data:`FOLD_DARKEN` times itself;
    with ``ridges``, sharp convex ridges (above :data:`RIDGE`) turn to scuffed bare aluminium (:data:`BARE`:
    bright base colour, metallic, rougher, no coat), the mask broken up by a small noise so it reads as
    scuffing rather than a clean line. Constant BSDF inputs move to the mixes' A inputs (see :func:`_set`).
    """
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    if CREASE_GEOMETRY in nodes:
        return
    bsdf = _bsdf(mat)
    geo = nodes.new("ShaderNodeNewGeometry")
    geo.name = CREASE_GEOMETRY
    pointiness = geo.outputs["Pointiness"]
    _mix_into(bsdf, "Base Color", _map_range(nodes, pointiness, *FOLD), (FOLD_DARKEN,) * 3 + (1.0,), "MULTIPLY")
    if not ridges:
        return
    coord = nodes.new("ShaderNodeTexCoord")
    noise = nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = SCUFF_SCALE
    noise.inputs["Detail"].default_value = 6.0
    noise.inputs["Roughness"].default_value = 0.65
    links.new(coord.outputs["Object"], noise.inputs["Vector"])
    scuff = nodes.new("ShaderNodeMapRange")
    scuff.clamp = True
    scuff.inputs["From Min"].default_value, scuff.inputs["From Max"].default_value = 0.35, 0.6
    scuff.inputs["To Min"].default_value = 0.25
    links.new(noise.outputs["Fac"], scuff.inputs["Value"])
    mask = nodes.new("ShaderNodeMath")
    mask.operation, mask.use_clamp = "MULTIPLY", True
    links.new(_map_range(nodes, pointiness, *RIDGE), mask.inputs[0])
    links.new(scuff.outputs["Result"], mask.inputs[1])
    for name, target in BARE.items():
        _mix_into(bsdf, name, mask.outputs["Value"], target)


def enable_creases(obj: bpy.types.Object, enabled: bool = True) -> None:
    """Switch the crease layer on (``render.creases``): once per process, after the object is built.

    The can's "Label" gets ridges and folds, its bare "Aluminium" folds only; a user mesh's material gets
    both when :func:`apply_material` creates it (or now, if it exists). Off, no material is touched.
    """
    global _creases
    _creases = enabled
    if not enabled:
        return
    for mat in obj.data.materials:
        if mat is not None and mat.name in ("Label", "Aluminium", OBJECT_MATERIAL):
            add_creases(mat, ridges=mat.name != "Aluminium")


def label_image(width: int = 512, height: int = 256, name: str = LABEL_IMAGE) -> bpy.types.Image:
    """The one label image (or the image ``name``), created on first use (8-bit sRGB) and resized in place when
    asked."""
    img = bpy.data.images.get(name)
    if img is None:
        img = bpy.data.images.new(name, width, height, alpha=True)
    elif tuple(img.size) != (width, height):
        img.scale(width, height)
    return img


def _write(img: bpy.types.Image, pixels: np.ndarray) -> None:
    """Overwrite ``img``'s pixels (row 0 = top) in place and make Cycles reload them."""
    img.pixels.foreach_set(np.ascontiguousarray(pixels[::-1]).ravel())  # Blender rows go bottom-up
    img.update()
    img.update_tag()
    # Cycles with persistent data keeps an image it has loaded until the image's parameters change; the
    # images are opaque, so flipping the (unused) alpha mode makes it reload the new pixels at no cost.
    img.alpha_mode = "NONE" if img.alpha_mode == "STRAIGHT" else "STRAIGHT"


def enable_appearance(obj: bpy.types.Object, on: bool = True) -> None:
    """Switch ``render.appearance`` on: once per process, after the object is built and before the crease layer.

    The can's "Label" gets the finish image: metallic and roughness mix from the ink's (the basecoat's metallic,
    the drawn roughness) to bare aluminium's where the finish is 1. A user mesh's material gets the texture photo
    when :func:`apply_material` creates it. Off, no material is touched."""
    global _appearance, _part_size
    _appearance = on
    if not on:
        return
    co = np.empty(len(obj.data.vertices) * 3, np.float32)
    obj.data.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3)
    _part_size = float((co.max(0) - co.min(0)).max()) if len(co) else 1.0
    label = obj.data.materials.get("Label") if obj.data.materials else None
    if label is None or FINISH_IMAGE in label.node_tree.nodes:
        return
    nodes, links = label.node_tree.nodes, label.node_tree.links
    bsdf = _bsdf(label)
    tex = nodes.new("ShaderNodeTexImage")
    tex.name = FINISH_IMAGE
    tex.image = label_image(name=FINISH_IMAGE)
    tex.image.colorspace_settings.name = "Non-Color"
    tex.interpolation = "Closest"  # a mask: no blur of metal into ink
    links.new(nodes[LABEL_IMAGE].inputs["Vector"].links[0].from_socket, tex.inputs["Vector"])
    for name, ink, metal in (("Metallic", INK_METALLIC, 1.0), ("Roughness", 0.3, METAL_ROUGHNESS)):
        mix = nodes.new("ShaderNodeMix")
        mix.name = FINISH_IMAGE + name
        mix.data_type = "FLOAT"
        _socket(mix.inputs, "A_Float").default_value = ink
        _socket(mix.inputs, "B_Float").default_value = metal
        links.new(tex.outputs["Color"], _socket(mix.inputs, "Factor_Float"))
        links.new(_socket(mix.outputs, "Result_Float"), bsdf.inputs[name])


def _texture_nodes(mat: bpy.types.Material, bsdf: bpy.types.Node) -> None:
    """A box-projected photo (object coordinates) mixed over the drawn colour by a 0/1 factor set per sample; the mix
    is the Base Color's entry, so :func:`_set` writes the drawn colour to its A input."""
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    coord = nodes.new("ShaderNodeTexCoord")
    mapping = nodes.new("ShaderNodeMapping")
    mapping.name = TEXTURE_IMAGE + "Mapping"
    tex = nodes.new("ShaderNodeTexImage")
    tex.name = TEXTURE_IMAGE
    tex.image = label_image(TEXTURE_SIZE, TEXTURE_SIZE, TEXTURE_IMAGE)
    tex.projection, tex.projection_blend, tex.extension = "BOX", 0.25, "MIRROR"
    links.new(coord.outputs["Object"], mapping.inputs["Vector"])
    links.new(mapping.outputs["Vector"], tex.inputs["Vector"])
    mix = nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    mix.name = CREASE_IN + "Base Color"
    _socket(mix.inputs, "A_Color").default_value = bsdf.inputs["Base Color"].default_value
    links.new(tex.outputs["Color"], _socket(mix.inputs, "B_Color"))
    links.new(_socket(mix.outputs, "Result_Color"), bsdf.inputs["Base Color"])


def can_materials(obj: bpy.types.Object) -> None:
    """Give ``obj`` slot 0 "Label" (printed aluminium) and slot 1 "Aluminium" (brushed metal)."""
    label, new = _material("Label")
    if new:
        bsdf = _bsdf(label)
        tex = label.node_tree.nodes.new("ShaderNodeTexImage")
        tex.name = LABEL_IMAGE
        tex.image = label_image()
        uv = label.node_tree.nodes.new("ShaderNodeUVMap")
        uv.uv_map = "UVMap"
        label.node_tree.links.new(uv.outputs["UV"], tex.inputs["Vector"])
        label.node_tree.links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
        _set(bsdf, {"Metallic": 0.7, "Roughness": 0.3, "Coat Weight": 0.35, "Coat Roughness": 0.08})
        _bump(label, bsdf, 900.0, 0.03)
    alu, new = _material("Aluminium")
    if new:
        bsdf = _bsdf(alu)
        _set(bsdf, {"Base Color": (0.8, 0.8, 0.82, 1.0), "Metallic": 1.0, "Roughness": 0.3,
                    "Anisotropic": 0.5})
        _bump(alu, bsdf, 1500.0, 0.05)
    mats = obj.data.materials
    mats.clear()
    mats.append(label)
    mats.append(alu)


def set_label(design: CanDesign, width: int = 512, height: int = 256, look: AppearanceParams | None = None,
              aspect: float = 1.0) -> None:
    """Print ``design`` into the shared "LabelImage" (pixels overwritten; no new image per sample). With ``look``
    (``render.appearance``, after :func:`enable_appearance`) the artwork of :mod:`~.label_art` for a label ``aspect``
    times taller than the built can's, its finish into "LabelFinish" and the drawn gloss and ink roughness."""
    if look is None:
        _write(label_image(width, height), make_label(design, width, height))
        return
    rgba, metal = make_artwork(design, look, width, height, aspect)
    _write(label_image(width, height), rgba)
    _write(label_image(width, height, FINISH_IMAGE), np.repeat(metal[..., None], 4, axis=2))
    label = bpy.data.materials["Label"]
    _set(_bsdf(label), {"Coat Weight": look.gloss})
    _socket(label.node_tree.nodes[FINISH_IMAGE + "Roughness"].inputs, "A_Float").default_value = look.roughness


def assign_regions(obj: bpy.types.Object, spec: Spec) -> None:
    """Which material slot each face of a user mesh takes: 0 the spec material's, 1 + i its region i's (a later region
    takes the faces it shares with an earlier one). Once per process, on the mesh as built, before
    :func:`apply_material`; raises :class:`UserError` naming a region that selects no face."""
    global _faces
    _faces = np.zeros(len(obj.data.polygons), np.int32)
    for i, region in enumerate(spec.material.regions if spec.material else []):
        _faces[selected(obj, region.where, f"spec '{spec.name}': material region '{region.name}'", faces=True)] = i + 1


def _finish(name: str, finish: Finish, params: MaterialParams, texture: bool = False) -> bpy.types.Material:
    """The material ``name`` (created on first use with its bump, ``texture`` nodes, print nodes and the crease layer
    when on) set to ``finish.kind`` with ``params`` colour, roughness and printed marks and the finish's anisotropy."""
    mat, new = _material(name)
    bsdf = _bsdf(mat)
    if new:
        _bump(mat, bsdf, 1200.0, 0.02)
        if texture:
            _texture_nodes(mat, bsdf)
        if finish.print is not None:
            _print_nodes(mat, bsdf)
    if _creases:
        add_creases(mat)
    _set(bsdf, {**_KINDS[finish.kind], "Base Color": (*params.color, 1.0), "Roughness": params.roughness,
                "Coat Roughness": 0.1, "Anisotropic Rotation": finish.anisotropic_rotation})
    if finish.anisotropic is not None:  # Cycles' default tangent runs around the object's up axis
        _set(bsdf, {"Anisotropic": finish.anisotropic})
    if finish.print is not None:
        _set_print(mat, params.print)
    return mat


def _print_nodes(mat: bpy.types.Material, bsdf: bpy.types.Node) -> None:
    """The ink mask, box-projected from the generated coordinates (each side of the part's box spans the image), mixing
    the base colour to the ink's and metallic and roughness to :data:`PRINT_INK`'s."""
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    coord = nodes.new("ShaderNodeTexCoord")
    tex = nodes.new("ShaderNodeTexImage")
    tex.name = PRINT_IMAGE
    tex.image = label_image(TEXTURE_SIZE, TEXTURE_SIZE, PRINT_IMAGE + mat.name)
    tex.image.colorspace_settings.name = "Non-Color"
    tex.projection, tex.projection_blend, tex.extension = "BOX", 0.1, "CLIP"
    links.new(coord.outputs["Generated"], tex.inputs["Vector"])
    _mix_into(bsdf, "Base Color", tex.outputs["Color"], (0.0, 0.0, 0.0, 1.0)).label = PRINT_IMAGE + "Base Color"
    for name, value in PRINT_INK.items():
        _mix_into(bsdf, name, tex.outputs["Color"], value)


def _set_print(mat: bpy.types.Material, p: PrintParams | None) -> None:
    """This sample's marks in the ink mask and its ink colour, or an empty mask (bare this sample)."""
    mask = make_print(p, TEXTURE_SIZE) if p is not None else np.zeros((TEXTURE_SIZE, TEXTURE_SIZE), np.float32)
    _write(mat.node_tree.nodes[PRINT_IMAGE].image, np.dstack([mask, mask, mask, np.ones_like(mask)]))
    if p is not None:
        ink = next(n for n in mat.node_tree.nodes if n.label == PRINT_IMAGE + "Base Color")
        _socket(ink.inputs, "B_Color").default_value = (*p.ink, 1.0)


def apply_material(obj: bpy.types.Object, spec_material: Material, params: MaterialParams,
                   look: AppearanceParams | None = None) -> None:
    """Give a user mesh its materials: the spec material's with ``params``, with ``look`` (``render.appearance``) its
    texture photo (or none) and gloss; each region's with its ``params.regions`` entry, on the faces of
    :func:`assign_regions`."""
    mat = _finish(OBJECT_MATERIAL, spec_material, params, _appearance)
    if look is not None and TEXTURE_IMAGE in mat.node_tree.nodes:
        _set_texture(mat, _bsdf(mat), look)
    slots = [mat] + [_finish(f"{OBJECT_MATERIAL}:{r.name}", r, p) for r, p in zip(spec_material.regions, params.regions)]
    mats = obj.data.materials
    if list(mats) != slots:
        mats.clear()
        for m in slots:
            mats.append(m)
        faces = _faces if _faces is not None else np.zeros(len(obj.data.polygons), np.int32)
        obj.data.polygons.foreach_set("material_index", faces)


def _set_texture(mat: bpy.types.Material, bsdf: bpy.types.Node, look: AppearanceParams) -> None:
    """The sample's texture photo (zoomed and shifted by its crop) over the part, or the drawn colour alone; gloss."""
    nodes = mat.node_tree.nodes
    entry = nodes[CREASE_IN + "Base Color"]
    _socket(entry.inputs, "Factor_Float").default_value = 1.0 if look.photo else 0.0
    if look.photo:
        from PIL import Image

        px = Image.fromarray((_photo_pixels(look.photo) * 255 + 0.5).astype(np.uint8))
        px = np.asarray(px.resize((TEXTURE_SIZE, TEXTURE_SIZE), Image.BILINEAR), np.float32) / 255
        _write(bpy.data.images[TEXTURE_IMAGE], np.concatenate([px, np.ones((*px.shape[:2], 1), np.float32)], axis=2))
        mapping = nodes[TEXTURE_IMAGE + "Mapping"]
        mapping.inputs["Scale"].default_value = (look.crop[2] / _part_size,) * 3
        mapping.inputs["Location"].default_value = (look.crop[0], look.crop[1], 0.0)
    _set(bsdf, {"Coat Weight": look.gloss})
