"""The scene around the part: the HDRI world, area lights, cameras and the ground under the part."""
