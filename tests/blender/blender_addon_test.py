"""The Blender add-on, headless, inside Blender (run by tests/blender/run_blender_test.py):

- its unit conversions against Cycles: a white Lambertian plane lit by each kind of lamp records
  the lamp's irradiance E, so π·pixel = E = I/d² (sun: S), checked against units.py;
- a scene with a camera, a sun and a point lamp: the add-on's flare image equals, bit for bit,
  `flare render` of the scene JSON the add-on wrote (same seed, same photons); the image Blender
  holds is that image times the documented scale; the compositor adds it over the render;
- moving the lamp moves its ghosts (round the axis, with the lamp);
- bad input (no camera, a lens not in the library, a lamp behind the camera, non-square pixels,
  an orthographic camera): an error report naming the problem and no file written.

blender -b --factory-startup --python-exit-code 1 --python tests/blender/blender_addon_test.py --
    --zip ADDON.zip --cli build/src/flare --out DIR [--docs-images docs/images]
"""
import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
import traceback
import zipfile

import bpy
import numpy as np
from mathutils import Vector

args = argparse.ArgumentParser()
args.add_argument("--zip", required=True)
args.add_argument("--cli", required=True)
args.add_argument("--out", required=True)
args.add_argument("--docs-images", default="")
args = args.parse_args(sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else [])

os.makedirs(args.out, exist_ok=True)
# Install from the zip as a user would: unpacked into a folder of its own, then registered.
addon_root = tempfile.mkdtemp(prefix="addon-", dir=args.out)
with zipfile.ZipFile(args.zip) as z:
    z.extractall(addon_root)
sys.path.insert(0, addon_root)
import flare_blender  # noqa: E402
sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))),
                                "docs", "examples"))
import blender_street_scene  # noqa: E402
from blender_street_scene import look  # noqa: E402
from flare_blender import units, compositing  # noqa: E402

flare_blender.register()

failures = []


def check(condition, message):
    print(("ok   " if condition else "FAIL ") + message, flush=True)
    if not condition:
        failures.append(message)


def clear_scene():
    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o)
    sc = bpy.context.scene
    sc.use_nodes = False
    return sc


def read_exr_pixels(path):
    img = bpy.data.images.load(path, check_existing=False)
    px = np.array(img.pixels[:], dtype=np.float32).reshape(img.size[1], img.size[0], 4)
    bpy.data.images.remove(img)
    return px[::-1, :, :3]  # Blender stores rows bottom first


# --- 1. Blender's lamp units, measured with Cycles -------------------------------------------------

