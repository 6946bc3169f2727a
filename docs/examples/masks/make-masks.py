#!/usr/bin/env python3
"""Writes the sample coverage masks in this folder (docs/scene-format.md, "Coverage masks").

    python3 docs/examples/masks/make-masks.py      # rewrites fingerprint.png and dust-rim.png

Plain Python (no packages): the same script always writes the same bytes.

- fingerprint.png: a thumb print pressed off-centre on an element: ridges (a loop pattern, about
  0.45 mm apart once the mask is laid over a 25 mm element) inside an elliptical smudge whose
  pressure fades towards its edge, with breaks in the ridges. Grey level = the share of the
  patch the grease film covers.
- dust-rim.png: dust that has gathered towards the rim of an element (cleaning leaves the centre
  cleanest): a radial ramp from 0.2 at the centre to 1 at the rim, 0 outside the circle.
"""
import math
import os
import random
import struct
import zlib

SIZE = 256


def write_grey_png(path, rows):
    """8-bit greyscale PNG; rows: lists of ints 0..255, first row at the top."""
    def chunk(kind, data):
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body) & 0xFFFFFFFF)
    height, width = len(rows), len(rows[0])
    raw = b"".join(b"\x00" + bytes(r) for r in rows)  # filter type 0 per row
    png = b"\x89PNG\r\n\x1a\n"
    png += chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(raw, 9))
    png += chunk(b"IEND", b"")
    with open(path, "wb") as f:
        f.write(png)


def fingerprint():
    rng = random.Random(7)
    # Ridge breaks: a few hundred short gaps placed at random.
    breaks = [(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(0.01, 0.025)) for _ in range(220)]
    cx, cy, angle = 0.18, -0.12, math.radians(25)   # print centre (mask units: -1..1) and tilt
    ax, ay = 0.42, 0.58                              # smudge half-axes
    rows = []
    for j in range(SIZE):
        y0 = 1 - 2 * (j + 0.5) / SIZE
        row = []
        for i in range(SIZE):
            x0 = 2 * (i + 0.5) / SIZE - 1
            dx, dy = x0 - cx, y0 - cy
            u = dx * math.cos(angle) + dy * math.sin(angle)
            v = -dx * math.sin(angle) + dy * math.cos(angle)
            r = math.hypot(u / ax, v / ay)
            if r >= 1.0:
                row.append(0)
                continue
            envelope = (1 - r * r) ** 0.7                     # pressure fades towards the edge
            # A loop: distance to a core point, stretched upwards, with a slight swirl.
            q = math.hypot(u * 1.15, (v + 0.08) * 0.9) + 0.05 * math.sin(3 * math.atan2(v, u))
            ridge = 0.5 + 0.5 * math.cos(2 * math.pi * q / 0.036)
            for bx, by, br in breaks:
                if abs(x0 - bx) < br and abs(y0 - by) < br:
                    ridge *= 0.3
                    break
            value = envelope * (0.25 + 0.75 * ridge)
            row.append(max(0, min(255, int(round(255 * value)))))
        rows.append(row)
    return rows


def dust_rim():
    rows = []
    for j in range(SIZE):
        y = 1 - 2 * (j + 0.5) / SIZE
        row = []
        for i in range(SIZE):
            x = 2 * (i + 0.5) / SIZE - 1
            r = math.hypot(x, y)
            row.append(0 if r > 1 else int(round(255 * (0.2 + 0.8 * r * r))))
        rows.append(row)
    return rows


if __name__ == "__main__":
    here = os.path.dirname(os.path.abspath(__file__))
    write_grey_png(os.path.join(here, "fingerprint.png"), fingerprint())
    write_grey_png(os.path.join(here, "dust-rim.png"), dust_rim())
