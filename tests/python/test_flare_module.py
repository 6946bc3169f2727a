"""The Python module `flare` against the CLI it mirrors: lens data, ghost tables, previews, renders
and comparisons equal the CLI's JSON and EXR output value for value and bit for bit.

Run by ctest with PYTHONPATH holding the built module and FLARE_CLI the built `flare` program;
by hand: PYTHONPATH=build/python FLARE_CLI=build/src/flare python3 tests/python/test_flare_module.py
"""
import json
import os
import subprocess
import tempfile
import threading
import time
import unittest

import numpy as np

import flare

SOURCE_DIR = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CLI = os.environ.get("FLARE_CLI", os.path.join(SOURCE_DIR, "build", "src", "flare"))

# The default scene at 96 x 64 pixels (the sensor's 3:2), so that every image here takes moments.
WIDTH_PX, HEIGHT_PX = 96, 64
# Two passes of the render (65 536 photons each): the fewest a render runs.
RENDER_PHOTONS = 100_000


def run_cli(*arguments):
    """The CLI's standard output; a failure shows its standard error."""
    result = subprocess.run([CLI, *arguments], capture_output=True, text=True)
    if result.returncode != 0:
        raise AssertionError(f"flare {' '.join(arguments)} exited with {result.returncode}: {result.stderr}")
    return result.stdout


def small_scene_text():
    scene = json.loads(flare.default_scene_text())
    scene["sensor"]["resolution"] = [WIDTH_PX, HEIGHT_PX]
    return json.dumps(scene, indent=2)


class FlareModuleTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.scratch = tempfile.TemporaryDirectory(prefix="pyflare-")
        cls.scene_path = os.path.join(cls.scratch.name, "small.json")
        with open(cls.scene_path, "w", encoding="utf-8") as handle:
            handle.write(small_scene_text())
        cls.scene = flare.load_scene(cls.scene_path)

    @classmethod
    def tearDownClass(cls):
        cls.scratch.cleanup()

    def scratch_path(self, name):
        return os.path.join(self.scratch.name, name)

    def assertImagesEqual(self, images, expected):
        """Same layer names, and every layer equal bit for bit (a per-ghost Footprint: over the same
        window of the same frame)."""
        self.assertEqual(sorted(images), sorted(expected))
        for name, image in images.items():
            with self.subTest(layer=name):
                other = expected[name]
                self.assertEqual(type(image), type(other))
                if isinstance(image, flare.Footprint):
                    self.assertEqual((image.x, image.y, image.frame_size), (other.x, other.y, other.frame_size))
                    image, other = image.rgb, other.rgb
                self.assertEqual(image.dtype, np.float32)
                self.assertEqual(image.shape, other.shape)
                self.assertTrue(np.array_equal(image.view(np.uint32), other.view(np.uint32)),
                                f"layer {name!r} differs from the CLI's")

    # Lenses.

    def test_lens_info_and_paraxial_data_equal_the_cli(self):
        lens = flare.load_lens("double-gauss-50mm", f_number=4.0)
        expected = json.loads(run_cli("lens", "info", "double-gauss-50mm", "--f-number", "4", "--json"))
        self.assertEqual(lens.info(), expected)
        paraxial = lens.paraxial()
        for key in ("efl_mm", "bfl_mm", "front_focal_distance_mm", "image_distance_mm", "entrance_pupil_z_mm",
                    "entrance_pupil_diameter_mm", "exit_pupil_z_mm", "exit_pupil_diameter_mm", "f_number",
                    "working_f_number", "field_of_view_deg", "total_track_mm"):
            self.assertEqual(getattr(paraxial, key), expected[key], key)
        self.assertAlmostEqual(paraxial.f_number, 4.0, places=2)
        self.assertEqual(lens.surface_count, expected["surfaces"])

    def test_a_lens_loads_by_path_shipped_name_pbrt_file_and_library_id(self):
        by_name = flare.load_lens("double-gauss-50mm")
        by_path = flare.load_lens(os.path.join(SOURCE_DIR, "lenses", "double-gauss-50mm.lens"))
        self.assertEqual(by_path.paraxial().efl_mm, by_name.paraxial().efl_mm)
        pbrt = flare.load_lens(os.path.join(SOURCE_DIR, "tests", "data", "dgauss.50mm.dat"))
        self.assertAlmostEqual(pbrt.paraxial().efl_mm, 50.0, delta=2.0)
        names = flare.lens_names()
        self.assertIn("double-gauss-50mm", names)
        with open(os.path.join(SOURCE_DIR, "lenses", "library", "index.json"), encoding="utf-8") as handle:
            library_id = json.load(handle)["lenses"][0]["id"]
        self.assertIn(library_id, names)
        self.assertGreater(flare.load_lens(library_id).paraxial().efl_mm, 0.0)
        zoom = flare.load_lens("zoom-24-70mm", zoom="50")
        self.assertAlmostEqual(zoom.paraxial().efl_mm, 50.0, delta=2.0)

    # Ghost tables.

    def test_the_ghost_table_of_a_lens_equals_the_cli(self):
        lens = flare.load_lens("double-gauss-50mm", f_number=4.0)
        report = lens.ghost_report(field_deg=[5.0, 3.0], all=True)
        expected = json.loads(run_cli("ghosts", "double-gauss-50mm", "--f-number", "4", "--field-deg", "5,3",
                                      "--all", "--json"))
        self.assertEqual(report, expected)
        self.assertEqual(len(report["ghosts"]), report["enumerated"])
        self.assertEqual(lens.ghosts(field_deg=[5.0, 3.0], all=True), expected["ghosts"])

    def test_the_ghost_table_of_a_scene_equals_the_cli(self):
        report = self.scene.ghost_report(wavelength_nm=600.0)
        expected = json.loads(run_cli("ghosts", self.scene_path, "--wavelength", "600", "--json"))
        self.assertEqual(report, expected)
        kept = report["ghosts"]
        self.assertTrue(kept and not any(g["pruned"] for g in kept))
        powers = [g["power_fraction"] for g in kept]
        self.assertEqual(powers, sorted(powers, reverse=True))

    # Images.

    def test_the_preview_equals_the_cli_bit_for_bit(self):
        images = flare.preview(self.scene, layers=True)
        exr = self.scratch_path("preview.exr")
        run_cli("preview", self.scene_path, "-o", exr, "--layers", "--float-layers", "--quiet")
        expected = flare.read_exr(exr)
        self.assertEqual(images[""].shape, (HEIGHT_PX, WIDTH_PX, 3))
        self.assertIn("direct", images)
        self.assertIn("starburst", images)
        self.assertIn("ghost", images)
        self.assertGreater(len(images), 4)  # per-ghost layers
        self.assertImagesEqual(images, expected)
        self.assertGreater(float(images["ghost"].sum()), 0.0)

    def test_per_ghost_layers_are_footprints_that_add_up_to_the_ghost_layer(self):
        """Each per-ghost layer covers the bounding box of its pixels; with layers="top:3" the three
        strongest keep theirs and ghost_other holds the rest: the sums equal the ghost layer to float
        rounding, as in the CLI's EXR."""
        every = flare.preview(self.scene, layers=True, diffraction=False)
        top = flare.preview(self.scene, layers="top:3", diffraction=False)
        exr = self.scratch_path("preview-top3.exr")
        run_cli("preview", self.scene_path, "-o", exr, "--layers", "top:3", "--float-layers", "--quiet",
                "--no-diffraction")
        self.assertImagesEqual(top, flare.read_exr(exr))
        ghosts = {name: layer for name, layer in every.items() if name.startswith("ghost_")}
        kept = sorted(name for name in top if name.startswith("ghost_") and name != "ghost_other")
        self.assertEqual(len(kept), 3)
        self.assertIn("ghost_other", top)
        for images, names in ((every, ghosts), (top, kept + ["ghost_other"])):
            total = np.zeros((HEIGHT_PX, WIDTH_PX, 3), dtype=np.float64)
            for name in names:
                layer = images[name]
                self.assertIsInstance(layer, flare.Footprint)
                self.assertEqual(layer.frame_size, (WIDTH_PX, HEIGHT_PX))
                whole = np.asarray(layer)
                self.assertTrue(np.array_equal(whole, layer.full()))
                window = whole[layer.y:layer.y + layer.height, layer.x:layer.x + layer.width]
                self.assertTrue(np.array_equal(window, layer.rgb))
                outside = whole.copy()
                outside[layer.y:layer.y + layer.height, layer.x:layer.x + layer.width] = 0.0
                self.assertFalse(outside.any())
                lit = np.any(layer.rgb != 0, axis=2)  # the window is the lit pixels' bounding box
                self.assertTrue(lit[0].any() and lit[-1].any() and lit[:, 0].any() and lit[:, -1].any())
                total += whole
            # Each pixel is a sum of float32 conversions of the same double sums: within a few
            # float ulps of the pixel's magnitude per layer.
            reference = images["ghost"].astype(np.float64)
            tolerance = 4 * len(names) * np.finfo(np.float32).eps * np.abs(reference).max()
            self.assertLess(float(np.abs(total - reference).max()), tolerance)
        with self.assertRaisesRegex(ValueError, "top:N"):
            flare.preview(self.scene, layers="top:0")
        with self.assertRaises(TypeError):
            flare.preview(self.scene, layers=3)

    def test_the_scene_key_ghost_ringing_reaches_the_preview_as_the_cli_flag_does(self):
        text = json.loads(small_scene_text())
        text.setdefault("render", {})["ghost_ringing"] = False
        scene = flare.parse_scene(text)
        self.assertFalse(scene.ghost_ringing)
        self.assertTrue(self.scene.ghost_ringing)
        images = flare.preview(scene, layers=True)
        exr = self.scratch_path("preview-no-ringing.exr")
        run_cli("preview", self.scene_path, "-o", exr, "--layers", "--float-layers", "--quiet", "--no-ghost-ringing")
        self.assertImagesEqual(images, flare.read_exr(exr))
        ringing = flare.preview(self.scene, layers=True)
        self.assertFalse(np.array_equal(ringing["ghost"], images["ghost"]))
        # The ripples move power across the rims and make none.
        self.assertAlmostEqual(float(ringing["ghost"].sum() / images["ghost"].sum()), 1.0, delta=1e-3)

    def test_the_preview_without_diffraction_equals_the_cli_bit_for_bit(self):
        images = flare.preview(self.scene, layers=True, diffraction=False)
        exr = self.scratch_path("preview-geometric.exr")
        run_cli("preview", self.scene_path, "-o", exr, "--layers", "--float-layers", "--quiet", "--no-diffraction")
        self.assertNotIn("starburst", images)
        self.assertImagesEqual(images, flare.read_exr(exr))

    def test_the_render_equals_the_cli_bit_for_bit_whatever_the_threads(self):
        images = flare.render(self.scene, photons=RENDER_PHOTONS, seed=7, threads=1, layers=True)
        exr = self.scratch_path("render.exr")
        run_cli("render", self.scene_path, "-o", exr, "--photons", str(RENDER_PHOTONS), "--seed", "7",
                "--threads", "2", "--layers", "--quiet")
        expected = flare.read_exr(exr)
        for name in ("", "direct", "ghost", "higher", "scatter", "starburst", "variance"):
            self.assertIn(name, images)
        self.assertImagesEqual(images, expected)
        self.assertGreater(float(images["ghost"].sum()), 0.0)
        self.assertGreater(float(images["variance"].sum()), 0.0)

    def test_compare_equals_the_cli_for_files_and_arrays(self):
        """The preview at f/4 against the one at f/5.6 (smaller ghosts)."""
        stopped_down = json.loads(small_scene_text())
        stopped_down["f_number"] = 5.6
        stopped_down_path = self.scratch_path("stopped-down.json")
        with open(stopped_down_path, "w", encoding="utf-8") as handle:
            json.dump(stopped_down, handle)
        a_exr, b_exr = self.scratch_path("compare-a.exr"), self.scratch_path("compare-b.exr")
        run_cli("preview", stopped_down_path, "-o", a_exr, "--layers", "--quiet")
        run_cli("preview", self.scene_path, "-o", b_exr, "--layers", "--quiet")
        for layer in ("", "ghost"):
            with self.subTest(layer=layer):
                expected = json.loads(run_cli("compare", a_exr, b_exr, "--layer", layer, "--json"))
                for key in ("a", "b", "layer"):
                    del expected[key]
                self.assertGreater(expected["rel_l2"], 0.0)
                self.assertEqual(flare.compare(a_exr, b_exr, layer=layer), expected)
                arrays = flare.compare(flare.read_exr(a_exr)[layer], flare.read_exr(b_exr)[layer])
                self.assertEqual(arrays, expected)
        self.assertEqual(flare.compare(a_exr, a_exr)["max_abs_diff"], 0.0)

    # Errors and threads.

    def test_engine_errors_become_python_exceptions_with_the_engine_message(self):
        with self.assertRaisesRegex(ValueError, "no-such-lens"):
            flare.load_lens("no-such-lens")
        with self.assertRaisesRegex(ValueError, "missing.json"):
            flare.load_scene(self.scratch_path("missing.json"))
        broken = small_scene_text().replace('"power": 1.0', '"power": -1.0')
        with self.assertRaisesRegex(ValueError, r"broken\.json:\d+: .*power"):
            flare.parse_scene(broken, file_name="broken.json")
        with self.assertRaisesRegex(ValueError, r"f/0\.5 is not available"):
            flare.load_lens("double-gauss-50mm", f_number=0.5)
        with self.assertRaisesRegex(ValueError, "mode"):
            flare.render(self.scene, photons=1, mode="magic")
        with self.assertRaises(IndexError):
            self.scene.ghost_report(light=3)
        with self.assertRaisesRegex(ValueError, "no such image file"):
            flare.read_exr(self.scratch_path("missing.exr"))
        with self.assertRaisesRegex(ValueError, "shape"):
            flare.compare(np.zeros((4, 4)), np.zeros((4, 4)))

    def test_the_gil_is_released_while_the_engine_works(self):
        """Python keeps running beside a preview: the longest pause of a loop in this thread is far
        shorter than the preview (it would last the whole preview if the engine held the GIL)."""
        scene = json.loads(small_scene_text())
        scene["sensor"]["resolution"] = [6 * WIDTH_PX, 6 * HEIGHT_PX]
        scene = flare.parse_scene(json.dumps(scene))
        done = threading.Event()
        timing = {}

        def work():
            start = time.perf_counter()
            flare.preview(scene)
            timing["preview_s"] = time.perf_counter() - start
            done.set()

        worker = threading.Thread(target=work)
        worker.start()
        longest_gap_s, last = 0.0, time.perf_counter()
        while not done.is_set():
            now = time.perf_counter()
            longest_gap_s, last = max(longest_gap_s, now - last), now
        worker.join()
        self.assertLess(longest_gap_s, 0.5 * timing["preview_s"])


if __name__ == "__main__":
    unittest.main(verbosity=2)