def cycles_units():
    sc = clear_scene()
    sc.render.engine = "CYCLES"
    sc.cycles.samples = 16
    sc.cycles.use_denoising = False
    sc.cycles.max_bounces = 0
    sc.cycles.seed = 1
    sc.render.resolution_x = sc.render.resolution_y = 8
    sc.render.resolution_percentage = 100
    sc.render.filter_size = 0.01
    sc.view_settings.view_transform = "Standard"
    sc.world = bpy.data.worlds.new("black")
    sc.world.use_nodes = True
    sc.world.node_tree.nodes["Background"].inputs[1].default_value = 0.0
    bpy.ops.mesh.primitive_plane_add(size=100, location=(0, 0, 0))
    plane = bpy.context.object
    m = bpy.data.materials.new("white")
    m.use_nodes = True
    nt = m.node_tree
    nt.nodes.clear()
    d = nt.nodes.new("ShaderNodeBsdfDiffuse")
    d.inputs[0].default_value = (1, 1, 1, 1)
    o = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(d.outputs[0], o.inputs[0])
    plane.data.materials.append(m)
    cd = bpy.data.cameras.new("ortho")
    cd.type = "ORTHO"
    cd.ortho_scale = 0.01  # a 1 cm patch under the lamp: the irradiance varies by < 1e-5 over it
    cam = bpy.data.objects.new("ortho", cd)
    cam.location = (0, 0, 5)
    sc.collection.objects.link(cam)
    sc.camera = cam
    sc.render.image_settings.file_format = "OPEN_EXR"
    sc.render.filepath = os.path.join(args.out, "units.exr")
    distance = 2.0

    def irradiance(kind, tilt_deg=0.0, **props):
        """E on the plane from π × the recorded radiance, with its standard error."""
        for ob in list(sc.objects):
            if ob.type == "LIGHT":
                bpy.data.objects.remove(ob)
        ld = bpy.data.lights.new("lamp", kind)
        for k, v in props.items():
            setattr(ld, k, v)
        lo = bpy.data.objects.new("lamp", ld)
        lo.location = (0, 0, distance)
        lo.rotation_euler = (math.radians(tilt_deg), 0, 0)
        sc.collection.objects.link(lo)
        bpy.ops.render.render(write_still=True)
        px = read_exr_pixels(sc.render.filepath).reshape(-1)
        return math.pi * px.mean(), math.pi * px.std() / math.sqrt(px.size)

    def compare(label, measured, expected):
        e, se = measured
        # Sampling noise (4 standard errors) plus the geometry: the patch's cos³ spread and the
        # lamp's extent, both below 1e-4 relative here, and float rounding.
        tol = 4.0 * se + 1e-4 * expected + 1e-6
        check(abs(e - expected) <= tol,
              f"Cycles {label}: E = {e:.6g} W/m², units.py says {expected:.6g} (tolerance {tol:.2g})")

    p = 100.0
    compare("point 100 W at 2 m", irradiance("POINT", energy=p, shadow_soft_size=0.0),
            units.point_intensity_w_sr(p) / distance ** 2)
    # A sphere lamp shows a disk of its radius: E = I · d² / (d² + r²) for a uniform disk.
    r = 0.1
    compare("point 100 W, radius 0.1 m", irradiance("POINT", energy=p, shadow_soft_size=r),
            units.point_intensity_w_sr(p) / (distance ** 2 + r ** 2))
    compare("sun 3 W/m²", irradiance("SUN", energy=3.0, angle=0.0), units.sun_irradiance_w_m2(3.0))
    for size_deg, blend in ((120.0, 0.0), (80.0, 0.5)):
        f = units.spot_factor(math.cos(math.radians(30.0)), math.radians(size_deg), blend)
        compare(f"spot 30° off its axis, size {size_deg:g}°, blend {blend:g}",
                irradiance("SPOT", tilt_deg=30.0, energy=p, shadow_soft_size=0.0,
                           spot_size=math.radians(size_deg), spot_blend=blend),
                units.point_intensity_w_sr(p) * f / distance ** 2)
    for tilt in (0.0, 40.0):
        a = 0.02  # the disk's diameter: (r/d)² = 2.5e-5
        compare(f"area disk 100 W seen {tilt:g}° off its normal",
                irradiance("AREA", tilt_deg=tilt, energy=p, shape="DISK", size=a),
                units.area_intensity_w_sr(p, math.cos(math.radians(tilt))) / distance ** 2)


# --- 2. The flare of a scene with a camera, a sun and a point lamp ------------------------------

WIDTH, HEIGHT = 96, 64
SEED, PHOTONS = 7, 100_000


def street_scene(width=WIDTH, height=HEIGHT, with_geometry=False):
    """The example scene (docs/examples/blender_street_scene.py) at this size, set for a final
    render of PHOTONS photons at SEED."""
    sc = clear_scene()
    blender_street_scene.build(sc, width, height, with_geometry)
    s = sc.flare
    s.quality, s.stop, s.photons, s.seed, s.diffraction = "FINAL", "PHOTONS", PHOTONS, SEED, True
    return sc


def run_operator(**kw):
    """(result, error text) of the add-on's operator as a script runs it."""
    try:
        return bpy.ops.flare.render("EXEC_DEFAULT", **kw), ""
    except RuntimeError as e:
        return {"CANCELLED"}, str(e)


