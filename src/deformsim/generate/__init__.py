"""The generate stage: input checks and orchestration (:mod:`.stage`), render backends (:mod:`.local`,
:mod:`.ray`, sharing :mod:`.backend`), the Blender worker client and the mesh probe. Never imports bpy."""
