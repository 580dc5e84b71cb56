"""The bank of physically simulated deformations: baked once per spec, mesh and solver settings, cached."""
