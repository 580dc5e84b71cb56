"""deformsim: synthetic deformation datasets from CAD + expert specs, and models trained on them."""

__version__ = "0.1.0"
