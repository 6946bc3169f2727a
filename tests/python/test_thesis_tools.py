"""scripts/thesis_tools.py's own pieces (docs/thesis.md): its PNG tone curve is the CLI's (pixel for
pixel against a PNG `flare preview` wrote, decoded here with every PNG row filter), the overlay is
frame + flare exactly, and the final check refuses a missing file and a non-finite number.

Run by ctest with PYTHONPATH holding the built module and FLARE_CLI the built `flare` program.
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile
import unittest
import zlib

import numpy as np

import flare

SOURCE_DIR = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CLI = os.environ.get("FLARE_CLI", os.path.join(SOURCE_DIR, "build", "src", "flare"))
TOOLS = os.path.join(SOURCE_DIR, "scripts", "thesis_tools.py")
sys.path.insert(0, os.path.join(SOURCE_DIR, "scripts"))
import thesis_tools  # noqa: E402


def read_png_rgb8(path):
    """An 8-bit RGB PNG's pixels (every row filter of the PNG specification undone)."""
    with open(path, "rb") as f:
        data = f.read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, idat, width, height = 8, b"", 0, 0
    while pos < len(data):
        n = int.from_bytes(data[pos:pos + 4], "big")
        kind, body = data[pos + 4:pos + 8], data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            width, height = int.from_bytes(body[0:4], "big"), int.from_bytes(body[4:8], "big")
            assert body[8] == 8 and body[9] == 2, "8-bit RGB expected"
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    raw = zlib.decompress(idat)
    stride, bpp = width * 3, 3
    out = np.zeros((height, stride), dtype=np.int64)
    prev = np.zeros(stride, dtype=np.int64)
    for y in range(height):
        kind = raw[y * (stride + 1)]
        line = np.frombuffer(raw, dtype=np.uint8, count=stride, offset=y * (stride + 1) + 1).astype(np.int64)
        cur = np.zeros(stride, dtype=np.int64)
        for x in range(stride):
            a = cur[x - bpp] if x >= bpp else 0
            b = prev[x]
            c = prev[x - bpp] if x >= bpp else 0
            if kind == 0:
                p = 0
            elif kind == 1:
                p = a
            elif kind == 2:
                p = b
            elif kind == 3:
                p = (a + b) // 2
            else:
                pa, pb, pc = abs(b - c), abs(a - c), abs(a + b - 2 * c)
                p = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
            cur[x] = (line[x] + p) % 256
        out[y] = cur
        prev = cur
    return out.reshape(height, width, 3).astype(np.uint8)


class ThesisTools(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.folder = tempfile.mkdtemp(prefix="flare-thesis-tools-")
        cls.scene = os.path.join(cls.folder, "scene.json")
        subprocess.run([sys.executable, TOOLS, "scene", cls.scene, "--zoom", "wide", "--field", "6,4",
                        "--resolution", "48,32"], check=True)
        cls.exr = os.path.join(cls.folder, "preview.exr")
        cls.png = os.path.join(cls.folder, "preview.png")
        cls.stops = 9.5
        subprocess.run([CLI, "preview", cls.scene, "-o", cls.exr, "--png", cls.png, "--exposure", str(cls.stops),
                        "--quiet"], check=True, capture_output=True)

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.folder, ignore_errors=True)

    def test_tone_curve_is_the_clis(self):
        main = np.asarray(flare.read_exr(self.exr)[""], dtype=np.float64)
        ours = thesis_tools.tone_map(main, self.stops).astype(np.int64)
        theirs = read_png_rgb8(self.png).astype(np.int64)
        # The EXR holds half floats of what the CLI tone-mapped in single or double precision: one
        # 8-bit step of rounding difference at most, and on few pixels.
        self.assertLessEqual(np.abs(ours - theirs).max(), 1)
        self.assertLess(np.mean(ours != theirs), 0.05)
        # The picture is not trivial: a range of levels, the light's core clipped to white.
        self.assertGreater(len(np.unique(theirs)), 50)

    def test_png_writer_round_trips(self):
        rng = np.random.default_rng(30)
        pixels = rng.integers(0, 256, size=(7, 11, 3), dtype=np.uint8)
        path = os.path.join(self.folder, "round.png")
        thesis_tools.write_png(path, pixels)
        np.testing.assert_array_equal(read_png_rgb8(path), pixels)

    def test_overlay_is_frame_plus_flare(self):
        out_exr = os.path.join(self.folder, "overlay.exr")
        subprocess.run([sys.executable, TOOLS, "overlay", "--scene", self.scene, "--flare-exr", self.exr,
                        "--out-exr", out_exr, "--out-png", os.path.join(self.folder, "overlay.png"),
                        "--frame-png", os.path.join(self.folder, "frame.png")], check=True)
        images = flare.read_exr(out_exr)
        flare_main = np.asarray(flare.read_exr(self.exr)[""], dtype=np.float64)
        np.testing.assert_array_equal(np.asarray(images["flare"], dtype=np.float64), flare_main)
        frame = np.asarray(images["frame"], dtype=np.float64)
        self.assertGreater(frame.min(), 0.0)  # a sky and a ground everywhere, no hole
        # The EXR stores what was summed: frame + flare, to float rounding.
        np.testing.assert_allclose(np.asarray(images[""], dtype=np.float64), frame + flare_main, rtol=1e-6, atol=0)

    def check(self, manifest):
        return subprocess.run([sys.executable, TOOLS, "check", manifest], capture_output=True, text=True)

    def test_check_refuses_a_missing_file_and_a_non_finite_number(self):
        folder = os.path.join(self.folder, "run")
        os.makedirs(folder, exist_ok=True)
        good = os.path.join(folder, "good.exr")
        flare.write_exr(good, {"": np.ones((4, 6, 3), dtype=np.float32)})
        manifest = os.path.join(folder, "manifest.json")

        def write(outputs):
            with open(manifest, "w") as f:
                json.dump({"results": [{"id": "a", "figure": "", "caption": "", "command": "", "wall_s": 1.0,
                                        "outputs": outputs, "photons": None, "estimated_error": None}]}, f)

        write(["good.exr"])
        self.assertEqual(self.check(manifest).returncode, 0)
        write(["good.exr", "missing.png"])
        r = self.check(manifest)
        self.assertEqual(r.returncode, 2)
        self.assertIn("missing.png was not written", r.stderr)
        # A report holding a NaN (the Python module refuses to write a NaN into an EXR, so the
        # report stands for the non-finite output; the EXR branch is the same np.isfinite test).
        with open(os.path.join(folder, "bad.json"), "w") as f:
            f.write('{"photons": 10, "layers": {"ghost": {"power_w": NaN}}}')
        write(["good.exr", "bad.json"])
        r = self.check(manifest)
        self.assertEqual(r.returncode, 2)
        self.assertIn("not finite", r.stderr)


if __name__ == "__main__":
    unittest.main()
