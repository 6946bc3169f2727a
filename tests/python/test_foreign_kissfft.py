"""The starburst does not change when the host process already holds another KissFFT: a library
exporting kiss_fft, kiss_fft_alloc, kiss_fft_stride... (libcodec2, which Blender loads through FFmpeg)
is loaded into the global symbol scope before the module, and the preview's starburst must still
equal the CLI's bit for bit (src/flare/wave/KissFft.h). Exits 77 (skipped) where no such library
is installed.

PYTHONPATH=build/python FLARE_CLI=build/src/flare python3 tests/python/test_foreign_kissfft.py
"""
import ctypes
import ctypes.util
import glob
import json
import os
import subprocess
import sys
import tempfile

SKIP = 77


def foreign_kissfft():
    """A shared library other than KissFFT's own that defines kiss_fft_alloc (which libkissfft's
    kiss_fftnd calls through the global scope)."""
    candidates = glob.glob("/usr/lib/*/libcodec2.so*") + glob.glob("/usr/lib/libcodec2.so*")
    name = ctypes.util.find_library("codec2")
    if name:
        candidates.insert(0, name)
    for c in candidates:
        try:
            lib = ctypes.CDLL(c, mode=ctypes.RTLD_GLOBAL)
        except OSError:
            continue
        if hasattr(lib, "kiss_fft_alloc"):
            return c
    return None


def main():
    path = foreign_kissfft()
    if path is None:
        print("SKIPPED: no library with its own KissFFT (libcodec2) is installed")
        return SKIP
    import flare  # after the foreign library, as inside Blender
    import numpy as np
    cli = os.environ.get("FLARE_CLI", "build/src/flare")
    scene = json.loads(flare.default_scene_text())
    scene["sensor"]["resolution"] = [96, 64]
    with tempfile.TemporaryDirectory(prefix="flare-kissfft-") as tmp:
        scene_path = os.path.join(tmp, "scene.json")
        with open(scene_path, "w") as f:
            json.dump(scene, f)
        exr = os.path.join(tmp, "cli.exr")
        subprocess.run([cli, "preview", scene_path, "-o", exr, "--layers"], check=True,
                       capture_output=True)
        ours = flare.preview(flare.load_scene(scene_path), layers=True)
        theirs = flare.read_exr(exr)
    a, b = np.asarray(ours["starburst"]), np.asarray(theirs["starburst"])
    if a.tobytes() != b.tobytes():
        print(f"FAIL: with {path} loaded first the starburst differs from the CLI's by up to "
              f"{np.abs(a - b).max():.3g} (peak {b.max():.3g})")
        return 1
    print(f"ok: with {path} loaded first the starburst equals the CLI's bit for bit")
    return 0


if __name__ == "__main__":
    sys.exit(main())
