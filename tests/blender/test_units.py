"""The Blender add-on's pure-Python parts, without Blender (src/blender/flare_blender/units.py and
camera.py): the black-body fit against Planck's law integrated over the CIE 1931 table the engine
uses, the choice of spectrum for a lamp colour, and the camera arithmetic.

python3 tests/blender/test_units.py
"""
import math
import os
import re
import sys
import unittest

SOURCE_DIR = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(SOURCE_DIR, "src", "blender"))

from flare_blender import camera, units  # noqa: E402
from flare_blender.engine import FlareInputError  # noqa: E402


def cie_table():
    """x̄, ȳ, z̄ at 360..830 nm (1 nm) from the engine's copy of the CIE table."""
    text = open(os.path.join(SOURCE_DIR, "src", "flare", "core", "Cie1931Data.inc"), encoding="utf-8").read()
    text = re.sub(r"//[^\n]*", "", text)
    tables = []
    for name in ("kCieX", "kCieY", "kCieZ"):
        body = re.search(name + r"\[kCieCount\] = \{(.*?)\};", text, re.S).group(1)
        values = [float(v) for v in body.replace("\n", " ").split(",") if v.strip()]
        tables.append(values + [0.0] * (471 - len(values)))
    return tables


CMF = cie_table()


def planck(nm, t):
    h, c, k = 6.62607015e-34, 299792458.0, 1.380649e-23
    lam = nm * 1e-9
    return 1.0 / (lam ** 5 * (math.exp(h * c / (lam * k * t)) - 1.0))


def blackbody_xy(t):
    """Planck's law against the CIE 1931 observer, summed on the table's 1 nm steps."""
    x = y = z = 0.0
    for i in range(471):
        p = planck(360 + i, t)
        x += p * CMF[0][i]
        y += p * CMF[1][i]
        z += p * CMF[2][i]
    s = x + y + z
    return (x / s, y / s)


# Linear Rec.709 from XYZ (the inverse of units._RGB_TO_XYZ, IEC 61966-2-1).
XYZ_TO_RGB = ((3.2406, -1.5372, -0.4986), (-0.9689, 1.8758, 0.0415), (0.0557, -0.2040, 1.0570))


def rgb_of_xy(xy):
    x, y = xy
    xyz = (x / y, 1.0, (1.0 - x - y) / y)
    return tuple(sum(m * c for m, c in zip(row, xyz)) for row in XYZ_TO_RGB)


class PlanckianLocus(unittest.TestCase):
    def test_fit_follows_plancks_law(self):
        # Kim et al.'s cubic fit: its deviation from the integrated locus is below 1e-3 in xy
        # over its range (the fit's own specification, here checked at every 500 K step).
        for t in range(2000, 25001, 500):
            fx, fy = units.planckian_xy(t)
            ex, ey = blackbody_xy(t)
            self.assertLess(math.hypot(fx - ex, fy - ey), 1e-3, f"{t} K")

    def test_illuminant_a(self):
        # CIE illuminant A is a black body at 2856 K: xy (0.44757, 0.40745) (CIE 15:2004).
        ex, ey = blackbody_xy(2856)
        self.assertAlmostEqual(ex, 0.44757, delta=5e-5)
        self.assertAlmostEqual(ey, 0.40745, delta=5e-5)


class SpectrumForColour(unittest.TestCase):
    def test_white_is_d65(self):
        spectrum, duv = units.spectrum_for_colour((1.0, 1.0, 1.0))
        self.assertEqual(spectrum, "d65")
        # The 4-decimal Rec.709 matrix maps (1, 1, 1) to D65's xy within ~1e-4.
        self.assertLess(duv, 2e-4)

    def test_black_body_colours_come_back(self):
        for t in (1900.0, 2700.0, 3200.0, 4500.0, 9000.0):
            rgb = rgb_of_xy(blackbody_xy(t))
            spectrum, duv = units.spectrum_for_colour(rgb)
            self.assertIsInstance(spectrum, dict, f"{t} K gave {spectrum}")
            # The fit's 1e-3 in xy is at most ~1e-3 in uv; along the locus, 1 % in T moves xy by
            # less than that at these temperatures, so 3 % bounds the round trip.
            self.assertAlmostEqual(spectrum["blackbody_k"] / t, 1.0, delta=0.03, msg=f"{t} K")
            self.assertLess(duv, 1.5e-3)

    def test_far_colour_is_flagged(self):
        _, duv = units.spectrum_for_colour((0.0, 1.0, 0.0))  # pure Rec.709 green
        self.assertGreater(duv, 0.05)

    def test_luminance(self):
        self.assertAlmostEqual(units.luminance((1.0, 1.0, 1.0)), 1.0, places=12)
        self.assertAlmostEqual(units.luminance((0.0, 1.0, 0.0)), 0.7152, places=12)