def flare_render_against_cli():
    sc = street_scene()
    out = os.path.join(args.out, "final")
    sc.render.filepath = os.path.join(out, "shot_")
    result, error = run_operator()
    check(result == {"FINISHED"}, f"the operator renders the frame ({error or result})")
    base = os.path.splitext(bpy.path.abspath(sc.render.frame_path(frame=1)))[0]
    scene_json, layers, image = base + ".flare.json", base + ".flare-layers.exr", base + ".flare.exr"
    for p in (scene_json, layers, image):
        check(os.path.isfile(p), f"the add-on wrote {os.path.basename(p)} beside the render")
    with open(scene_json) as f:
        doc = json.load(f)
    kinds = sorted(l["type"] for l in doc["lights"])
    check(kinds == ["directional", "point"], f"the scene holds a directional and a point light ({kinds})")
    sun = next(l for l in doc["lights"] if l["type"] == "directional")
    # Blender keeps rotations in float32 (2⁻²⁴ relative, ~3e-6° per rounding): a few roundings.
    check(abs(sun["field_deg"][0] - 9.0) < 3e-5 and abs(sun["field_deg"][1] - 6.0) < 3e-5,
          f"the sun is seen at [9, 6] deg ({sun['field_deg']})")
    lamp = next(l for l in doc["lights"] if l["type"] == "point")
    # 2000 W at (−2, 25, 2.4) seen from (0, 0, 1.6): I = Y·P/(4π); x, y, z in the camera's frame.
    y_colour = units.luminance((1.0, 0.7, 0.4))
    # The colour is stored in float32 (0.7 and 0.4 rounded by up to 2⁻²⁴ relative).
    check(abs(lamp["power"] / (y_colour * 2000.0 / (4 * math.pi)) - 1) < 1e-7,
          f"the point lamp's power is Y·P/(4π) W/sr ({lamp['power']:.6g})")
    cli_exr = os.path.join(out, "cli.exr")
    proc = subprocess.run([args.cli, "render", scene_json, "-o", cli_exr, "--photons", str(PHOTONS),
                           "--seed", str(SEED), "--quiet"], capture_output=True, text=True)
    check(proc.returncode == 0, f"flare render reads the add-on's JSON ({proc.stderr.strip()})")
    import flare
    ours = flare.read_exr(layers)
    cli = flare.read_exr(cli_exr)
    check(set(cli) <= set(ours), f"the add-on's EXR has every layer of the CLI's ({sorted(cli)})")
    for name in sorted(cli):
        a, b = np.asarray(ours[name]), np.asarray(cli[name])
        check(a.shape == b.shape and a.tobytes() == b.tobytes(),
              f"layer '{name}' equals flare render's bit for bit")
    check(float(np.asarray(ours["ghost"]).sum()) > 0.0, "the ghost layer is not black")
    scale = np.float32(units.flare_to_blender_scale(flare.parse_scene(doc).lens().paraxial().working_f_number))
    held = np.array(bpy.data.images[compositing.frame_image_name(1)].pixels[:], np.float32)
    held = held.reshape(HEIGHT, WIDTH, 4)[::-1, :, :3]
    expected = np.asarray(ours[""], np.float32) * scale
    check(held.tobytes() == expected.tobytes(),
          f"Blender's image 'Flare 0001' is the flare × {float(scale):.6g} (4 N_w²/π)")
    tree = sc.node_tree
    check(sc.use_nodes and tree.nodes.get(compositing.GROUP_NODE) is not None,
          "the compositor has the 'Flare Over' group before the Composite output")
    return sc


