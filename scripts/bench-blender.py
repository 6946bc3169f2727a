"""Time the Blender add-on adds to a frame (docs/BENCHMARKS.md, "The Blender add-on"): the example
scene (docs/examples/blender_street_scene.py) rendered by Cycles, then the add-on's operator at
preview and at final quality on one frame (median of --repeats runs), and over an animation of
--frames frames with the street lamp moving. Run in Blender:

blender -b --factory-startup --python scripts/bench-blender.py -- [--build build] [--out DIR]
    [--width 960] [--height 640] [--frames 48] [--repeats 3] [--samples 64]
    [--cycles-repeats N] [--final-repeats N] [--preview-frames N] [--final-frames N]

The animation's frames are all converted and checked before any is rendered: "export" times that
for --frames frames alone; --preview-frames and --final-frames (default --frames; 0 skips) are the
frames of the animations rendered at each quality.

Prints one line per measurement and a JSON summary on the last line.
"""
import argparse
import json
import os
import statistics
import sys
import time

import bpy

SOURCE_DIR = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
ap = argparse.ArgumentParser()
ap.add_argument("--build", default=os.path.join(SOURCE_DIR, "build"))
ap.add_argument("--out", default="/tmp/flare-bench-blender")
ap.add_argument("--width", type=int, default=960)
ap.add_argument("--height", type=int, default=640)
ap.add_argument("--frames", type=int, default=48)
ap.add_argument("--preview-frames", type=int, default=None)
ap.add_argument("--final-frames", type=int, default=None)
ap.add_argument("--repeats", type=int, default=3)
ap.add_argument("--cycles-repeats", type=int, default=None)
ap.add_argument("--final-repeats", type=int, default=None)
ap.add_argument("--samples", type=int, default=64, help="Cycles samples of the reference frame")
args = ap.parse_args(argv)

os.environ["FLARE_PYTHON_PATH"] = os.path.join(os.path.abspath(args.build), "python")
sys.path.insert(0, os.path.join(SOURCE_DIR, "src", "blender"))
sys.path.insert(0, os.path.join(SOURCE_DIR, "docs", "examples"))
import flare_blender  # noqa: E402
import blender_street_scene  # noqa: E402
from flare_blender import operators  # noqa: E402

flare_blender.register()
sc = bpy.context.scene
for o in list(bpy.data.objects):
    bpy.data.objects.remove(o)
blender_street_scene.build(sc, args.width, args.height, with_geometry=True)
sc.render.engine = "CYCLES"
sc.cycles.samples = args.samples
sc.cycles.use_denoising = False
sc.render.image_settings.file_format = "OPEN_EXR"
os.makedirs(args.out, exist_ok=True)
results = {"width": args.width, "height": args.height, "frames": args.frames}


def timed(label, fn, repeats=1):
    """Wall time and the process's CPU time (all threads: the engine's and Cycles' workers), the
    latter the steadier figure on a shared machine."""
    walls, cpus = [], []
    for _ in range(repeats):
        t, c = time.perf_counter(), time.process_time()
        fn()
        walls.append(time.perf_counter() - t)
        cpus.append(time.process_time() - c)
    wall, cpu = statistics.median(walls), statistics.median(cpus)
    print(f"bench: {label}: median wall {wall:.2f} s ({', '.join(f'{t:.2f}' for t in walls)}), "
          f"CPU {cpu:.2f} s ({', '.join(f'{t:.2f}' for t in cpus)})", flush=True)
    results[label] = {"median_wall_s": wall, "wall_s": walls, "median_cpu_s": cpu, "cpu_s": cpus}
    return wall


def cycles_frame():
    sc.render.filepath = os.path.join(args.out, "cycles_")
    bpy.ops.render.render(write_still=False)


def flare(animation, folder):
    def run():
        sc.render.filepath = os.path.join(args.out, folder, "shot_")
        result = bpy.ops.flare.render("EXEC_DEFAULT", animation=animation)
        if result != {"FINISHED"}:
            raise SystemExit(f"bench: the operator returned {result}")
    return run


s = sc.flare
s.quality, s.stop, s.passes = "PREVIEW", "PHOTONS", 1
flare(False, "warm-up")()  # loads the engine and the lens library once, as a session would
timed(f"cycles frame ({args.samples} samples)", cycles_frame, args.cycles_repeats or args.repeats)
s.quality, s.stop, s.passes = "PREVIEW", "PHOTONS", 2
timed("flare preview, one frame", flare(False, "preview"), args.repeats)
s.quality, s.stop, s.target_error, s.photons = "FINAL", "ERROR", 0.02, 100_000_000
timed("flare final (2 % target error), one frame", flare(False, "final"), args.final_repeats or args.repeats)

lamp = sc.objects["Lamp"]
sc.frame_start, sc.frame_end = 1, args.frames
for f, x in ((1, -6.0), (args.frames, 6.0)):
    lamp.location = (x, 25.0, 2.4)
    lamp.keyframe_insert("location", frame=f)
timed(f"export and check of {args.frames} frames", lambda: operators._prepare(bpy.context, True))
for quality, count in (("PREVIEW", args.preview_frames), ("FINAL", args.final_frames)):
    count = args.frames if count is None else count
    if count == 0:
        continue
    sc.frame_end = count
    s.quality = quality
    label = "preview" if quality == "PREVIEW" else "final (2 % target error)"
    timed(f"flare {label}, {count}-frame animation", flare(True, f"anim-{quality.lower()}"))
print("bench-json: " + json.dumps(results), flush=True)