class LampUnits(unittest.TestCase):
    def test_point_spreads_over_the_sphere(self):
        # Integrating I = P/(4π) over the sphere gives back P.
        self.assertAlmostEqual(units.point_intensity_w_sr(100.0) * 4 * math.pi, 100.0, places=10)

    def test_spot_mask(self):
        size = math.radians(60.0)
        self.assertEqual(units.spot_factor(math.cos(math.radians(31.0)), size, 0.0), 0.0)
        self.assertAlmostEqual(units.spot_factor(1.0, size, 0.5), 1.0)
        edge = math.cos(math.radians(29.999))
        self.assertLess(units.spot_factor(edge, size, 0.2), 1e-4)  # the blend fades to 0 at the rim

    def test_area_lambertian(self):
        # A Lambertian emitter of radiance L = P/(4A): intensity L·A·cos θ = P/4 · cos θ; its flux
        # ∫ I dΩ over the front hemisphere is π·P/4.
        n = 2000
        flux = sum(units.area_intensity_w_sr(1.0, math.cos((i + 0.5) * math.pi / (2 * n)))
                   * math.sin((i + 0.5) * math.pi / (2 * n)) * 2 * math.pi * math.pi / (2 * n) for i in range(n))
        self.assertAlmostEqual(flux, math.pi / 4, delta=1e-6)
        self.assertEqual(units.area_intensity_w_sr(1.0, -0.5), 0.0)

    def test_flare_scale_is_the_camera_equation(self):
        # A Lambertian source of radiance L filling the view: E = π L / (4 N²) on the sensor, so
        # E × scale = L for any N.
        for n in (1.4, 2.0, 4.0, 11.0):
            radiance = 3.0
            e = math.pi * radiance / (4 * n * n)
            self.assertAlmostEqual(e * units.flare_to_blender_scale(n), radiance, places=12)


class CameraArithmetic(unittest.TestCase):
    def test_sensor_fit(self):
        self.assertEqual(camera.frame_size_mm("AUTO", 36, 24, 1920, 1080), (36, 36 * 1080 / 1920))
        self.assertEqual(camera.frame_size_mm("AUTO", 36, 24, 1080, 1920), (36 * 1080 / 1920, 36))
        self.assertEqual(camera.frame_size_mm("HORIZONTAL", 36, 24, 1080, 1920), (36, 36 * 1920 / 1080))
        self.assertEqual(camera.frame_size_mm("VERTICAL", 36, 24, 1920, 1080), (24 * 1920 / 1080, 24))
        with self.assertRaises(FlareInputError):
            camera.frame_size_mm("AUTO", 36, 24, 100, 100, 2.0, 1.0)
        with self.assertRaises(FlareInputError):
            camera.frame_size_mm("DIAGONAL", 36, 24, 100, 100)

    def test_shift_window(self):
        # 96 x 64, Auto: shift in units of the longer side, 96 px; +x right, +y up.
        self.assertEqual(camera.shift_window("AUTO", 96, 64, 0.125, 0.0), (120, 64, 24, 0, None))
        self.assertEqual(camera.shift_window("AUTO", 96, 64, -0.125, 0.0), (120, 64, 0, 0, None))
        self.assertEqual(camera.shift_window("AUTO", 96, 64, 0.0, 0.125), (96, 88, 0, 0, None))
        self.assertEqual(camera.shift_window("AUTO", 96, 64, 0.0, -0.125), (96, 88, 0, 24, None))
        self.assertEqual(camera.shift_window("VERTICAL", 96, 64, 0.25, 0.0)[:4], (128, 64, 32, 0))
        self.assertIn("rounded", camera.shift_window("AUTO", 96, 64, 0.1, 0.0)[4])

    def test_zoom_follows_within_range(self):
        entry = {"id": "z", "zoom_positions": ["w", "m", "t"], "zoom_focal_lengths_mm": [24.0, 50.0, 70.0],
                 "focal_range_mm": [24.0, 70.0]}
        self.assertEqual(camera.zoom_setting(entry, 35.0), (35.0, None))
        self.assertEqual(camera.zoom_setting(entry, 70.0), ("t", None))
        zoom, note = camera.zoom_setting(entry, 100.0)
        self.assertEqual(zoom, "t")
        self.assertIn("outside the zoom range", note)
        self.assertEqual(camera.zoom_setting(entry, 10.0)[0], "w")
        self.assertEqual(camera.zoom_setting({"id": "p", "focal_range_mm": [50, 50]}, 35.0), (None, None))

    def test_field_angles(self):
        fx, fy = camera.field_deg((math.tan(math.radians(10)), math.tan(math.radians(-5)), -1.0))
        self.assertAlmostEqual(fx, 10.0, places=12)
        self.assertAlmostEqual(fy, -5.0, places=12)
        self.assertIsNone(camera.field_deg((0.0, 0.0, 1.0)))
        self.assertIsNone(camera.field_deg((1.0, 0.0, -1e-4)))  # beyond 89.9°

    def test_focus_from_the_pupil(self):
        self.assertEqual(camera.focus_distance_mm(None, 20.0), "infinity")
        self.assertAlmostEqual(camera.focus_distance_mm(2.0, 20.0), 1980.0)
        with self.assertRaises(FlareInputError):
            camera.focus_distance_mm(0.01, 20.0)


if __name__ == "__main__":
    unittest.main()
