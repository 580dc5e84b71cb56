"""The built-in 355 ml soda can, built procedurally with bmesh (no .blend file).

One mesh object "Can" in metres, standing on z = 0 around the z axis: a revolved profile (domed bottom,
standing ring, straight side wall, tapered neck, rolled rim, countersunk lid), a teardrop score panel in the
lid and a riveted tab plate. Every loop of the body has :data:`SEGMENTS` vertices, so it is all quads but
the poles. Shape keys "Seal" (panel hinged down) and "Tab" (ring end lifted) are the openings.
"""

from __future__ import annotations

import math

import bpy

# isort: split
import bmesh  # importable only once bpy is
import numpy as np

SEGMENTS = 64
RADIUS, HEIGHT = 0.033, 0.122
WALL = (0.010, 0.108)  # side-wall (label) z range
WALL_RINGS = 41
LID_Z, LID_R = 0.1172, 0.0245
PANEL_C = np.array([0.0, 0.0115])  # score panel centre: off the rivet (origin) towards +y
SCORE_GAP = 0.0006  # width of the score strip that becomes the panel's wall when pushed in
SCORE_DEPTH = 0.00012  # the score line is a shallow groove at rest
SEAL_DROP = 0.0035  # far end of the panel goes down this much at Seal = 1
TAB_LIFT, NOSE_DIP = math.radians(75), math.radians(10)
TAB_HINGE_Y = -0.0018  # tab bends just behind the rivet
TAB_Z = (LID_Z + 0.0003, LID_Z + 0.00075)  # tab underside, top

# Profile (radius, z) in mm from the bottom dome's edge to the lid panel; the wall is inserted between.
_BOTTOM = [(3, 9.35), (6, 8.9), (9, 8.1), (12, 7.0), (15, 5.6), (18, 4.0), (20.5, 2.7), (22.2, 1.7),
           (23.2, 0.8), (24.0, 0.2), (25.0, 0.0), (26.0, 0.25), (27.5, 1.1), (29.5, 2.6), (31.3, 4.5),
           (32.5, 6.7), (32.95, 8.6)]
_TOP = [(32.9, 109.6), (32.3, 111.5), (31.1, 113.4), (29.9, 115.3), (29.0, 117.0), (28.6, 118.3),
        (28.8, 119.5), (28.95, 120.6), (28.6, 121.6), (27.9, 122.0), (27.2, 121.7), (26.85, 120.9),
        (26.6, 119.4), (26.35, 117.6), (26.05, 116.1), (25.6, 115.45), (25.05, 115.6), (24.65, 116.3),
        (24.5, 117.2)]
_BOTTOM_POLE_Z = 0.0095


def _panel_radius(theta: np.ndarray) -> np.ndarray:
    """Teardrop outline of the score panel, in polar form around PANEL_C: narrow towards the rivet."""
    a, b, k = 0.0085, 0.0078, 0.14
    ellipse = 1.0 / np.sqrt((np.cos(theta) / a) ** 2 + (np.sin(theta) / b) ** 2)
    return ellipse * (1 + k * np.sin(theta))


class _Mesh:
    """Vertices, faces and per-face part tags collected before building the bmesh."""

    def __init__(self) -> None:
        self.verts: list[np.ndarray] = []
        self.faces: list[tuple[list[int], str]] = []
        self.n = 0

    def add(self, pts: np.ndarray) -> np.ndarray:
        pts = np.atleast_2d(pts)
        self.verts.append(pts)
        idx = np.arange(self.n, self.n + len(pts))
        self.n += len(pts)
        return idx

    def bridge(self, a: np.ndarray, b: np.ndarray, part: str) -> None:
        """Quads between two loops of equal length; normal = (a[j+1]-a[j]) x (b[j]-a[j])."""
        for j in range(len(a)):
            k = (j + 1) % len(a)
            self.faces.append(([a[j], a[k], b[k], b[j]], part))

    def fan(self, loop: np.ndarray, pole: int, part: str) -> None:
        for j in range(len(loop)):
            self.faces.append(([loop[j], loop[(j + 1) % len(loop)], pole], part))


def _ring(r: float, z: float, theta: np.ndarray) -> np.ndarray:
    return np.stack([r * np.cos(theta), r * np.sin(theta), np.full_like(theta, z)], axis=1)


