"""autorig: automatic rigging of 3D characters.

    import autorig
    result = autorig.rig("hero.obj", "biped")      # -> autorig.Rig
    result.joints, result.names, result.parents, result.weights
    result = autorig.skin("hero.obj", "my_rig.glb")  # weights only, for your own skeleton

Nothing heavy is imported here: the command line must start fast, so numpy, scipy, trimesh and libigl load
only when a rig is actually computed.
"""
from .version import __version__

__all__ = ["rig", "Rig", "RigOptions", "skin", "SkinOptions", "AutorigError", "__version__"]


def __getattr__(name):
    if name in ("rig", "RigOptions", "skin", "SkinOptions"):
        from . import pipeline
        return getattr(pipeline, name)
    if name == "Rig":
        from .result import Rig
        return Rig
    if name == "AutorigError":
        from .errors import AutorigError
        return AutorigError
    raise AttributeError(f"module 'autorig' has no attribute {name!r}")
