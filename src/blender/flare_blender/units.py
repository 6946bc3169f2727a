"""Blender's light units → the engine's radiometric units, and the flare's sensor irradiance →
Blender's pixel values. Pure Python (no bpy), so /usr/bin/python3 can test it.

Blender 3.4, as Cycles renders them (docs/blender.md shows the measurements the
headless test repeats in Cycles):

- sun: `energy` S is the irradiance on a plane normal to its rays, W/m² (per unit of colour);
- point and spot: `energy` P is a "power" whose radiant intensity is P / (4π) W/sr in every
  direction; a spot does not concentrate it in its cone, it masks it: I(θ) = P/(4π)·cos θ·
  smoothstep(blend) inside the cone (θ from the spot's axis), 0 outside;
  a point of radius r > 0 is a sphere that shows the lens a uniform disk of radius r, I unchanged;
- area: `energy` P gives a Lambertian emitter of radiance P / (4 A) (A its area), so its radiant
  intensity is P/4 · cos θ towards a viewer θ off its normal (not P/π: Blender's "watts" of an
  area light are not its radiant flux, which is πP/4).

A colour (r, g, b) in Blender's scene-linear Rec.709 multiplies all of these channel by channel.
The engine takes a spectral shape and a power whose luminance Y it is (docs/rendering.md: a light
of power 1 seen directly gives Y = 1 W/m²), so power = geometric factor × Y(r, g, b), and the
shape is the nearest of D65 (Rec.709's white), illuminant E and the black bodies in chromaticity.
"""

import math

# Rec.709 luminance weights (the Y row of the Rec.709 → XYZ matrix with D65 white).
_Y_WEIGHTS = (0.2126, 0.7152, 0.0722)
# Linear Rec.709 (D65) → CIE 1931 XYZ, from the primaries (ITU-R BT.709-6).
_RGB_TO_XYZ = ((0.4124, 0.3576, 0.1805), (0.2126, 0.7152, 0.0722), (0.0193, 0.1192, 0.9505))
D65_XY = (0.3127, 0.3290)
E_XY = (1.0 / 3.0, 1.0 / 3.0)
BLACKBODY_MIN_K = 1667.0   # the range of the Planckian-locus fit below (and inside the engine's
BLACKBODY_MAX_K = 25000.0  # [1000, 40000] K)


def luminance(rgb):
    return sum(w * c for w, c in zip(_Y_WEIGHTS, rgb))


def xy_of_rgb(rgb):
    x, y, z = (sum(m * c for m, c in zip(row, rgb)) for row in _RGB_TO_XYZ)
    s = x + y + z
    if s <= 0.0:
        return None
    return (x / s, y / s)


def planckian_xy(temperature_k):
    """CIE 1931 xy of a black body, Kim et al.'s cubic fit (US patent 7,024,034; 1667–25000 K,
    within 1e-3 of Planck's law integrated against the CIE 1931 observer)."""
    t = temperature_k
    if t < 4000.0:
        x = -0.2661239e9 / t**3 - 0.2343589e6 / t**2 + 0.8776956e3 / t + 0.179910
    else:
        x = -3.0258469e9 / t**3 + 2.1070379e6 / t**2 + 0.2226347e3 / t + 0.240390
    if t < 2222.0:
        y = -1.1063814 * x**3 - 1.34811020 * x**2 + 2.18555832 * x - 0.20219683
    elif t < 4000.0:
        y = -0.9549476 * x**3 - 1.37418593 * x**2 + 2.09137015 * x - 0.16748867
    else:
        y = 3.0817580 * x**3 - 5.87338670 * x**2 + 3.75112997 * x - 0.37001483
    return (x, y)


def _uv(xy):
    """CIE 1960 UCS (u, v), where distances between chromaticities mean about the same everywhere."""
    x, y = xy
    d = -2.0 * x + 12.0 * y + 3.0
    return (4.0 * x / d, 6.0 * y / d)


def _uv_distance(a, b):
    ua, va = _uv(a)
    ub, vb = _uv(b)
    return math.hypot(ua - ub, va - vb)


def spectrum_for_colour(rgb):
    """(spectrum for the scene JSON, its chromaticity distance Δuv from the colour). White and
    near-white colours give D65 exactly when it is the nearest shape."""
    xy = xy_of_rgb(rgb)
    if xy is None:
        return ("d65", 0.0)
    best = ("d65", _uv_distance(xy, D65_XY))
    e = _uv_distance(xy, E_XY)
    if e < best[1]:
        best = ("equal_energy", e)
    # Golden-section search would do; a log-spaced scan then a local refinement is plainly robust.
    steps = 400
    ratio = BLACKBODY_MAX_K / BLACKBODY_MIN_K
    temps = [BLACKBODY_MIN_K * ratio ** (i / steps) for i in range(steps + 1)]
    t_best = min(temps, key=lambda t: _uv_distance(xy, planckian_xy(t)))
    lo, hi = t_best / ratio ** (1 / steps), t_best * ratio ** (1 / steps)
    for _ in range(60):
        a, b = lo + (hi - lo) / 3, hi - (hi - lo) / 3
        if _uv_distance(xy, planckian_xy(a)) < _uv_distance(xy, planckian_xy(b)):
            hi = b
        else:
            lo = a
    t_best = min(max(0.5 * (lo + hi), BLACKBODY_MIN_K), BLACKBODY_MAX_K)
    d = _uv_distance(xy, planckian_xy(t_best))
    if d < best[1]:
        best = ({"blackbody_k": round(t_best, 1)}, d)
    return best


def _smoothstep(t):
    t = min(max(t, 0.0), 1.0)
    return t * t * (3.0 - 2.0 * t)


def spot_factor(cos_theta, spot_size_rad, spot_blend):
    """Blender's spot mask towards a direction cos θ off the spot's axis: cos θ inside the cone,
    smoothed over the outer share `spot_blend` of (1 − cos(size/2)), 0 outside."""
    cos_half = math.cos(0.5 * spot_size_rad)
    if cos_theta <= cos_half:
        return 0.0
    smooth = (1.0 - cos_half) * spot_blend
    t = cos_theta - cos_half
    factor = cos_theta
    if smooth > 0.0 and t < smooth:
        factor *= _smoothstep(t / smooth)
    return factor


def point_intensity_w_sr(energy_w):
    """Radiant intensity of a Blender point or spot light of `energy` P (on its axis): P/(4π)."""
    return energy_w / (4.0 * math.pi)


def area_intensity_w_sr(energy_w, cos_theta):
    """Radiant intensity of a Blender area light of `energy` P towards a viewer cos θ off its
    normal: P/4 · cos θ (0 behind it)."""
    return 0.25 * energy_w * max(cos_theta, 0.0)


def sun_irradiance_w_m2(strength):
    return strength


def flare_to_blender_scale(working_f_number, transmittance=1.0):
    """Factor from the engine's sensor irradiance (W/m²) to Blender's pixel values (the scene
    radiance a pinhole camera records). A lens at working f-number N forms, from a scene of
    radiance L, the sensor irradiance E = π L T / (4 N²) near the axis (camera equation), so the
    flare is added to the render as E · 4N² / (π T): a light's own image then has the value a
    Blender camera gives the light's surface."""
    return 4.0 * working_f_number ** 2 / (math.pi * transmittance)
