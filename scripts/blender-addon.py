#!/usr/bin/env python3
"""Builds the Blender add-on's installable zip (Edit > Preferences > Add-ons > Install...):
src/blender/flare_blender/ and, unless --no-engine, the engine's Python module from the build
(BUILD/python/flare.cpython-*.so and flare.pyi, into flare_blender/engine/) with the lens library
and the glass catalogues (lenses/library and lenses/glass, into flare_blender/lenses/), so that the add-on runs on a machine with the
same Debian libraries without a build tree.

Usage: scripts/blender-addon.py [--build build] [--output build/flare_blender.zip] [--no-engine]
"""
import argparse
import glob
import os
import sys
import tempfile
import zipfile

SOURCE_DIR = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PACKAGE = "flare_blender"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--build", default=os.path.join(SOURCE_DIR, "build"))
    ap.add_argument("--output", default=None, help="zip to write (default: BUILD/flare_blender.zip)")
    ap.add_argument("--no-engine", action="store_true",
                    help="the add-on's Python files only (the engine module is found through the "
                         "add-on preference or FLARE_PYTHON_PATH)")
    args = ap.parse_args()
    output = args.output or os.path.join(args.build, "flare_blender.zip")
    files = []  # (path on disk, path in the zip)
    package_dir = os.path.join(SOURCE_DIR, "src", "blender", PACKAGE)
    for name in sorted(os.listdir(package_dir)):
        if name.endswith(".py"):
            files.append((os.path.join(package_dir, name), f"{PACKAGE}/{name}"))
    if not args.no_engine:
        modules = glob.glob(os.path.join(args.build, "python", "flare.cpython-*.so"))
        if len(modules) != 1:
            sys.exit(f"blender-addon: expected one engine module in {args.build}/python, found "
                     f"{len(modules)} (build it first: scripts/build.sh; or --no-engine)")
        files.append((modules[0], f"{PACKAGE}/engine/{os.path.basename(modules[0])}"))
        stubs = os.path.join(args.build, "python", "flare.pyi")
        if os.path.exists(stubs):
            files.append((stubs, f"{PACKAGE}/engine/flare.pyi"))
        # The library and, beside it where the engine looks for them, the makers' glass catalogues
        # (src/flare/optics/AgfCatalog.h).
        for folder in ("library", "glass"):
            top = os.path.join(SOURCE_DIR, "lenses", folder)
            for root, _, names in os.walk(top):
                for name in sorted(names):
                    path = os.path.join(root, name)
                    files.append((path, f"{PACKAGE}/lenses/{folder}/{os.path.relpath(path, top)}"))
    # All or nothing: the zip is written beside its target and moved into place when complete.
    folder = os.path.dirname(os.path.abspath(output))
    os.makedirs(folder, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=".flare_blender.", suffix=".zip", dir=folder)
    os.close(fd)
    try:
        with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
            for disk, arc in files:
                z.write(disk, arc)
        os.replace(tmp, output)
    except BaseException:
        os.unlink(tmp)
        raise
    print(f"blender-addon: wrote {output} ({len(files)} files, {os.path.getsize(output) / 1e6:.1f} MB)")


if __name__ == "__main__":
    main()
