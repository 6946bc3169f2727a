"""Finding and importing the engine's Python module (`flare`, built into build/python) from
inside Blender, whose Python 3.11 is Debian's /usr/bin/python3's."""

import os
import sys

_ADDON_DIR = os.path.dirname(os.path.abspath(__file__))
# Where the add-on zip carries the module (scripts/blender-addon.py copies it there).
BUNDLED_DIR = os.path.join(_ADDON_DIR, "engine")


class FlareInputError(Exception):
    """A problem with the Blender scene or the add-on's settings, said in the user's terms; the
    operator reports it in Blender's report area and writes nothing."""


def module_dirs(preference_dir=""):
    """The folders searched for the module, first match wins: the add-on preference, the
    environment variable FLARE_PYTHON_PATH, the copy bundled in the add-on."""
    dirs = []
    if preference_dir:
        dirs.append(os.path.abspath(os.path.expanduser(preference_dir)))
    for d in os.environ.get("FLARE_PYTHON_PATH", "").split(os.pathsep):
        if d:
            dirs.append(os.path.abspath(d))
    dirs.append(BUNDLED_DIR)
    return dirs


def import_flare(preference_dir=""):
    if "flare" in sys.modules:
        return sys.modules["flare"]
    searched = module_dirs(preference_dir)
    for d in searched:
        if os.path.isdir(d) and any(n.startswith("flare.") and n.endswith(".so") for n in os.listdir(d)):
            if d not in sys.path:
                sys.path.insert(0, d)
            # The bundled lens library travels beside the bundled module.
            library = os.path.join(_ADDON_DIR, "lenses", "library")
            if d == BUNDLED_DIR and os.path.isdir(library) and "FLARE_LENS_PATH" not in os.environ:
                os.environ["FLARE_LENS_PATH"] = library
            import flare  # noqa: E402  (found now)
            return flare
    raise FlareInputError(
        "cannot find the flare engine's Python module (flare.cpython-*.so); searched: "
        + ", ".join(searched)
        + ". Build it (scripts/build.sh) and set the add-on preference 'Engine module folder' "
        "to the build's python folder, or set FLARE_PYTHON_PATH")
