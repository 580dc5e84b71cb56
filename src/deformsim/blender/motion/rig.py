"""The deformation rig: a B-spline lattice with one shape key per spec key, plus crinkle shape keys.

Lattice keys come from :func:`deformsim.spec.lattice_ops.key_points`; crinkle keys are hard Stucci DISPLACE
modifiers baked as mesh shape keys on the undeformed mesh, limited to the vertex group ``crinkle``.
"""

from __future__ import annotations

from dataclasses import dataclass

import bpy
import numpy as np

from deformsim.blender.part.selection import selected, vectors
from deformsim.errors import UserError
from deformsim.spec.lattice_ops import key_points, rest_lattice
from deformsim.spec.model import Spec

SLIDER_MAX = 3.0
CRINKLE_GROUP = "crinkle"


def mesh_bounds(obj) -> tuple[np.ndarray, np.ndarray]:
    """World-space (min, max) corners of the object's undeformed mesh."""
    co = vectors(obj.data.vertices, "co")
    m = np.array(obj.matrix_world)
    world = co @ m[:3, :3].T + m[:3, 3]
    return world.min(0), world.max(0)


BANK_PREFIX = "bank:"


@dataclass
class Rig:
    obj: object
    lattice: object
    spec: Spec
    bank: tuple[str, ...] = ()  # simulated entries loaded as mesh keys ``bank:NAME``

    def set(self, keys: dict[str, float], displacement: dict[str, float], seal: float = 0.0, tab: float = 0.0,
            bank: str = "", bank_amount: float = 0.0) -> None:
        """Set every lattice key, crinkle key, opening key and bank key (``bank`` at ``bank_amount``, the rest 0);
        unknown names raise ValueError."""
        lat_keys = self.lattice.data.shape_keys.key_blocks
        mesh_keys = self.obj.data.shape_keys.key_blocks if self.obj.data.shape_keys else {}
        for values, names, kind in ((keys, self.spec.key_names, "lattice key"),
                                    (displacement, self.spec.texture_names, "crinkle key")):
            unknown = set(values) - set(names)
            if unknown:
                raise ValueError(f"unknown {kind}(s): {', '.join(sorted(unknown))}")
        for name in self.spec.key_names:
            lat_keys[name].value = float(keys.get(name, 0.0))
        for name in self.spec.texture_names:
            mesh_keys[name].value = float(displacement.get(name, 0.0))
        for name, value in ((self.spec.openings.seal, seal), (self.spec.openings.tab, tab)):
            if name:
                mesh_keys[name].value = float(value)
        if bank and bank not in self.bank:
            raise ValueError(f"bank entry '{bank}' is not loaded (baked bank has {len(self.bank)} entries)")
        for name in self.bank:
            mesh_keys[BANK_PREFIX + name].value = float(bank_amount) if name == bank else 0.0

    def load_bank(self, names: list[str], positions: np.ndarray) -> None:
        """Add each simulated entry as a mesh shape key (relative to the Basis, so openings still apply)."""
        if positions.shape[1] != len(self.obj.data.vertices):
            raise UserError(f"the baked bank has {positions.shape[1]} vertices per entry, the part "
                            f"{len(self.obj.data.vertices)}: bake again (deformsim bake --force)")
        for name, co in zip(names, positions):
            block = self.obj.shape_key_add(name=BANK_PREFIX + name, from_mix=False)
            block.slider_max = SLIDER_MAX
            block.value = 0.0
            block.data.foreach_set("co", np.ascontiguousarray(co, dtype=np.float32).ravel())
        self.bank = tuple(names)


def build_rig(obj, spec: Spec) -> Rig:
    """Bake crinkle keys, then add the lattice (with its keys) and the LATTICE modifier to ``obj``."""
    _check_openings(obj, spec)
    if obj.data.shape_keys:  # new keys start at 1.0: bake crinkle on the undeformed mesh
        for block in obj.data.shape_keys.key_blocks[1:]:
            block.value = 0.0
    if spec.displacement and spec.displacement.textures:
        _crinkle_group(obj, spec)
        for tex in spec.displacement.textures:
            _bake_texture_key(obj, tex)
    lattice = _lattice(obj, spec)
    mod = obj.modifiers.new("Deform", "LATTICE")
    mod.object = lattice
    return Rig(obj=obj, lattice=lattice, spec=spec)


