#!/usr/bin/python3
"""Relative L2 error of one layer of an EXR against a reference EXR, per pixel and in B x B bins
(as the preview's benchmark states it: docs/BENCHMARKS.md), and the power ratio.

Usage: /usr/bin/python3 scripts/layer-error.py A.exr REFERENCE.exr [--layer ghost] [--reference-layer ghost] [--bin 8]
Needs the Python module (build/python, built by scripts/build.sh) and numpy.
"""
import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "build", "python"))
import flare  # noqa: E402


def relative_l2(a, b):
    return float(np.sqrt(np.sum((a - b) ** 2) / np.sum(b ** 2)))


def binned(image, size):
    h, w = image.shape[0] // size * size, image.shape[1] // size * size
    return image[:h, :w].reshape(h // size, size, w // size, size, -1).sum(axis=(1, 3))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("image")
    parser.add_argument("reference")
    parser.add_argument("--layer", default="ghost")
    parser.add_argument("--reference-layer", default=None)
    parser.add_argument("--bin", type=int, default=8)
    args = parser.parse_args()
    a = flare.read_exr(args.image)[args.layer].astype(np.float64)
    b = flare.read_exr(args.reference)[args.reference_layer or args.layer].astype(np.float64)
    if a.shape != b.shape:
        sys.exit(f"layer-error: {a.shape} against {b.shape}: not the same size")
    print(f"per_pixel_rel_l2 {relative_l2(a, b):.4f}")
    print(f"bins_{args.bin}x{args.bin}_rel_l2 {relative_l2(binned(a, args.bin), binned(b, args.bin)):.4f}")
    print(f"power_ratio {a.sum() / b.sum():.4f}")


if __name__ == "__main__":
    main()
