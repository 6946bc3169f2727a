"""The thesis's bounce-limit study (scripts/thesis.sh step 2, docs/thesis.md) adds up.

Four small renders of the thesis's zoom, uncoated, with a black interior (every path specular), with
--max-bounces 2, 5, 10 and unbounded: the flare's power is non-decreasing in the limit, and what the
limits from 2 up add is the unbounded render's `higher` layer (less the 2-limit render's own), both
within the renders' standard errors (z-tests at 1e-3, scripts/thesis_tools.py bounce_checks). The
limit must matter: the unbounded `higher` layer lies many standard errors above the 2-limit's. And
the check itself catches a study that does not add up (higher-order light counted as ghost light,
a limit's power lowered).

The renders are unguided (`--mode naive`, the thesis's method): every layer then obeys the limit,
and no ghost analysis is paid for (about 10 s of CPU in all).

Run by ctest with FLARE_CLI the built `flare` program; by hand:
FLARE_CLI=build/src/flare python3 tests/python/test_thesis_bounces.py
"""
import copy
import os
import shutil
import subprocess
import sys
import tempfile
import unittest

SOURCE_DIR = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CLI = os.environ.get("FLARE_CLI", os.path.join(SOURCE_DIR, "build", "src", "flare"))
sys.path.insert(0, os.path.join(SOURCE_DIR, "scripts"))
import thesis_tools  # noqa: E402

PHOTONS = 1_500_000
LIMITS = (2, 5, 10, -1)


class BounceLimits(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.folder = tempfile.mkdtemp(prefix="flare-thesis-bounces-")
        scene = os.path.join(cls.folder, "scene.json")
        subprocess.run([sys.executable, os.path.join(SOURCE_DIR, "scripts", "thesis_tools.py"), "scene", scene,
                        "--zoom", "mid", "--field", "3,2", "--f-number", "4", "--coating", "none",
                        "--resolution", "48,32"], check=True)
        cls.reports = []
        for k in LIMITS:
            report = f"bounces{k}.json"
            result = subprocess.run(
                [CLI, "render", scene, "-o", os.path.join(cls.folder, f"bounces{k}.exr"), "--report",
                 os.path.join(cls.folder, report), "--mode", "naive", "--photons", str(PHOTONS),
                 "--target-error", "0", "--max-bounces", str(k), "--interior-albedo", "0", "--no-diffraction",
                 "--seed", str(10 + len(cls.reports)), "--quiet"], capture_output=True, text=True)
            if result.returncode != 0:
                raise AssertionError(f"flare render exited with {result.returncode}: {result.stderr}")
            cls.reports.append(f"{'unbounded' if k < 0 else k}={report}")
        cls.rows = thesis_tools.bounce_rows(cls.folder, cls.reports)

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.folder, ignore_errors=True)

    def layer(self, limit, name):
        return next(layers for k, layers, _ in self.rows if k == limit)[name]

    def test_the_layers_add_up(self):
        self.assertEqual(thesis_tools.bounce_checks(self.rows), [])

    def test_the_limit_matters(self):
        # Without the limit the study would add up trivially: the unbounded render's higher-order
        # light must stand far above the 2-limit render's (which holds only what TIR or a path the
        # enumeration does not name carries in two reflections).
        h2, s2 = self.layer(2, "higher")
        hinf, sinf = self.layer(-1, "higher")
        self.assertGreater(hinf - h2, 6.0 * (s2 ** 2 + sinf ** 2) ** 0.5)
        # Uncoated, the order-2 ghosts dominate: the same in every render within their errors.
        g2, sg2 = self.layer(2, "ghost")
        ginf, sginf = self.layer(-1, "ghost")
        self.assertLess(abs(g2 - ginf), 3.29 * (sg2 ** 2 + sginf ** 2) ** 0.5)
        self.assertEqual(self.layer(-1, "scatter")[0], 0.0)  # a black interior scatters nothing

    def test_the_check_catches_a_study_that_does_not_add_up(self):
        # The unbounded render's higher-order light counted as ghost light (a layer classification
        # that ignores the number of reflections): its flare power is the same, but its `higher`
        # layer no longer holds what the limits add.
        rows = copy.deepcopy(self.rows)
        for k, layers, _ in rows:
            if k == -1:
                layers["ghost"] = (layers["ghost"][0] + layers["higher"][0], layers["ghost"][1])
                layers["higher"] = (0.0, layers["higher"][1])
        self.assertTrue(any("add" in p for p in thesis_tools.bounce_checks(rows)))
        # The 10-limit render with its higher-order light gone: the power falls from 5 to 10.
        rows = copy.deepcopy(self.rows)
        for k, layers, _ in rows:
            if k == 10:
                layers["higher"] = (0.0, layers["higher"][1])
                layers["ghost"] = (0.9 * layers["ghost"][0], layers["ghost"][1])
        self.assertTrue(any("falls" in p for p in thesis_tools.bounce_checks(rows)))


if __name__ == "__main__":
    unittest.main()