def _body(m: _Mesh) -> dict[str, np.ndarray]:
    """Revolve the profile and close the lid with the score panel; returns vertex index sets."""
    theta = 2 * np.pi * np.arange(SEGMENTS) / SEGMENTS
    wall_z = np.linspace(*WALL, WALL_RINGS)
    profile = [(r / 1000, z / 1000, "bottom") for r, z in _BOTTOM]
    profile += [(RADIUS, z, "wall") for z in wall_z]
    profile += [(r / 1000, z / 1000, "top") for r, z in _TOP]
    pole = m.add(np.array([0.0, 0.0, _BOTTOM_POLE_Z]))[0]
    rings = [(m.add(_ring(r, z, theta)), part) for r, z, part in profile]
    m.fan(rings[0][0], pole, "bottom")
    for (a, pa), (b, pb) in zip(rings, rings[1:]):
        m.bridge(a, b, "wall" if pa == pb == "wall" else "metal")
    m.faces[:SEGMENTS] = [(f[::-1], p) for f, p in m.faces[:SEGMENTS]]  # bottom fan faces down

    # Lid: interpolate from the lid edge (around the origin) to the score loop (around PANEL_C).
    rho = _panel_radius(theta)
    edge = rings[-1][0]
    lid_pts = _ring(LID_R, LID_Z, theta)
    score = np.column_stack([PANEL_C + rho[:, None] * np.column_stack([np.cos(theta), np.sin(theta)]),
                             np.full(SEGMENTS, LID_Z - SCORE_DEPTH)])
    prev = edge
    for t in np.linspace(0, 1, 12)[1:]:
        pts = lid_pts * (1 - t) + score * t
        pts[:, 2] = LID_Z if t < 1 else LID_Z - SCORE_DEPTH
        cur = m.add(pts)
        m.bridge(prev, cur, "lid")
        prev = cur
    score_idx = prev
    panel = []
    for s in (1 - SCORE_GAP / rho.min(), 0.7, 0.4):
        pts = score.copy()
        pts[:, 2] = LID_Z
        pts[:, :2] = PANEL_C + (score[:, :2] - PANEL_C) * s
        cur = m.add(pts)
        m.bridge(prev, cur, "score" if prev is score_idx else "lid")
        panel.append(cur)
        prev = cur
    centre = m.add(np.array([*PANEL_C, LID_Z]))[0]
    m.fan(prev, centre, "lid")
    wall = np.concatenate([idx for idx, part in rings if part == "wall"])
    return {"wall": wall, "panel": np.concatenate([*panel, [centre]]), "score": score_idx}


def _tab_outline(phi: np.ndarray, hole: np.ndarray) -> np.ndarray:
    """Radius from the finger-hole centre to the tab outline (hull of two circles) at angles ``phi``."""
    circles = [((0.0, -0.0093), 0.0062), ((0.0, 0.0030), 0.0045)]
    t = np.linspace(0, 2 * np.pi, 720, endpoint=False)[:, None]
    (c1, r1), (c2, r2) = circles
    s = np.linspace(0, 1, 40)[None, :]  # points with equal outward normals span the hull
    x = (c1[0] + r1 * np.cos(t)) * (1 - s) + (c2[0] + r2 * np.cos(t)) * s
    y = (c1[1] + r1 * np.sin(t)) * (1 - s) + (c2[1] + r2 * np.sin(t)) * s
    pts = np.column_stack([x.ravel(), y.ravel()])
    d = pts - hole
    ang, rad = np.arctan2(d[:, 1], d[:, 0]), np.hypot(d[:, 0], d[:, 1])
    bins = np.linspace(-np.pi, np.pi, 361)
    which = np.digitize(ang, bins)
    far = np.array([rad[which == i].max() for i in range(1, len(bins))])  # convex hull in polar form
    mids = (bins[:-1] + bins[1:]) / 2
    return np.interp(np.mod(phi + np.pi, 2 * np.pi) - np.pi, mids, far, period=2 * np.pi)


def _tab(m: _Mesh) -> np.ndarray:
    """The tab: a plate with a finger hole around ``hole``, nose over the panel, rivet head at the origin."""
    n = 32
    phi = 2 * np.pi * np.arange(n) / n
    hole = np.array([0.0, -0.0096])
    d = np.column_stack([np.cos(phi), np.sin(phi)])
    outer = hole + _tab_outline(phi, hole)[:, None] * d
    inner = hole + d * np.array([0.0042, 0.0034])
    start = m.n
    top, bot = [], []
    for t, bead in zip(np.linspace(0, 1, 4), (-0.0002, 0.0003, 0.0003, -0.0001)):  # curled edges
        xy = outer * (1 - t) + inner * t
        top.append(m.add(np.column_stack([xy, np.full(n, TAB_Z[1] + bead)])))
        bot.append(m.add(np.column_stack([xy, np.full(n, TAB_Z[0])])))
    for k in range(3):
        m.bridge(top[k], top[k + 1], "tab")
        m.bridge(bot[k + 1], bot[k], "tab")
    m.bridge(bot[0], top[0], "tab")
    m.bridge(top[-1], bot[-1], "tab")
    # Rivet head: a small closed dome sitting on the tab.
    ang = 2 * np.pi * np.arange(16) / 16
    base = m.add(_ring(0.0017, TAB_Z[1] + 0.0002, ang))
    mid = m.add(_ring(0.0012, TAB_Z[1] + 0.0007, ang))
    m.bridge(base, mid, "tab")
    m.fan(mid, m.add(np.array([0, 0, TAB_Z[1] + 0.0009]))[0], "tab")
    m.fan(base[::-1], m.add(np.array([0, 0, TAB_Z[1] + 0.0002]))[0], "tab")
    return np.arange(start, m.n)