def composite_adds_the_flare(sc):
    """Renders with Cycles through the compositor, with the group's strength 1 and 0: the
    difference is the flare image Blender holds."""
    sc.render.engine = "CYCLES"
    sc.cycles.samples = 2
    sc.cycles.use_denoising = False
    sc.cycles.seed = 3
    sc.view_settings.view_transform = "Standard"
    sc.render.image_settings.file_format = "OPEN_EXR"
    group = sc.node_tree.nodes[compositing.GROUP_NODE]
    outs = []
    for strength in (1.0, 0.0):
        group.inputs["Strength"].default_value = strength
        sc.render.filepath = os.path.join(args.out, f"composite_{int(strength)}.exr")
        bpy.ops.render.render(write_still=True)
        outs.append(read_exr_pixels(sc.render.filepath))
    flare_img = np.array(bpy.data.images[compositing.frame_image_name(1)].pixels[:], np.float32)
    flare_img = flare_img.reshape(HEIGHT, WIDTH, 4)[::-1, :, :3]
    diff = outs[0] - outs[1]
    # One float32 addition per pixel: the sum is exact to half an ulp of the larger term.
    tol = np.float32(2 ** -23) * np.maximum(np.abs(outs[0]), np.abs(outs[1])) + 1e-30
    check(bool(np.all(np.abs(diff - flare_img) <= tol)),
          f"the composite is render + flare (max deviation {np.abs(diff - flare_img).max():.3g})")


def centroid(rgb):
    """(luminance sum, centroid (x right, y up) in pixels from the frame's centre)."""
    lum = np.asarray(rgb, np.float64) @ np.array([0.2126, 0.7152, 0.0722])
    rows, cols = np.indices(lum.shape)
    w = lum.sum()
    if w <= 0.0:
        return 0.0, np.zeros(2)
    cx = (cols * lum).sum() / w + 0.5 - lum.shape[1] / 2
    cy = lum.shape[0] / 2 - ((rows * lum).sum() / w + 0.5)
    return w, np.array([cx, cy])


def lamp_ghosts(sc, lamp_xz, name):
    """The lamp alone at (x, 25 m, z) in the preview: (centroid of its own image, {ghost layer:
    centroid} for the ghosts holding at least 1 % of the ghost light, 4 px or more from the centre)."""
    sc.objects["Sun"].flare_include = False
    sc.objects["Lamp"].location = (lamp_xz[0], 25.0, lamp_xz[1])
    s = sc.flare
    s.quality, s.stop, s.passes, s.diffraction, s.ghost_layers = "PREVIEW", "PHOTONS", 2, False, True
    sc.render.filepath = os.path.join(args.out, name, "shot_")
    result, error = run_operator()
    check(result == {"FINISHED"}, f"the preview renders ({error or result})")
    import flare
    base = os.path.splitext(bpy.path.abspath(sc.render.frame_path(frame=1)))[0]
    img = flare.read_exr(base + ".flare-layers.exr")
    total, _ = centroid(img["ghost"])
    ghosts = {}
    for layer in img:
        if layer.startswith("ghost_") and layer != "ghost_other":
            w, c = centroid(np.asarray(img[layer]))
            if w >= 0.01 * total and np.hypot(*c) >= 4.0:
                ghosts[layer] = c
    return centroid(img["direct"])[1], ghosts


