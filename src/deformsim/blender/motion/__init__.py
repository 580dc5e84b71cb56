"""How the part moves: the deformation rig, the pose, a drop onto the ground and the cloth simulation of the bank."""
