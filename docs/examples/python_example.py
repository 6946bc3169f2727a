"""The Python module on the default scene: the lens's paraxial data, the five strongest ghosts,
the preview's layers with their statistics, saved as NumPy arrays.

    PYTHONPATH=build/python python3 docs/examples/python_example.py [--output DIR]
"""
import argparse
import os

import numpy as np

import flare


def main():
    parser = argparse.ArgumentParser(description="The flare module on the default scene")
    parser.add_argument("--output", default="out", help="folder for preview.npz (default: out)")
    args = parser.parse_args()

    scene = flare.default_scene()
    lens = scene.lens()
    paraxial = lens.paraxial()
    print(f"{lens.name}: EFL {paraxial.efl_mm:.2f} mm, f/{paraxial.f_number:.2f}, entrance pupil "
          f"{paraxial.entrance_pupil_diameter_mm:.2f} mm, {lens.surface_count} surfaces")

    # The same dict as `flare ghosts docs/examples/default.json --json`.
    report = scene.ghost_report()
    print(f"{report['enumerated']} ghosts of order {report['order']} ({report['pruned_count']} pruned); "
          f"all ghosts carry {report['total_ghost_power_fraction']:.3e} of the entering power. The five strongest:")
    print(f"  {'surfaces':<10} {'power':>10} {'focus (mm)':>11}  footprint x, y (mm)")
    for ghost in report["ghosts"][:5]:
        surfaces = "-".join(str(s) for s in ghost["surfaces"])
        focus = "afocal" if ghost["ghost_focus_mm"] is None else f"{ghost['ghost_focus_mm']:.2f}"
        box = ghost["footprint_mm"]
        print(f"  {surfaces:<10} {ghost['power_fraction']:>10.3e} {focus:>11}  "
              f"[{box['x_min']:.1f}, {box['x_max']:.1f}] x [{box['y_min']:.1f}, {box['y_max']:.1f}]")

    # Linear Rec.709 RGB in W/m2, one float32 array (height, width, 3) per EXR layer name.
    images = flare.preview(scene, layers=True)
    print(f"preview: {scene.width_px} x {scene.height_px} px, {len(images) - 3} ghost layers")
    for name in ("", "direct", "ghost"):
        image = images[name]
        print(f"  {name or '(main)':<8} sum {image.sum(dtype=np.float64):.4e}  max {image.max():.4e}")

    os.makedirs(args.output, exist_ok=True)
    path = os.path.join(args.output, "preview.npz")
    np.savez_compressed(path, **{name or "main": image for name, image in images.items()})
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
