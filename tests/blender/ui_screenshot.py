"""A screenshot of the add-on in Blender's interface while it renders (docs/images/blender-panel.png):
the Lens Flare panel and the progress in the status bar. Blender draws its interface only with an
OpenGL context, so this runs under a virtual X server (Debian: xvfb, xauth) and not in the test
suite; the modal operator it starts is the one the Lens Flare buttons start.

    blender -b --factory-startup --python tests/blender/ui_screenshot.py -- --make-blend DIR/street.blend
    xvfb-run -a -s "-screen 0 1280x800x24" blender DIR/street.blend \\
        --python tests/blender/ui_screenshot.py -- --shot docs/images/blender-panel.png --build build

(A .blend opened from the command line spares the start-up splash screen.)
"""
import argparse
import os
import sys
import time

import bpy

SOURCE_DIR = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
ap = argparse.ArgumentParser()
ap.add_argument("--make-blend", default="")
ap.add_argument("--shot", default="")
ap.add_argument("--build", default=os.path.join(SOURCE_DIR, "build"))
args = ap.parse_args(sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else [])

os.environ["FLARE_PYTHON_PATH"] = os.path.join(os.path.abspath(args.build), "python")
sys.path.insert(0, os.path.join(SOURCE_DIR, "src", "blender"))
sys.path.insert(0, os.path.join(SOURCE_DIR, "docs", "examples"))
import flare_blender  # noqa: E402

flare_blender.register()

if args.make_blend:
    import blender_street_scene
    sc = bpy.context.scene
    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o)
    blender_street_scene.build(sc, 480, 320, with_geometry=True)
    sc.flare.quality, sc.flare.stop, sc.flare.photons = "FINAL", "PHOTONS", 1_000_000
    sc.render.filepath = os.path.join(os.path.dirname(os.path.abspath(args.make_blend)), "out", "street_")
    bpy.ops.wm.save_as_mainfile(filepath=args.make_blend)
    sys.exit(0)

state = {"phase": 0, "start": time.time()}


def tick():
    win = bpy.context.window_manager.windows[0]
    big = max(win.screen.areas, key=lambda a: a.width * a.height)
    if state["phase"] == 0:  # the 3D view becomes a Properties editor (its context next redraw)
        big.type = "PROPERTIES"
    elif state["phase"] == 1:
        big.spaces[0].context = "OUTPUT"
        # Output's other panels out of the way, so that Lens Flare shows whole.
        for name in ("RENDER_PT_format", "RENDER_PT_frame_range", "RENDER_PT_time_stretching",
                     "RENDER_PT_stereoscopy", "RENDER_PT_output", "RENDER_PT_post_processing",
                     "RENDER_PT_output_views", "RENDER_PT_encoding"):
            cls = getattr(bpy.types, name, None)
            if cls is not None:
                bpy.utils.unregister_class(cls)
    elif state["phase"] == 2:
        region = next(r for r in big.regions if r.type == "WINDOW")
        with bpy.context.temp_override(window=win, area=big, region=region):
            print("ui_screenshot: operator", bpy.ops.flare.render("INVOKE_DEFAULT", animation=False), flush=True)
        state["phase"] += 1
        return 6.0  # a few seconds of the render, for the status bar
    elif state["phase"] == 3:
        with bpy.context.temp_override(window=win):
            bpy.ops.screen.screenshot(filepath=os.path.abspath(args.shot))
        print(f"ui_screenshot: wrote {args.shot}", flush=True)
        bpy.ops.wm.quit_blender()
        return None
    state["phase"] += 1
    return 1.0


bpy.app.timers.register(tick, first_interval=3.0)
