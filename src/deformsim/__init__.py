"""deformsim: synthetic deformation datasets from CAD + expert specs, and models trained on them.

``from deformsim import Engine`` gives the pipeline as a Python API (see :mod:`deformsim.api`).
"""

from deformsim.version import __version__

__all__ = ["Engine", "__version__"]


def __getattr__(name: str):
    if name == "Engine":  # loaded on first use, so `import deformsim.cli` stays light
        from deformsim.api import Engine

        return Engine
    raise AttributeError(f"module 'deformsim' has no attribute {name!r}")