def moving_lamp_moves_ghosts():
    sc = street_scene(64, 64)
    # The lamp 12° right of the camera's axis, then 12° left of it. Each ghost of a lens with
    # rotational symmetry is symmetric about the line through the centre and the lamp's image,
    # and the horizontal line is a mirror of everything else that shapes the ghosts (the frame,
    # its pixel grid, the double Gauss's six-bladed iris), so each ghost's centroid lies on it;
    # a half turn maps the frame, the grid and the iris onto themselves, so the ghosts turn with
    # the lamp: c₂ = −c₁. What breaks the symmetry is how the preview samples the pupil, a
    # fraction of a pixel: each centroid is held to half a pixel.
    angles = (0.0, 180.0)
    radius_m = 25.0 * math.tan(math.radians(12.0))
    results = []
    for i, angle in enumerate(angles):
        a = math.radians(angle)
        xz = (radius_m * math.cos(a), 1.6 + radius_m * math.sin(a))
        results.append(lamp_ghosts(sc, xz, f"move{i}"))
    for (direct, ghosts), angle in zip(results, angles):
        seen = math.degrees(math.atan2(direct[1], direct[0])) % 360.0
        tol = math.degrees(math.atan2(0.5, np.hypot(*direct)))
        check(abs((seen - angle + 180.0) % 360.0 - 180.0) <= tol,
              f"the lamp's image is where Blender sees it ({seen:.3f}° vs {angle:g}° mod 360, ±{tol:.3f}°)")
        check(len(ghosts) >= 2, f"lamp at {angle:g}°: {len(ghosts)} strong ghosts away from the centre")
        line = np.array([math.cos(math.radians(angle)), math.sin(math.radians(angle))])
        worst = max((abs(c[0] * line[1] - c[1] * line[0]) for c in ghosts.values()), default=0.0)
        check(worst <= 0.5, f"lamp at {angle:g}°: every strong ghost lies on the lamp's line "
                                  f"through the centre (farthest {worst:.3f} px off it)")
    rot = np.array([[-1.0, 0.0], [0.0, -1.0]])
    common = sorted(set(results[0][1]) & set(results[1][1]))
    check(len(common) >= 2, f"the same ghosts are strong at both places ({len(common)})")
    for name in common:
        c1, c2 = results[0][1][name], results[1][1][name]
        miss = float(np.hypot(*(rot @ c1 - c2)))
        moved = float(np.hypot(*(c2 - c1)))
        check(miss <= 1.0 and moved >= 5.0,
              f"{name} turned with the lamp: moved {moved:.1f} px, {miss:.3f} px from the "
              "rotated position")


def camera_matches_blender():
    """The sensor the add-on derives against Blender's own view frame, for every sensor fit and
    both orientations; a zoom lens follows the camera; a prime of another focal length is noted
    and the sensor scaled to keep the camera's field of view."""
    import flare
    from flare_blender.export import export_frame
    sc = street_scene()
    cam = sc.camera
    for fit in ("AUTO", "HORIZONTAL", "VERTICAL"):
        for w, h in ((96, 64), (64, 96)):
            cam.data.sensor_fit = fit
            cam.data.sensor_height = 20.0
            sc.render.resolution_x, sc.render.resolution_y = w, h
            export = export_frame(flare, bpy.context, sc.flare, 1)
            got = export.scene["sensor"]["width_mm"], export.scene["sensor"]["height_mm"]
            corners = cam.data.view_frame(scene=sc)
            # Corners at depth z: half widths x/z in units of the focal length.
            xs = [abs(c.x / c.z) for c in corners]
            ys = [abs(c.y / c.z) for c in corners]
            want = (2 * max(xs) * cam.data.lens, 2 * max(ys) * cam.data.lens)
            efl = flare.parse_scene(export.scene).lens().paraxial().efl_mm
            want = (want[0] * efl / cam.data.lens, want[1] * efl / cam.data.lens)
            # view_frame works in float32: 2⁻²³ relative, a few roundings.
            check(all(abs(g / v - 1) < 1e-6 for g, v in zip(got, want)),
                  f"sensor fit {fit}, {w}x{h}: the flare's sensor {got[0]:.5f} x {got[1]:.5f} mm is "
                  f"Blender's frame × EFL/f ({want[0]:.5f} x {want[1]:.5f})")
    sc.render.resolution_x, sc.render.resolution_y = WIDTH, HEIGHT
    cam.data.sensor_fit = "AUTO"
    cam.data.lens = 35.0
    sc.flare.lens = "zoom-24-70mm"
    export = export_frame(flare, bpy.context, sc.flare, 1)
    check(export.scene["zoom"] == 35.0 and not any("focal length" in n for n in export.notes),
          f"the zoom lens follows the camera's 35 mm (zoom {export.scene['zoom']})")
    cam.data.lens = 100.0
    export = export_frame(flare, bpy.context, sc.flare, 1)
    check(export.scene["zoom"] == "tele" and any("outside the zoom range" in n for n in export.notes),
          f"a camera beyond the zoom's range sets its end, with a note ({export.notes})")
    sc.flare.lens = "double-gauss-50mm"
    cam.data.lens = 35.0
    export = export_frame(flare, bpy.context, sc.flare, 1)
    check(any("focal length of" in n for n in export.notes),
          "a prime of another focal length is noted")
    cam.data.dof.aperture_fstop = 1.0
    export = export_frame(flare, bpy.context, sc.flare, 1)
    check(any("faster than" in n for n in export.notes) and export.scene["f_number"] > 2.0,
          f"an f-stop faster than the lens renders wide open, with a note (f/{export.scene['f_number']:.3g})")


