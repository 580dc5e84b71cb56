"""The Blender side: scene, deformation rig, world, cameras and rendering, run inside worker processes.

Only modules of this package import ``bpy``; they are loaded by ``python -m deformsim.blender.worker``
(see :mod:`deformsim.generate.worker_client`), never by the CLI or the test process.
"""