def _rotate_x(pts: np.ndarray, y0: float, z0: float, angle: np.ndarray) -> np.ndarray:
    """Rotate points about the line (y = y0, z = z0) parallel to x; positive angles lift +y."""
    out = pts.copy()
    dy, dz = pts[:, 1] - y0, pts[:, 2] - z0
    c, s = np.cos(angle), np.sin(angle)
    out[:, 1] = y0 + dy * c - dz * s
    out[:, 2] = z0 + dy * s + dz * c
    return out


def build_can() -> bpy.types.Object:
    """Build the can mesh, its UVs, materials, "side_wall" group and Basis/Seal/Tab keys; link it."""
    from deformsim.blender.part.materials import can_materials

    m = _Mesh()
    groups = _body(m)
    tab = _tab(m)
    co = np.concatenate(m.verts)

    bm = bmesh.new()
    verts = [bm.verts.new(p) for p in co]
    bm.verts.ensure_lookup_table()
    uv = bm.loops.layers.uv.new("UVMap")
    wall_lo, wall_h = WALL[0], WALL[1] - WALL[0]
    for idx, part in m.faces:
        f = bm.faces.new([verts[i] for i in idx])
        f.smooth = True
        us = [(math.atan2(lp.vert.co.y, lp.vert.co.x) / (2 * math.pi)) % 1 for lp in f.loops]
        for loop, u in zip(f.loops, us):
            if part == "wall":
                if max(us) - u > 0.5:  # the face that closes the loop: u runs 63/64 -> 1
                    u += 1
                loop[uv].uv = (u, (loop.vert.co.z - wall_lo) / wall_h)
            else:  # planar top view: fine for lid, tab and bottom, unused by the aluminium
                loop[uv].uv = (0.5 + loop.vert.co.x / HEIGHT, 0.5 + loop.vert.co.y / HEIGHT)
    mesh = bpy.data.meshes.new("Can")
    bm.to_mesh(mesh)
    bm.free()
    mesh.set_sharp_from_angle(angle=math.radians(40))
    _crease_score(mesh, groups)
    obj = bpy.data.objects.new("Can", mesh)
    bpy.context.scene.collection.objects.link(obj)
    obj.vertex_groups.new(name="side_wall").add(groups["wall"].tolist(), 1.0, "REPLACE")
    obj.shape_key_add(name="Basis", from_mix=False)
    _key(obj, "Seal", co, groups["panel"], _seal(co[groups["panel"]]))
    _key(obj, "Tab", co, tab, _tab_open(co[tab]))
    can_materials(obj)  # slot 0 "Label" on the side wall, slot 1 "Aluminium" elsewhere
    slots = np.array([0 if part == "wall" else 1 for _, part in m.faces], np.int32)
    mesh.polygons.foreach_set("material_index", slots)
    return obj


def _crease_score(mesh: bpy.types.Mesh, groups: dict[str, np.ndarray]) -> None:
    """Mark the score line and the panel edge sharp: they crease once the panel is pushed in."""
    ev = np.empty(len(mesh.edges) * 2, np.int32)
    mesh.edges.foreach_get("vertices", ev)
    ev = ev.reshape(-1, 2)
    loops = (groups["score"], groups["panel"][:SEGMENTS])
    mask = np.any([np.isin(ev, loop).all(axis=1) for loop in loops], axis=0)
    sharp = np.empty(len(mesh.edges), bool)
    mesh.edges.foreach_get("use_edge_sharp", sharp)
    mesh.edges.foreach_set("use_edge_sharp", sharp | mask)


def _seal(pts: np.ndarray) -> np.ndarray:
    """Panel hinged on its rivet-side edge, far end pushed down SEAL_DROP."""
    hinge = pts[:, 1].min()
    angle = -math.asin(SEAL_DROP / (pts[:, 1].max() - hinge))
    return _rotate_x(pts, hinge, LID_Z, np.full(len(pts), angle))


def _tab_open(pts: np.ndarray) -> np.ndarray:
    """Ring end lifted TAB_LIFT about the rivet line, nose dipped NOSE_DIP onto the panel."""
    angle = np.where(pts[:, 1] < TAB_HINGE_Y, -TAB_LIFT, -NOSE_DIP)
    return _rotate_x(pts, TAB_HINGE_Y, TAB_Z[0], angle)


def _key(obj: bpy.types.Object, name: str, co: np.ndarray, idx: np.ndarray, moved: np.ndarray) -> None:
    key = obj.shape_key_add(name=name, from_mix=False)
    pts = co.copy()
    pts[idx] = moved
    key.data.foreach_set("co", pts.astype(np.float32).ravel())
