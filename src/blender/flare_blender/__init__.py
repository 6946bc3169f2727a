"""Lens flare for Blender: the physically based flare of the scene's camera and lamps through a
real lens prescription, rendered by the flare engine's Python module and added over the render
(docs/blender.md). units.py and camera.py need no Blender (tests/blender/test_units.py imports
them with Debian's python3); the rest is imported when Blender registers the add-on."""

bl_info = {
    "name": "Lens Flare (flare engine)",
    "author": "flare developers",
    "version": (1, 0, 0),
    "blender": (3, 4, 0),
    "location": "Properties > Output > Lens Flare",
    "description": "Physically based lens flare of the camera and lamps, added over the render",
    "category": "Render",
}

_modules = []


def register():
    import importlib
    from . import props, operators, ui
    _modules[:] = [importlib.reload(m) for m in (props, operators, ui)]
    for m in _modules:
        m.register()


def unregister():
    for m in reversed(_modules):
        m.unregister()
    _modules.clear()
