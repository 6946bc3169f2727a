#!/usr/bin/python3
"""Make the example plates of `flare composite` (docs/composite.md): synthetic linear HDR EXRs, no
downloads. Values are scene-linear Rec.709 with 1.0 a diffuse white, so a lamp is hundreds to
thousands and the sun about 10^5.

    night-street.exr  1920 x 1080: a street at night, 24 street lamps receding in perspective on both
                      sides, lit windows in the facades, a neon sign (pink and cyan strokes), dim
                      facades and a dark sky
    sunlit.exr        1920 x 1080: a low sun in a blue sky over a bright field, with a glint

Usage: scripts/make-plates.py OUT_DIR [--width W]   (default 1920; the height is 9/16 of it: the
       docs' pictures use 960, quick tests 480)

The EXRs are written by the engine's own writer (flare.write_exr: OpenEXR, uncompressed, 32-bit
float R, G, B, the chromaticities of linear Rec.709); the module is taken from build/python when it
is not on the path.
"""
import os
import sys

import numpy as np

try:
    import flare
except ImportError:
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "build", "python"))
    import flare


def write_exr(path, rgb):
    """An H x W x 3 float array (R, G, B, linear Rec.709) as an uncompressed EXR, all or nothing."""
    flare.write_exr(path, {"": np.ascontiguousarray(rgb, dtype=np.float32)}, compression="none")


def disk_cover(shape, cx, cy, radius):
    """The coverage of a disk (px), antialiased by 4 x 4 supersampling, over its bounding box:
    (y0, y1, x0, x1, cover) or None outside the image."""
    h, w = shape[:2]
    x0, x1 = max(0, int(cx - radius - 1)), min(w, int(cx + radius + 2))
    y0, y1 = max(0, int(cy - radius - 1)), min(h, int(cy + radius + 2))
    if x0 >= x1 or y0 >= y1:
        return None
    ys, xs = np.mgrid[y0:y1, x0:x1]
    cover = np.zeros(xs.shape)
    for sy in range(4):
        for sx in range(4):
            dx = xs + (sx + 0.5) / 4 - cx
            dy = ys + (sy + 0.5) / 4 - cy
            cover += (dx * dx + dy * dy <= radius * radius)
    return y0, y1, x0, x1, cover / 16.0


def disk(img, cx, cy, radius, colour, value):
    found = disk_cover(img.shape, cx, cy, radius)
    if found:
        y0, y1, x0, x1, cover = found
        img[y0:y1, x0:x1] += cover[:, :, None] * value * np.asarray(colour)[None, None, :]


def rect(img, x0, y0, x1, y1, colour, value):
    img[int(y0):int(y1), int(x0):int(x1)] += value * np.asarray(colour)


def stroke(img, points, width, colour, value):
    """A polyline of round-capped segments (the neon tubes): the coverage of overlapping disks along
    it, kept at its largest (not summed) so that a tube is evenly bright."""
    cover = np.zeros(img.shape[:2])
    for (ax, ay), (bx, by) in zip(points[:-1], points[1:]):
        n = max(2, int(np.hypot(bx - ax, by - ay) / (0.25 * width)) + 1)
        for t in np.linspace(0.0, 1.0, n):
            found = disk_cover(img.shape, ax + t * (bx - ax), ay + t * (by - ay), 0.5 * width)
            if found:
                y0, y1, x0, x1, c = found
                np.maximum(cover[y0:y1, x0:x1], c, out=cover[y0:y1, x0:x1])
    img += (cover[:, :, None] * value * np.asarray(colour)[None, None, :]).astype(np.float32)