def shifted_camera():
    """A lens shift: the engine renders a frame centred on the axis that holds Blender's shifted
    frame, and the add-on keeps Blender's window of it: its centre where Blender's view frame
    puts it, its layers `flare preview` of the JSON cropped there, bit for bit."""
    import flare
    from flare_blender.export import export_frame
    sc = street_scene()
    cam = sc.camera.data
    cam.shift_x, cam.shift_y = 0.125, -0.0625  # 12 and −6 px of the 96 px longer side
    export = export_frame(flare, bpy.context, sc.flare, 1)
    x0, y0, w, h = export.crop
    big_w, big_h = export.scene["sensor"]["resolution"]
    pitch_mm = export.scene["sensor"]["width_mm"] / big_w
    # Blender's frame centre, in mm on a sensor at the lens's EFL, right and up of the axis.
    corners = cam.view_frame(scene=sc)
    efl = flare.parse_scene(export.scene).lens().paraxial().efl_mm
    cx = sum(c.x / -c.z for c in corners) / 4 * efl
    cy = sum(c.y / -c.z for c in corners) / 4 * efl
    wx = (x0 + w / 2 - big_w / 2) * pitch_mm
    wy = (big_h / 2 - (y0 + h / 2)) * pitch_mm
    check(abs(wx - cx) < 1e-4 and abs(wy - cy) < 1e-4,
          f"the shifted window's centre ({wx:.4f}, {wy:.4f}) mm is Blender's ({cx:.4f}, {cy:.4f})")
    s = sc.flare
    s.quality, s.stop, s.passes = "PREVIEW", "PHOTONS", 1
    out = os.path.join(args.out, "shift")
    sc.render.filepath = os.path.join(out, "shot_")
    result, error = run_operator()
    check(result == {"FINISHED"}, f"the shifted camera's flare renders ({error or result})")
    base = os.path.splitext(bpy.path.abspath(sc.render.frame_path(frame=1)))[0]
    cli_exr = os.path.join(out, "cli.exr")
    proc = subprocess.run([args.cli, "preview", base + ".flare.json", "-o", cli_exr, "--passes", "1",
                           "--seed", str(SEED), "--layers", "--float-layers"], capture_output=True, text=True)
    check(proc.returncode == 0, f"flare preview reads the shifted scene ({proc.stderr.strip()})")
    ours, cli = flare.read_exr(base + ".flare-layers.exr"), flare.read_exr(cli_exr)
    for name in ("", "direct", "starburst", "ghost"):
        a = np.asarray(ours[name])
        b = np.asarray(cli[name])[y0:y0 + h, x0:x0 + w]
        check(a.shape == (HEIGHT, WIDTH, 3) and a.tobytes() == b.tobytes(),
              f"shifted: layer '{name}' is flare preview's, cropped, bit for bit")


