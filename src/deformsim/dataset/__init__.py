"""A dataset's files and tables: layout, manifest, image variants, photo folders, training tables, contact sheets.

Import-light on purpose (the Blender worker imports :mod:`deformsim.dataset.layout`): nothing is imported here.
"""