def night_street(w, h):
    s = w / 1920.0
    img = np.zeros((h, w, 3), np.float32)
    ys = np.arange(h)[:, None]
    horizon = 0.55 * h
    # Sky: dark blue-grey, a little brighter at the horizon (city glow).
    sky = 0.004 + 0.012 * np.clip(ys / horizon, 0, 1) ** 3
    img += (sky[:, :, None] * np.array([0.6, 0.7, 1.0])[None, None, :]).astype(np.float32)
    # Road below the horizon, facades on both sides converging to a vanishing point.
    vx, vy = 0.5 * w, horizon
    xs = np.arange(w)[None, :]
    road = ys > horizon
    img[np.broadcast_to(road, (h, w))] = 0.008
    facade = np.abs(xs - vx) > 0.12 * w * (1 + 3 * np.abs(ys - vy) / h)
    img[np.broadcast_to(facade & (ys < 0.85 * h), (h, w))] = np.array([0.02, 0.018, 0.015], np.float32)
    rng = np.random.default_rng(29)
    # Lit windows: warm rectangles on both facades, smaller towards the vanishing point.
    for side in (-1, 1):
        for col in range(6):
            depth = 1.0 / (1.0 + 0.55 * col)
            x = vx + side * (0.18 * w + 0.30 * w * depth)
            for row in range(4):
                if rng.random() < 0.45:
                    continue
                y = vy - 0.26 * h * depth - row * 0.09 * h * depth
                ww, wh = 22 * s * depth, 30 * s * depth
                warm = np.array([1.0, 0.78, 0.5]) * rng.uniform(0.8, 1.2)
                rect(img, x - ww / 2, y - wh / 2, x + ww / 2, y + wh / 2, warm, rng.uniform(4.0, 9.0))
    # Street lamps: 12 a side, receding; sodium orange on the left, LED white on the right.
    for side, colour in ((-1, (1.0, 0.52, 0.13)), (1, (1.0, 0.93, 0.82))):
        for k in range(12):
            depth = 1.0 / (1.0 + 0.35 * k)
            x = vx + side * 0.42 * w * depth
            y = vy - 0.30 * h * depth
            disk(img, x, y, max(1.2, 5.0 * s * depth), colour, 1500.0)
            # its pool of light on the road
            disk(img, x, vy + 0.35 * (h - vy) * depth + 4, 60 * s * depth, colour, 0.05)
    # Neon sign: pink letters and a cyan underline on the left facade.
    pink, cyan = (1.0, 0.15, 0.55), (0.1, 0.9, 1.0)
    ox, oy, u = 0.14 * w, 0.34 * h, 14 * s
    letters = [
        [(0, 3), (0, 0), (2, 0), (0, 0), (0, 1.5), (1.5, 1.5)],          # F
        [(3, 0), (3, 3), (5, 3)],                                         # L
        [(6, 3), (7, 0), (8, 3), (7.5, 1.8), (6.5, 1.8)],                 # A
        [(9, 3), (9, 0), (11, 0), (11, 1.5), (9, 1.5), (11, 3)],          # R
        [(14, 0), (12, 0), (12, 3), (14, 3), (12, 3), (12, 1.5), (13.5, 1.5)],  # E
    ]
    for points in letters:
        stroke(img, [(ox + u * px, oy + u * py) for px, py in points], 2.5 * s, pink, 40.0)
    stroke(img, [(ox, oy + 4 * u), (ox + 14 * u, oy + 4 * u)], 2.5 * s, cyan, 30.0)
    return img


def sunlit(w, h):
    s = w / 1920.0
    img = np.zeros((h, w, 3), np.float32)
    ys = np.arange(h)[:, None].astype(np.float32)
    horizon = 0.62 * h
    t = np.clip(ys / horizon, 0, 1)
    sky = (1.0 - t)[:, :, None] * np.array([0.35, 0.55, 1.2]) + t[:, :, None] * np.array([1.1, 1.2, 1.4])
    img += (sky * 1.2).astype(np.float32)
    ground = np.broadcast_to(ys > horizon, (h, w))
    img[ground] = np.array([0.25, 0.3, 0.1], np.float32)
    # The sun: 0.53 degrees is about 25 px across with a 50 mm lens on a 36 mm wide plate.
    disk(img, 0.72 * w, 0.22 * h, 12.5 * s, (1.0, 0.97, 0.9), 1.0e5)
    disk(img, 0.72 * w, 0.22 * h, 40 * s, (1.0, 0.95, 0.85), 20.0)  # the bright sky around it
    # A glint on a car roof in the field.
    disk(img, 0.30 * w, 0.80 * h, 1.5 * s + 0.5, (1.0, 1.0, 1.0), 3000.0)
    return img


def main():
    if len(sys.argv) < 2:
        print(__doc__)
        return 2
    out = sys.argv[1]
    w = int(sys.argv[sys.argv.index("--width") + 1]) if "--width" in sys.argv[2:] else 1920
    h = w * 9 // 16
    os.makedirs(out, exist_ok=True)
    write_exr(os.path.join(out, "night-street.exr"), night_street(w, h))
    write_exr(os.path.join(out, "sunlit.exr"), sunlit(w, h))
    print(f"wrote {out}/night-street.exr and {out}/sunlit.exr ({w} x {h})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