def lamps_and_search():
    """Spot, area and sphere lamps through the add-on's export, and the lens search."""
    import flare
    from flare_blender.export import export_frame
    from flare_blender.props import search_lenses
    sc = street_scene()
    sc.objects["Sun"].flare_include = False
    lamp = sc.objects["Lamp"]
    lamp.data.shadow_soft_size = 0.3
    export = export_frame(flare, bpy.context, sc.flare, 1)
    disk = export.scene["lights"][0]
    check(disk["type"] == "disk" and abs(disk["radius_mm"] - 300.0) < 1e-3,
          f"a point lamp of radius 0.3 m is a disk of that radius facing the lens ({disk['type']})")
    spot = bpy.data.objects.new("Spot", bpy.data.lights.new("Spot", "SPOT"))
    spot.location = (0.0, 20.0, 1.6)
    look(spot, (0.0, 1.0, 0.0))  # shining away from the camera
    sc.collection.objects.link(spot)
    export = export_frame(flare, bpy.context, sc.flare, 1)
    check(len(export.scene["lights"]) == 1 and any("outside its cone" in n for n in export.notes),
          "a spot aimed away is left out, with a note")
    bpy.data.objects.remove(spot)
    area = bpy.data.objects.new("Panel", bpy.data.lights.new("Panel", "AREA"))
    area.data.shape, area.data.size, area.data.energy = "DISK", 0.5, 300.0
    area.data.color = (1.0, 1.0, 1.0)
    area.location = (0.0, 20.0, 1.6)
    tilt = 30.0
    look(area, (math.sin(math.radians(tilt)), -math.cos(math.radians(tilt)), 0.0))
    sc.collection.objects.link(area)
    export = export_frame(flare, bpy.context, sc.flare, 1)
    panel = next(l for l in export.scene["lights"] if l["name"] == "Panel")
    cos_t = math.cos(math.radians(tilt))
    want_r = math.sqrt(math.pi * 0.25 ** 2 * cos_t / math.pi) * 1000.0
    check(panel["type"] == "disk" and abs(panel["power"] / (300.0 / 4 * cos_t) - 1) < 1e-6
          and abs(panel["radius_mm"] / want_r - 1) < 1e-6,
          f"an area disk seen {tilt:g}° off its normal: P/4·cos θ W/sr over its foreshortened area "
          f"({panel['power']:.6g} W/sr, radius {panel['radius_mm']:.5g} mm)")
    area.data.shape = "RECTANGLE"
    export = export_frame(flare, bpy.context, sc.flare, 1)
    check(any("rendered as a disk of the same area" in n for n in export.notes),
          "a rectangular area lamp is a disk of its area, with a note")
    found = search_lenses(flare, "canon 50")
    check(found and all("canon" in e["id"] and e["focal_range_mm"][0] - 0.5 <= 50 <= e["focal_range_mm"][1] + 0.5
                        for e in found), f"searching 'canon 50' finds {len(found)} Canon lenses covering 50 mm")
    check(any(e["id"] == "zoom-24-70mm" for e in search_lenses(flare, "24-70")),
          "searching '24-70' finds the shipped zoom")


def animation():
    """Three frames with the lamp moving: a file set per frame, an image per frame, the
    compositor reading them as a sequence, and the flare moving."""
    import flare
    sc = street_scene(64, 64)
    sc.objects["Sun"].flare_include = False
    s = sc.flare
    s.quality, s.stop, s.passes, s.diffraction = "PREVIEW", "PHOTONS", 1, False
    sc.frame_start, sc.frame_end = 1, 3
    lamp = sc.objects["Lamp"]
    for f, x in ((1, -4.0), (3, 4.0)):
        lamp.location = (x, 25.0, 1.6)
        lamp.keyframe_insert("location", frame=f)
    sc.render.filepath = os.path.join(args.out, "anim", "shot_")
    result, error = run_operator(animation=True)
    check(result == {"FINISHED"}, f"the animation renders ({error or result})")
    xs = []
    for f in (1, 2, 3):
        base = os.path.splitext(bpy.path.abspath(sc.render.frame_path(frame=f)))[0]
        check(all(os.path.isfile(base + e) for e in (".flare.json", ".flare-layers.exr", ".flare.exr")),
              f"frame {f}: its three files")
        check(compositing.frame_image_name(f) in bpy.data.images, f"frame {f}: its image in Blender")
        xs.append(centroid(flare.read_exr(base + ".flare-layers.exr")["direct"])[1][0])
    node = sc.node_tree.nodes[compositing.IMAGE_NODE]
    check(node.image.source == "SEQUENCE" and node.frame_duration == 3 and node.frame_offset == 0,
          "the compositor reads the frames as a sequence")
    check(xs[0] < xs[1] < xs[2], f"the lamp's image follows the lamp across frames ({xs})")


