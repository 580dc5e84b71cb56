"""The generate stage: what a dataset is made from (:mod:`.identity`), refusals of bad or conflicting output
(:mod:`.refusals`), the run (:mod:`.stage`), render backends (:mod:`.local`,
:mod:`.ray`, sharing :mod:`.backend`), the Blender worker client and the mesh probe. Never imports bpy."""
