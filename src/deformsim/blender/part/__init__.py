"""The part: the built-in can and its printed label, a user's imported mesh, materials and the crease layer."""