def _check_openings(obj, spec: Spec) -> None:
    have = set(obj.data.shape_keys.key_blocks.keys()) if obj.data.shape_keys else set()
    for name in (spec.openings.seal, spec.openings.tab):
        if name and name not in have:
            raise UserError(f"spec '{spec.name}': opening key '{name}' is not a shape key of the mesh (has: {sorted(have)})")


def _lattice(obj, spec: Spec):
    lo, hi = mesh_bounds(obj)
    size = np.maximum(hi - lo, 1e-6) * (1 + 2 * spec.lattice.margin)
    data = bpy.data.lattices.new("DeformLattice")
    lat = bpy.data.objects.new("DeformLattice", data)
    bpy.context.scene.collection.objects.link(lat)
    lat.location = tuple((lo + hi) / 2)
    lat.scale = tuple(size)
    data.points_u, data.points_v, data.points_w = spec.lattice.points  # after linking: points span [-0.5, 0.5]
    for axis in "uvw":
        setattr(data, f"interpolation_type_{axis}", "KEY_BSPLINE")
    rest = rest_lattice(spec.lattice.points)
    if not np.allclose(vectors(data.points, "co"), rest, atol=1e-5):
        raise RuntimeError("Blender's lattice point order differs from lattice_ops.rest_lattice")
    lat.shape_key_add(name="Basis", from_mix=False)
    for fam in spec.families:
        for key in fam.keys:
            block = lat.shape_key_add(name=key.name, from_mix=False)
            block.slider_max = SLIDER_MAX
            block.value = 0.0
            pts = key_points(rest, [(op.op, op.params) for op in key.ops])
            block.data.foreach_set("co", pts.astype(np.float32).ravel())
    lat.hide_render = True
    return lat


def _crinkle_group(obj, spec: Spec) -> None:
    mask = selected(obj, spec.displacement.vertex_rule, f"spec '{spec.name}': displacement.vertex_rule")
    obj.vertex_groups.new(name=CRINKLE_GROUP).add(np.flatnonzero(mask).tolist(), 1.0, "REPLACE")


def _bake_texture_key(obj, tex) -> None:
    """Apply a hard Stucci DISPLACE modifier as the mesh shape key ``tex.name``."""
    if obj.data.shape_keys is None:
        obj.shape_key_add(name="Basis", from_mix=False)
    texture = bpy.data.textures.new(tex.name, "STUCCI")
    texture.noise_type = "HARD_NOISE"
    texture.noise_scale = tex.noise_scale
    texture.turbulence = tex.turbulence
    texture.stucci_type = tex.stucci_type
    origin = bpy.data.objects.new(f"{tex.name}_origin", None)  # texture space shifted by -offset
    bpy.context.scene.collection.objects.link(origin)
    origin.location = tuple(-np.asarray(tex.offset, dtype=float))
    mod = obj.modifiers.new(tex.name, "DISPLACE")
    mod.texture = texture
    mod.texture_coords = "OBJECT"
    mod.texture_coords_object = origin
    mod.direction = "NORMAL"
    mod.strength = tex.strength
    mod.vertex_group = CRINKLE_GROUP
    bpy.context.view_layer.update()
    with bpy.context.temp_override(object=obj, active_object=obj, selected_objects=[obj]):
        bpy.ops.object.modifier_apply_as_shapekey(modifier=mod.name, keep_modifier=False)
    block = obj.data.shape_keys.key_blocks[-1]
    block.name = tex.name
    block.slider_max = SLIDER_MAX
    block.value = 0.0
    bpy.data.objects.remove(origin)
    bpy.data.textures.remove(texture)