def cancelling():
    """What Esc does in the UI: the plan's cancel flag, set while a final render runs in its
    thread, stops it between passes; the frame under way is not written."""
    import threading
    from flare_blender import operators
    sc = street_scene()
    sc.flare.photons = 2_000_000_000  # far more than a test can wait for: only the cancel ends it
    out = tempfile.mkdtemp(prefix="cancel-", dir=args.out)
    sc.render.filepath = os.path.join(out, "shot_")
    plan = operators._prepare(bpy.context, False)
    thread = threading.Thread(target=plan.run)
    thread.start()
    t0 = time.monotonic()
    while plan.fraction == 0.0 and not plan.finished and time.monotonic() - t0 < 300:
        time.sleep(0.05)
    plan.cancel = True
    thread.join()
    check(plan.error == "cancelled" and plan.done == [] and os.listdir(out) == [],
          f"a cancelled render stops ({plan.error}) and writes nothing ({os.listdir(out)})")


# --- 3. Bad input: a clear error and no file -------------------------------------------------------

def bad_input():
    def expect_error(label, mutate, words):
        sc = street_scene()
        out = tempfile.mkdtemp(prefix="bad-", dir=args.out)
        sc.render.filepath = os.path.join(out, "shot_")
        mutate(sc)
        result, error = run_operator()
        check(result == {"CANCELLED"} and all(w in error for w in words),
              f"{label}: refused with '{error.strip()}'")
        check(os.listdir(out) == [], f"{label}: no file written")

    expect_error("no camera", lambda sc: setattr(sc, "camera", None), ["no active camera"])
    expect_error("a lens not in the library", lambda sc: setattr(sc.flare, "lens", "no-such-lens"),
                 ["no-such-lens", "not in the library"])
    expect_error("a lamp behind the camera",
                 lambda sc: setattr(sc.objects["Lamp"], "location", (0.0, -5.0, 1.6)),
                 ["'Lamp'", "behind"])
    expect_error("non-square pixels", lambda sc: setattr(sc.render, "pixel_aspect_x", 2.0),
                 ["square pixels"])
    expect_error("an orthographic camera", lambda sc: setattr(sc.camera.data, "type", "ORTHO"),
                 ["perspective"])


# --- 4. Images for docs/blender.md -------------------------------------------------------------

def docs_images(folder):
    """The composited frame of the street scene (Cycles, 480 × 320) and the flare alone."""
    os.makedirs(folder, exist_ok=True)
    sc = street_scene(480, 320, with_geometry=True)
    sc.flare.quality, sc.flare.stop, sc.flare.photons = "FINAL", "PHOTONS", 1_000_000
    sc.flare.occlusion = True
    sc.render.filepath = os.path.join(args.out, "docs", "street_")
    result, error = run_operator()
    check(result == {"FINISHED"}, f"the docs frame's flare renders ({error or result})")
    sc.render.engine = "CYCLES"
    sc.cycles.samples = 32
    sc.view_settings.view_transform = "Filmic"
    sc.render.image_settings.file_format = "PNG"
    group = sc.node_tree.nodes[compositing.GROUP_NODE]
    for strength, name in ((1.0, "blender-composite.png"), (0.0, "blender-render.png")):
        group.inputs["Strength"].default_value = strength
        sc.render.filepath = os.path.join(folder, name)
        bpy.ops.render.render(write_still=True)
    print(f"docs images in {folder}")


try:
    cycles_units()
    sc = flare_render_against_cli()
    composite_adds_the_flare(sc)
    moving_lamp_moves_ghosts()
    camera_matches_blender()
    shifted_camera()
    lamps_and_search()
    animation()
    cancelling()
    bad_input()
    if args.docs_images:
        docs_images(args.docs_images)
except Exception:
    traceback.print_exc()
    failures.append("exception")

print(f"{len(failures)} failure(s)" + (": " + "; ".join(failures) if failures else ""), flush=True)
sys.exit(1 if failures else 0)
