"""The Blender side, run inside worker processes, grouped by kind:

- ``part/``: the part: the built-in can and its label, a user's mesh, materials and creases;
- ``scene/``: the world, area lights, the sun, cameras and the ground (shadow catcher, textured surface);
- ``motion/``: the deformation rig, the pose, drops onto the ground and the cloth simulation of the bank;
- ``passes/``: rendering one sample and its dense ground truth;
- :mod:`~deformsim.blender.feature` and :mod:`~deformsim.blender.features`: the seam of optional render features
  and their set-up from the registry (:mod:`deformsim.sampling.features`); :mod:`~deformsim.blender.cycles`: the
  empty scene and Cycles settings;
- :mod:`~deformsim.blender.worker` and :mod:`~deformsim.blender.bake`: the two process entry points.

Only modules of this package import ``bpy``; they are loaded by ``python -m deformsim.blender.worker``
(see :mod:`deformsim.generate.worker_client`), never by the CLI or the test process.
"""
