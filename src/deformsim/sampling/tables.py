"""The lookup tables the draws pick from: area light geometry, surface colours, brand words, cut sides, can sizes."""

from __future__ import annotations

# Geometry of each kind of area light (built-in can, metres/degrees): size, aspect (height/width), distance,
# elevation. A ring sits just behind one of the sample's cameras, on its axis, instead (see draw_lights).
LIGHT_KINDS = {
    "softbox": {"size": (0.25, 0.5), "aspect": (0.5, 1.0), "distance": (0.5, 0.9), "elevation": (20.0, 65.0)},
    "ring": {"size": (0.12, 0.25), "aspect": (1.0, 1.0), "distance": (1.02, 1.2), "elevation": (-4.0, 4.0)},
    "window": {"size": (0.8, 1.5), "aspect": (0.6, 1.5), "distance": (1.5, 3.0), "elevation": (0.0, 25.0)},
    "overhead": {"size": (0.6, 1.2), "aspect": (0.5, 1.0), "distance": (0.7, 1.2), "elevation": (75.0, 90.0)},
}

# Colour ranges (HSV) per surface kind: wood browns, white to cream paper, grey concrete, steel, any cloth, black rubber.
SURFACE_COLOURS = {
    "wood": {"hue": (0.04, 0.11), "saturation": (0.35, 0.75), "value": (0.25, 0.75), "roughness": (0.35, 0.7)},
    "paper": {"hue": (0.0, 1.0), "saturation": (0.0, 0.12), "value": (0.7, 0.95), "roughness": (0.85, 1.0)},
    "concrete": {"hue": (0.05, 0.15), "saturation": (0.0, 0.12), "value": (0.3, 0.7), "roughness": (0.85, 1.0)},
    "metal": {"hue": (0.0, 1.0), "saturation": (0.0, 0.05), "value": (0.55, 0.9), "roughness": (0.2, 0.45)},
    "cloth": {"hue": (0.0, 1.0), "saturation": (0.1, 0.8), "value": (0.15, 0.85), "roughness": (0.9, 1.0)},
    "conveyor": {"hue": (0.0, 1.0), "saturation": (0.0, 0.15), "value": (0.03, 0.15), "roughness": (0.55, 0.85)},
    "photo": {"hue": (0.0, 0.0), "saturation": (0.0, 0.0), "value": (0.8, 1.2), "roughness": (0.4, 0.9)},
}

BRAND_WORDS = ("FIZZ", "COLA", "ZEST", "NOVA", "LIME", "BOLT", "AURA", "PEAK", "WAVE", "SODA", "BREW", "MAX")

CUT_SIDES = ("left", "right", "top", "bottom")

# The built-in can's named sizes (config.CAN_SIZES): nominal body diameter and height (mm, real cans), rim radius over
# body radius (the neck's taper: slim and sleek cans have nearly flush ends), neck height and dome depth factors.
# standard355 is the can as built (66.0 x 122.0 mm); every size is mapped by its ratios to standard355's nominal.
CAN_SIZES = {
    "slim250": {"diameter": 53.0, "height": 134.0, "rim": 0.94, "neck": 0.7, "dome": 1.0},
    "sleek330": {"diameter": 58.0, "height": 146.0, "rim": 0.93, "neck": 0.75, "dome": 1.0},
    "standard330": {"diameter": 66.0, "height": 115.0, "rim": 0.8773, "neck": 1.0, "dome": 1.0},
    "standard355": {"diameter": 66.2, "height": 122.2, "rim": 0.8773, "neck": 1.0, "dome": 1.0},
    "tall473": {"diameter": 66.0, "height": 157.0, "rim": 0.8773, "neck": 1.0, "dome": 1.0},
    "tall500": {"diameter": 66.0, "height": 168.0, "rim": 0.8773, "neck": 1.0, "dome": 1.0},
    "tall568": {"diameter": 66.0, "height": 184.0, "rim": 0.8773, "neck": 1.0, "dome": 1.0},
}
