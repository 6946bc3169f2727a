"""What a Python user expects of the module beyond the CLI's images (issue 28, item 7): the render's
report equal to `flare render --report`'s, a progress callback, checkpoints and resume, scenes from a
dict with settable fields, arguments checked as the CLI checks them, warnings through `warnings`, an
EXR writer, the lens library with its metadata, __version__, docstrings and type stubs.

Run by ctest with PYTHONPATH holding the built module (and its flare.pyi) and FLARE_CLI the built
`flare` program; by hand: PYTHONPATH=build/python FLARE_CLI=build/src/flare python3 tests/python/test_python_api.py
"""
import ast
import copy
import json
import math
import os
import re
import subprocess
import sys
import tempfile
import unittest
import warnings

import numpy as np

import flare

SOURCE_DIR = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CLI = os.environ.get("FLARE_CLI", os.path.join(SOURCE_DIR, "build", "src", "flare"))

WIDTH_PX, HEIGHT_PX = 96, 64
PHOTONS_PER_PASS = 262_144  # a guided render's pass: kGuidedBatchesPerPass (SceneRender.h) batches of 1024


def run_cli(*arguments):
    result = subprocess.run([CLI, *arguments], capture_output=True, text=True)
    if result.returncode != 0:
        raise AssertionError(f"flare {' '.join(arguments)} exited with {result.returncode}: {result.stderr}")
    return result.stdout


def small_scene_dict():
    scene = json.loads(flare.default_scene_text())
    scene["sensor"]["resolution"] = [WIDTH_PX, HEIGHT_PX]
    return scene


def without_timings(report):
    """The report without what measures time (wall time, rates, the starburst's seconds)."""
    report = copy.deepcopy(report)
    for key in ("wall_time_s", "photons_per_second"):
        del report[key]
    for light in report.get("diffraction", {}).get("lights", []):
        light.pop("seconds", None)
    return report


class PythonApiTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.scratch = tempfile.TemporaryDirectory(prefix="pyflare-api-")
        cls.scene_path = os.path.join(cls.scratch.name, "small.json")
        with open(cls.scene_path, "w", encoding="utf-8") as handle:
            json.dump(small_scene_dict(), handle, indent=2)
        cls.scene = flare.load_scene(cls.scene_path)

    @classmethod
    def tearDownClass(cls):
        cls.scratch.cleanup()

    def scratch_path(self, name):
        return os.path.join(self.scratch.name, name)

    def assertImagesEqual(self, images, expected):
        self.assertEqual(sorted(images), sorted(expected))
        for name in images:
            with self.subTest(layer=name):
                # (Per-ghost layers are Footprints: compared over the whole frame.)
                a, b = np.asarray(images[name], dtype=np.float32), np.asarray(expected[name], dtype=np.float32)
                self.assertTrue(np.array_equal(a.view(np.uint32), b.view(np.uint32)),
                                f"layer {name!r} differs")

    # The render's report, progress and checkpoints.

    def test_the_render_report_equals_the_clis_but_for_timings(self):
        photons = 3 * PHOTONS_PER_PASS
        result = flare.render(self.scene, photons=photons, seed=3)
        report_path = self.scratch_path("report.json")
        run_cli("render", self.scene_path, "-o", self.scratch_path("report.exr"), "--photons", str(photons),
                "--seed", "3", "--report", report_path, "--quiet")
        with open(report_path, encoding="utf-8") as handle:
            expected = json.load(handle)
        # The scene label is the file it came from in both.
        self.assertEqual(result.report["scene"], self.scene_path)
        self.assertEqual(without_timings(result.report), without_timings(expected))
        self.assertEqual(result.report["passes"], 3)
        self.assertGreater(result.report["wall_time_s"], 0.0)
        self.assertTrue(result.report["ghosts"])
        # The result still reads as the dict of images render returned.
        self.assertIn("", result)
        self.assertEqual(result[""].shape, (HEIGHT_PX, WIDTH_PX, 3))
        self.assertEqual(sorted(result), sorted(result.images))
        self.assertEqual(len(result), len(result.images))
        self.assertIsInstance(result, __import__("collections.abc").abc.Mapping)
        self.assertIsNone(result.get("no-such-layer"))
        with self.assertRaises(KeyError):
            result["no-such-layer"]

    def test_scatter_splits_is_the_clis_scatter_splits(self):
        photons = 2 * PHOTONS_PER_PASS
        split_twice = flare.render(self.scene, photons=photons, seed=4, scatter_splits=2)
        report_path = self.scratch_path("splits.json")
        run_cli("render", self.scene_path, "-o", self.scratch_path("splits.exr"), "--photons", str(photons),
                "--seed", "4", "--scatter-splits", "2", "--report", report_path, "--quiet")
        with open(report_path, encoding="utf-8") as handle:
            self.assertEqual(without_timings(split_twice.report), without_timings(json.load(handle)))
        # The argument reaches the tracer: the default (8 directions) scatters the same light otherwise.
        default = flare.render(self.scene, photons=photons, seed=4)
        self.assertFalse(np.array_equal(split_twice["scatter"], default["scatter"]))
        for refused in (0, 18):
            with self.assertRaisesRegex(ValueError, r"scatter_splits: in \[1, 17\]"):
                flare.render(self.scene, photons=1, scatter_splits=refused)

    def test_the_progress_callback_sees_every_pass_and_can_stop_the_render(self):
        seen = []
        result = flare.render(self.scene, photons=5 * PHOTONS_PER_PASS, seed=2, progress=seen.append)
        self.assertEqual([p["passes"] for p in seen], list(range(1, 6)))
        # (The first three passes are nominal; the adaptive pass plan sizes the later ones' photons.)
        self.assertEqual([p["photons"] for p in seen][:3], [k * PHOTONS_PER_PASS for k in range(1, 4)])
        self.assertIsNone(seen[0]["estimated_error"])  # one pass: no spread to estimate from
        self.assertGreater(seen[-1]["estimated_error"], 0.0)
        self.assertEqual(seen[-1]["estimated_error"], result.report["flare_estimated_relative_error"])
        self.assertEqual(seen[-1]["fraction"], 1.0)  # the photon limit is reached
        for p in seen:
            self.assertGreaterEqual(p["fraction"], 0.0)
            self.assertLessEqual(p["fraction"], 1.0)
            self.assertEqual(p["target_error"], 0.02)

        stopped = flare.render(self.scene, photons=5 * PHOTONS_PER_PASS, seed=2,
                               progress=lambda p: p["passes"] < 3)
        self.assertEqual(stopped.report["passes"], 3)

        class Stop(Exception):
            pass

        def fail(progress):
            raise Stop()

        with self.assertRaises(Stop):
            flare.render(self.scene, photons=5 * PHOTONS_PER_PASS, progress=fail)
        with self.assertRaisesRegex(ValueError, "progress"):
            flare.render(self.scene, photons=1, progress=42)

    def test_an_interrupted_render_resumes_from_its_checkpoint_to_the_clis_image(self):
        checkpoint = self.scratch_path("resume.checkpoint")
        photons = 4 * PHOTONS_PER_PASS

        def interrupt_after_two(progress):
            if progress["passes"] == 2:
                raise KeyboardInterrupt

        with self.assertRaises(KeyboardInterrupt):
            flare.render(self.scene, photons=photons, seed=5, checkpoint=checkpoint, progress=interrupt_after_two)
        self.assertTrue(os.path.isfile(checkpoint))
        passes = []
        resumed = flare.render(self.scene, photons=photons, seed=5, checkpoint=checkpoint,
                               progress=lambda p: passes.append(p["passes"]))
        self.assertEqual(passes, [3, 4])  # the first two came from the checkpoint
        self.assertEqual(resumed.report["passes"], 4)  # (--photons counts nominal passes)
        exr = self.scratch_path("resume.exr")
        run_cli("render", self.scene_path, "-o", exr, "--photons", str(photons), "--seed", "5", "--quiet")
        self.assertImagesEqual(resumed, flare.read_exr(exr))
        # A checkpoint of another render is refused with the engine's reason.
        with self.assertRaisesRegex(ValueError, "resume.checkpoint"):
            flare.render(self.scene, photons=photons, seed=6, checkpoint=checkpoint)

    def test_ctrl_c_stops_a_render_with_keyboard_interrupt_and_keeps_a_checkpoint(self):
        import signal
        import threading
        checkpoint = self.scratch_path("ctrl-c.checkpoint")
        timer = threading.Timer(1.0, lambda: os.kill(os.getpid(), signal.SIGINT))
        timer.start()
        try:
            with self.assertRaises(KeyboardInterrupt):
                flare.render(self.scene, photons=10**12, target_error=0.0, checkpoint=checkpoint)
        finally:
            timer.cancel()
        self.assertTrue(os.path.isfile(checkpoint))

    # Scenes.

    def test_a_scene_from_a_dict_equals_the_scene_from_its_text(self):
        from_dict = flare.parse_scene(small_scene_dict())
        from_text = flare.parse_scene(json.dumps(small_scene_dict()))
        for key in ("lens_name", "resolution", "f_number", "photons", "seed", "light_names", "sensor_size_mm"):
            self.assertEqual(getattr(from_dict, key), getattr(from_text, key), key)
        self.assertImagesEqual(flare.preview(from_dict), flare.preview(from_text))
        broken = small_scene_dict()
        broken["lights"][0]["power"] = -1
        with self.assertRaisesRegex(ValueError, r"lights\[0\]\.power"):
            flare.parse_scene(broken, file_name="broken")
        with self.assertRaises(TypeError):
            flare.parse_scene(42)

    def test_scene_fields_are_settable_and_checked_as_the_scene_file_checks_them(self):
        scene = flare.default_scene()
        scene.resolution = (WIDTH_PX, HEIGHT_PX)
        scene.f_number = 5.6
        scene.seed = 11
        scene.photons = 123_456
        scene.description = "set from Python"
        self.assertEqual((scene.width_px, scene.height_px), (WIDTH_PX, HEIGHT_PX))
        self.assertEqual(flare.preview(scene)[""].shape, (HEIGHT_PX, WIDTH_PX, 3))
        # The same scene written as a file gives the same preview.
        as_file = small_scene_dict()
        as_file["f_number"] = 5.6
        self.assertImagesEqual(flare.preview(scene, seed=11), flare.preview(flare.parse_scene(as_file), seed=11))
        self.assertAlmostEqual(scene.lens().paraxial().f_number, 5.6, places=2)
        for field, value, message in (("f_number", 0.1, r"f_number: in \[0\.5, 128\]"),
                                      ("resolution", (0, 10), r"resolution"),
                                      ("resolution", (100, 100), r"not square"),
                                      ("photons", 0, r"photons"),
                                      ("seed", -1, r"seed: an integer in \[0, 2\*\*64\)"),
                                      ("beams_per_pass", 8, r"beams_per_pass"),
                                      ("ghost_order", 3, r"ghost_order"),
                                      ("lens_name", "no-such-lens", r"no-such-lens"),
                                      ("zoom", -4, r"zoom")):
            with self.subTest(field=field, value=value):
                with self.assertRaisesRegex(ValueError, message):
                    setattr(scene, field, value)
        self.assertEqual(scene.f_number, 5.6)  # a refused value changes nothing
        scene.sensor_size_mm = (24.0, 24.0)
        scene.resolution = (64, 64)  # square pixels again
        copied = scene.copy()
        copied.f_number = 8.0
        self.assertEqual(scene.f_number, 5.6)

    def test_a_zoom_is_a_number_or_a_name(self):
        by_number = flare.load_lens("zoom-24-70mm", zoom=50)
        by_text = flare.load_lens("zoom-24-70mm", zoom="50")
        self.assertEqual(by_number.paraxial().efl_mm, by_text.paraxial().efl_mm)
        self.assertEqual(flare.load_lens("zoom-24-70mm", zoom=50.0).paraxial().efl_mm, by_text.paraxial().efl_mm)
        scene = flare.default_scene()
        scene.lens_name = "zoom-24-70mm"
        scene.f_number = None
        scene.zoom = 50
        self.assertEqual(scene.zoom, "50")
        self.assertEqual(scene.lens().paraxial().efl_mm, by_text.paraxial().efl_mm)
        with self.assertRaises(TypeError):
            flare.load_lens("zoom-24-70mm", zoom=True)

    # Arguments checked as the CLI checks them.

    def test_arguments_the_cli_refuses_raise_value_error_naming_them(self):
        lens = flare.load_lens("double-gauss-50mm")
        for wavelength in (-5.0, 0.0, 299.0, 2001.0, math.nan):
            with self.subTest(wavelength=wavelength):
                with self.assertRaisesRegex(ValueError, r"wavelength_nm: in \[300, 2000\] nm"):
                    lens.paraxial(wavelength)
                with self.assertRaisesRegex(ValueError, r"wavelength_nm"):
                    lens.info(wavelength_nm=wavelength)
        self.assertGreater(lens.paraxial(300.0).efl_mm, 0.0)
        with self.assertRaisesRegex(ValueError, r"threads: 0 \(all cores\) or a positive number"):
            flare.preview(self.scene, threads=-3)
        with self.assertRaisesRegex(ValueError, r"threads: 0 \(all cores\) or a positive number"):
            flare.render(self.scene, photons=1, threads=-3)
        with self.assertRaisesRegex(ValueError, r"seed: an integer in \[0, 2\*\*64\), got -1"):
            flare.render(self.scene, photons=1, seed=-1)
        with self.assertRaisesRegex(ValueError, r"seed: an integer in \[0, 2\*\*64\), got -1"):
            flare.preview(self.scene, seed=-1)
        with self.assertRaisesRegex(ValueError, r"seed"):
            flare.render(self.scene, photons=1, seed=2**64)
        with self.assertRaisesRegex(TypeError, r"seed: an integer"):
            flare.render(self.scene, photons=1, seed="1")
        with self.assertRaisesRegex(ValueError, r"beam_replicates"):
            flare.render(self.scene, photons=1, beam_replicates=1)
        for probes in (1, -1, 65):
            with self.assertRaisesRegex(ValueError, r"beam_probes: 0, or 2 to 64, got " + str(probes)):
                flare.render(self.scene, photons=1, beam_probes=probes)

    # Warnings.

    def zmx_with_an_unknown_keyword(self):
        path = self.scratch_path("warned.zmx")
        run_cli("lens", "export", "double-gauss-50mm", "-o", path)
        with open(path, encoding="utf-8") as handle:
            text = handle.read()
        with open(path, "w", encoding="utf-8") as handle:
            handle.write(text.replace("UNIT MM", "UNIT MM\r\nXYZZY 1", 1) if "UNIT MM" in text else "XYZZY 1\r\n" + text)
        return path

    def test_engine_warnings_are_python_warnings_not_stderr(self):
        path = self.zmx_with_an_unknown_keyword()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            flare.load_lens(path)
        messages = [str(w.message) for w in caught if issubclass(w.category, flare.FlareWarning)]
        self.assertTrue(any("XYZZY" in m and "warned.zmx:" in m for m in messages), messages)
        self.assertTrue(issubclass(flare.FlareWarning, UserWarning))
        with warnings.catch_warnings():
            warnings.simplefilter("error", flare.FlareWarning)
            with self.assertRaisesRegex(flare.FlareWarning, "XYZZY"):
                flare.load_lens(path)
        # Nothing on the process's stderr (a child, whose stderr is captured).
        child = subprocess.run([sys.executable, "-W", "ignore", "-c", f"import flare; flare.load_lens({path!r})"],
                               capture_output=True, text=True, env=os.environ)
        self.assertEqual(child.returncode, 0, child.stderr)
        self.assertEqual(child.stderr, "")

    def test_a_private_glass_catalogue_is_given_to_load_lens_and_scenes(self):
        agf = self.scratch_path("PYPRIVATE.agf")
        with open(agf, "w", encoding="utf-8") as handle:
            handle.write("NM PYPRIV-BK7 2 517642.251 1.5168 64.17 0 1\n"
                         "CD 1.039612120E+00 6.000698670E-03 2.317923440E-01 2.001791440E-02 1.010469450E+00 "
                         "1.035606530E+02 0 0\nLD 3.0E-01 2.5E+00\n")
        exported = self.scratch_path("bk7.zmx")
        run_cli("lens", "export", "double-gauss-50mm", "-o", exported)
        with open(exported, encoding="utf-8") as handle:
            text = handle.read()
        # Every glass of the exported lens by name in the private catalogue is not possible; one is enough:
        # the first glass line becomes the private N-BK7 twin, with the same indices as the built-in N-BK7.
        glass_line = next(line for line in text.splitlines() if line.strip().startswith("GLAS "))
        private = text.replace(glass_line, "  GLAS PYPRIV-BK7 0 0 1.5168 64.17 0 0 0 0 0 0", 1)
        bk7 = text.replace(glass_line, "  GLAS N-BK7 0 0 1.5168 64.17 0 0 0 0 0 0", 1)
        paths = {}
        for name, content in (("private.zmx", private), ("bk7-first.zmx", bk7)):
            paths[name] = self.scratch_path(name)
            with open(paths[name], "w", encoding="utf-8") as handle:
                handle.write(content)
        with self.assertRaisesRegex(ValueError, r"unknown glass 'PYPRIV-BK7'.*--glass-catalog"):
            flare.load_lens(paths["private.zmx"])
        lens = flare.load_lens(paths["private.zmx"], glass_catalog=agf)
        # The built-in N-BK7 and the catalogue's agree to the catalogue's digits.
        reference = flare.load_lens(paths["bk7-first.zmx"]).paraxial().efl_mm
        self.assertLess(abs(lens.paraxial().efl_mm - reference), 1e-9 * reference)
        self.assertEqual(flare.load_lens(paths["private.zmx"], glass_catalog=[agf]).paraxial().efl_mm,
                         lens.paraxial().efl_mm)
        with self.assertRaisesRegex(ValueError, "missing.agf"):
            flare.load_lens(paths["private.zmx"], glass_catalog=self.scratch_path("missing.agf"))
        scene = small_scene_dict()
        scene["lens"] = paths["private.zmx"]
        scene["glass_catalog"] = agf
        self.assertEqual(flare.parse_scene(scene).lens().paraxial().efl_mm, lens.paraxial().efl_mm)

    # Images.

    def test_write_exr_writes_what_read_exr_and_the_cli_read_back(self):
        images = flare.preview(self.scene, layers=True)
        path = self.scratch_path("written.exr")
        flare.write_exr(path, images, metadata={"comment": "from Python"})
        self.assertImagesEqual(flare.read_exr(path), images)
        self.assertEqual(flare.compare(path, images[""])["max_abs_diff"], 0.0)
        cli = json.loads(run_cli("compare", path, path, "--layer", "ghost", "--json"))
        self.assertEqual(cli["max_abs_diff"], 0.0)
        # Half precision where asked: within half's rounding of the floats (half an ulp: 2^-11 of the
        # value, or 2^-25 below half's smallest normal 2^-14). In W/m2 the ghosts lie below half's
        # range: scaled to a peak of 100 (what a compositor's exposure does) they fit.
        ghost = images["ghost"] * np.float32(100.0 / float(images["ghost"].max()))
        half_path = self.scratch_path("half.exr")
        flare.write_exr(half_path, {"": images[""], "ghost": ghost}, half_layers=["ghost"], compression="piz")
        back = flare.read_exr(half_path)
        self.assertTrue(np.array_equal(back[""], images[""]))
        scale = np.maximum(np.abs(ghost), 2.0**-14)
        self.assertLessEqual(float(np.max(np.abs(back["ghost"] - ghost) / scale)), 2.0**-11)
        self.assertGreater(float(np.max(np.abs(back["ghost"] - ghost))), 0.0)  # it was rounded
        with self.assertRaisesRegex(ValueError, r"half_layers: layer 'ghost' has values beyond"):
            flare.write_exr(half_path, {"": images[""], "ghost": images["ghost"]}, half_layers=["ghost"])
        bad = {"": np.full((4, 4, 3), np.nan, dtype=np.float32)}
        with self.assertRaisesRegex(ValueError, r"NaN"):
            flare.write_exr(self.scratch_path("bad.exr"), bad)
        self.assertFalse(os.path.exists(self.scratch_path("bad.exr")))
        with self.assertRaisesRegex(ValueError, r"one size"):
            flare.write_exr(self.scratch_path("bad.exr"), {"": np.zeros((4, 4, 3)), "b": np.zeros((2, 4, 3))})
        with self.assertRaisesRegex(ValueError, r"half_layers: no layer 'nope'"):
            flare.write_exr(self.scratch_path("bad.exr"), {"": np.zeros((4, 4, 3))}, half_layers=["nope"])

    # The library, the version, docstrings and stubs.

    def test_lens_list_and_search_equal_the_cli(self):
        listed = flare.lens_list(maker="Nikon", focal_mm=(70, 200), f_number=2.8)
        expected = json.loads(run_cli("lens", "list", "--maker", "Nikon", "--focal", "70-200", "--f-number", "2.8",
                                      "--json"))["lenses"]
        self.assertTrue(expected)
        self.assertEqual(listed, expected)
        self.assertEqual(flare.lens_list(focal_mm=50),
                         json.loads(run_cli("lens", "list", "--focal", "50", "--json"))["lenses"])
        self.assertEqual(flare.lens_list(focal_mm=(None, 20)),
                         json.loads(run_cli("lens", "list", "--focal", "-20", "--json"))["lenses"])
        self.assertEqual(flare.lens_search("70-200 2.8"),
                         json.loads(run_cli("lens", "search", "70-200", "2.8", "--json"))["lenses"])
        for key in ("id", "maker", "focal_length_mm", "focal_range_mm", "f_number", "patent", "file"):
            self.assertIn(key, listed[0])
        with self.assertRaisesRegex(ValueError, "focal_mm"):
            flare.lens_list(focal_mm=(200, 70))

    def test_the_version_is_the_projects(self):
        with open(os.path.join(SOURCE_DIR, "CMakeLists.txt"), encoding="utf-8") as handle:
            version = re.search(r"project\(flare VERSION ([0-9.]+)", handle.read()).group(1)
        self.assertEqual(flare.__version__, version)

    def test_every_public_name_has_a_docstring(self):
        for name in dir(flare):
            if name.startswith("_"):
                continue
            value = getattr(flare, name)
            with self.subTest(name=name):
                doc = getattr(value, "__doc__", None) or ""
                # pybind11 puts the signature first: there must be prose after it.
                self.assertGreater(len(re.sub(r"^\w+\(.*\) -> .*\n", "", doc).strip()), 10, name)
            if isinstance(value, type) and not issubclass(value, Warning):
                for member, attribute in vars(value).items():
                    if member.startswith("_") or not callable(attribute):
                        continue
                    with self.subTest(name=f"{name}.{member}"):
                        doc = attribute.__doc__ or ""
                        self.assertGreater(len(re.sub(r"^\w+\(.*\) -> .*\n", "", doc).strip()), 5)

    def test_the_type_stubs_describe_the_module(self):
        """flare.pyi lies beside the module, names what the module has and nothing else, with each
        function's parameters as the module's signatures give them."""
        stub_path = os.path.join(os.path.dirname(flare.__file__), "flare.pyi")
        self.assertTrue(os.path.isfile(stub_path), stub_path)
        with open(stub_path, encoding="utf-8") as handle:
            tree = ast.parse(handle.read())
        stub = {}
        for node in tree.body:
            if isinstance(node, ast.FunctionDef):
                stub[node.name] = node
            elif isinstance(node, ast.ClassDef):
                stub[node.name] = node
            elif isinstance(node, ast.AnnAssign):
                stub[node.target.id] = node
        module_names = {n for n in dir(flare) if not n.startswith("_")} | {"__version__"}
        self.assertEqual(module_names, set(stub) - {"Image"})

        def parameters(function):
            names = [a.arg for a in function.args.posonlyargs + function.args.args + function.args.kwonlyargs]
            return [n for n in names if n != "self"]

        def signature_parameters(doc):
            first = doc.splitlines()[0]
            inside = first[first.index("(") + 1:first.rindex(") ->")]
            names, depth, current = [], 0, ""
            for char in inside + ",":
                if char in "([{":
                    depth += 1
                elif char in ")]}":
                    depth -= 1
                if char == "," and depth == 0:
                    part = current.strip()
                    current = ""
                    if part and part != "*":
                        names.append(part.split(":")[0].split("=")[0].strip())
                    continue
                current += char
            return [n for n in names if n != "self"]

        for name, node in stub.items():
            if isinstance(node, ast.FunctionDef):
                with self.subTest(function=name):
                    self.assertEqual(parameters(node), signature_parameters(getattr(flare, name).__doc__))
            elif isinstance(node, ast.ClassDef) and not issubclass(getattr(flare, name), Warning):
                cls = getattr(flare, name)
                stub_members = set()
                for item in node.body:
                    if isinstance(item, ast.FunctionDef):
                        stub_members.add(item.name)
                        member = getattr(cls, item.name)
                        if callable(member) and not isinstance(member, property) and member.__doc__:
                            with self.subTest(method=f"{name}.{item.name}"):
                                self.assertEqual(parameters(item), signature_parameters(member.__doc__))
                    elif isinstance(item, ast.AnnAssign):
                        stub_members.add(item.target.id)
                public = {m for m in vars(cls) if not m.startswith("_") or m in ("__getitem__", "__contains__",
                          "__len__", "__iter__", "__copy__", "__deepcopy__")}
                with self.subTest(cls=name):
                    self.assertEqual(public, stub_members)


if __name__ == "__main__":
    unittest.main(verbosity=2)
