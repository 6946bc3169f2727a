#!/usr/bin/env python3
"""Runs tests/blender/blender_addon_test.py in Blender, headless, on the add-on zip built from this
tree (scripts/blender-addon.py). Exits 77 (ctest: skipped) with a message where Blender is absent.

Usage: run_blender_test.py --build BUILD --cli BUILD/src/flare --out DIR [--docs-images DIR]
Environment: BLENDER, the program to run (default: blender on PATH).
"""
import argparse
import os
import shutil
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE_DIR = os.path.dirname(os.path.dirname(HERE))
SKIP = 77


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--build", required=True)
    ap.add_argument("--cli", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--docs-images", default="")
    args = ap.parse_args()
    blender = os.environ.get("BLENDER") or shutil.which("blender")
    if not blender:
        print("SKIPPED: Blender is not installed, so the add-on's headless test cannot run "
              "(scripts/setup.sh installs it: apt-get install --no-install-recommends blender; "
              "or set BLENDER to the program)")
        return SKIP
    if os.path.isdir(args.out):
        shutil.rmtree(args.out)
    os.makedirs(args.out)
    zip_path = os.path.join(args.out, "flare_blender.zip")
    subprocess.run([sys.executable, os.path.join(SOURCE_DIR, "scripts", "blender-addon.py"),
                    "--build", args.build, "--output", zip_path], check=True)
    env = dict(os.environ)
    env.pop("FLARE_PYTHON_PATH", None)  # the add-on must find the engine the zip carries
    command = [blender, "-b", "--factory-startup", "--python-exit-code", "1",
               "--python", os.path.join(HERE, "blender_addon_test.py"), "--",
               "--zip", zip_path, "--cli", args.cli, "--out", args.out]
    if args.docs_images:
        command += ["--docs-images", args.docs_images]
    return subprocess.run(command, env=env).returncode


if __name__ == "__main__":
    sys.exit(main())
