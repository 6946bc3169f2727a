"""The active Blender scene at one frame → the engine's scene (a dict with the scene file's keys,
docs/scene-format.md), in the camera's frame and the engine's units (units.py). Reads Blender;
writes nothing. Every problem raises FlareInputError with the object's name."""

import math

import bpy
from mathutils import Vector

from . import camera as cam_math
from . import units
from .engine import FlareInputError

# Points over a disk lamp's silhouette tested for occlusion (a Vogel spiral: even coverage).
OCCLUSION_SAMPLES = 16
# Field angle (deg) above which a lamp counts as beside rather than in front of the camera.
_MAX_FIELD_DEG = 89.9


class FrameExport:
    """One frame's scene for the engine and what the add-on needs to put the flare back."""

    def __init__(self, frame, scene_dict, to_blender_scale, notes, light_count):
        self.frame = frame
        self.scene = scene_dict          # None when no lamp reaches the lens at this frame
        self.to_blender_scale = to_blender_scale
        self.notes = notes               # warnings for the report area
        self.light_count = light_count
        self.crop = None                 # (first column, first row, width, height) of a shift


def library_entry(flare, lens_id):
    for e in flare.lens_list():
        if e["id"] == lens_id:
            return e
    return None


def _shipped_zoom_entry(flare, lens_id):
    """Shipped lenses are not in lens_list; a shipped zoom's positions come from its info."""
    info = flare.load_lens(lens_id).info()
    positions = info.get("zoom_positions") or []
    if len(positions) < 2:
        return None
    focals = [p["focal_length_mm"] for p in positions]
    return {"id": lens_id, "zoom_positions": [p["name"] for p in positions],
            "zoom_focal_lengths_mm": focals, "focal_range_mm": [min(focals), max(focals)]}


def _camera_focus_m(cam_obj):
    dof = cam_obj.data.dof
    if not dof.use_dof:
        return None  # a pinhole: everything sharp; the lens is set to infinity
    if dof.focus_object is not None:
        target = dof.focus_object.matrix_world.translation
        to_target = cam_obj.matrix_world.normalized().inverted() @ target
        return max(-to_target.z, 1e-6)
    return dof.focus_distance


def lens_setup(flare, settings, cam_obj, notes):
    """(scene keys for the lens, lens EFL in mm, entrance pupil z in mm, working f-number)."""
    lens_id = settings.lens.strip()
    if not lens_id:
        raise FlareInputError("no lens chosen: pick one in the Flare panel (Output Properties)")
    try:
        entry = library_entry(flare, lens_id)
        if entry is None:
            flare.load_lens(lens_id)  # a shipped lens, or the engine's 'no lens ... nearest' error
            entry = _shipped_zoom_entry(flare, lens_id)
    except ValueError as e:
        raise FlareInputError(f"the lens '{lens_id}' is not in the library: {e}") from None
    camera_focal_mm = cam_obj.data.lens
    keys = {"lens": lens_id}
    zoom, note = cam_math.zoom_setting(entry, camera_focal_mm)
    if note:
        notes.append(note)
    if zoom is not None:
        keys["zoom"] = zoom
    try:
        wide = flare.load_lens(lens_id, zoom=zoom if zoom is not None else "")
        para = wide.paraxial()
        f_number = cam_obj.data.dof.aperture_fstop
        if f_number < para.f_number:
            notes.append(f"the camera's f/{f_number:g} is faster than '{lens_id}' opens "
                         f"(f/{para.f_number:.3g}): rendered wide open")
            f_number = para.f_number
        focus = cam_math.focus_distance_mm(_camera_focus_m(cam_obj), para.entrance_pupil_z_mm)
        lens = flare.load_lens(lens_id, zoom=zoom if zoom is not None else "",
                               focus_mm=None if focus == "infinity" else focus, f_number=f_number)
    except ValueError as e:
        raise FlareInputError(f"camera '{cam_obj.name}' with lens '{lens_id}': {e}") from None
    keys["focus_distance_mm"] = focus
    keys["f_number"] = f_number
    p = lens.paraxial()
    if abs(p.efl_mm / camera_focal_mm - 1.0) > 0.01:
        notes.append(f"the lens '{lens_id}' has a focal length of {p.efl_mm:.4g} mm, the camera "
                     f"'{cam_obj.name}' {camera_focal_mm:g} mm: the flare keeps the camera's "
                     f"field of view (sensor scaled by {p.efl_mm / camera_focal_mm:.4g})")
    return keys, p.efl_mm, p.entrance_pupil_z_mm, p.working_f_number


def _visible_fraction(scene, depsgraph, origin, targets):
    """Share of the camera → target segments (or rays, for a target None-distance direction)
    that scene geometry leaves open."""
    open_count = 0
    for direction, distance in targets:
        hit, *_ = scene.ray_cast(depsgraph, origin, direction, distance=distance)
        open_count += 0 if hit else 1
    return open_count / len(targets)


def _disk_points(centre, axis, radius):
    """OCCLUSION_SAMPLES points over a disk of `radius` facing `axis` (Vogel spiral)."""
    helper = Vector((1.0, 0.0, 0.0)) if abs(axis.x) < 0.9 else Vector((0.0, 1.0, 0.0))
    u = axis.cross(helper).normalized()
    v = axis.cross(u)
    golden = math.pi * (3.0 - math.sqrt(5.0))
    pts = []
    for i in range(OCCLUSION_SAMPLES):
        r = radius * math.sqrt((i + 0.5) / OCCLUSION_SAMPLES)
        a = i * golden
        pts.append(centre + u * (r * math.cos(a)) + v * (r * math.sin(a)))
    return pts


def _lamps(scene):
    for obj in scene.objects:
        if obj.type == "LIGHT" and not obj.hide_render and obj.flare_include:
            yield obj


def light_dicts(scene, depsgraph, cam_obj, entrance_pupil_z_mm, occlusion, notes):
    cam_world = cam_obj.matrix_world.normalized()
    to_cam = cam_world.inverted()
    cam_rot_t = to_cam.to_3x3()
    cam_pos = cam_world.translation
    lights = []
    for obj in _lamps(scene):
        data = obj.data
        world = obj.matrix_world
        pos = world.translation
        axis = (world.to_3x3() @ Vector((0.0, 0.0, -1.0))).normalized()  # lamps shine along −z
        colour = tuple(data.color)
        y = units.luminance(colour)
        if data.energy <= 0.0 or y <= 0.0:
            notes.append(f"lamp '{obj.name}' emits nothing (power or colour 0): left out")
            continue
        if data.use_nodes:
            notes.append(f"lamp '{obj.name}' uses shader nodes: the flare reads its colour and "
                         "power only, not the nodes")
        spectrum, duv = units.spectrum_for_colour(colour)
        if duv > 0.01:
            notes.append(f"lamp '{obj.name}': its colour is {duv:.3f} (CIE 1960 uv) from the "
                         "nearest spectrum the engine knows (D65, E, black bodies): the flare's hue "
                         "differs from the lamp's")
        light = {"name": obj.name, "spectrum": spectrum}
        behind = FlareInputError(
            f"lamp '{obj.name}' is behind or beside the camera '{cam_obj.name}' (more than "
            f"{_MAX_FIELD_DEG}° off its axis) at frame {scene.frame_current}: it cannot shine into "
            "the lens. Untick 'Flare' in the lamp's Object Properties > Visibility to leave it out")
        if data.type == "SUN":
            seen = cam_rot_t @ (-axis)
            field = cam_math.field_deg(seen)
            if field is None:
                raise behind
            diameter = math.degrees(data.angle)
            if diameter > 20.0:
                notes.append(f"sun '{obj.name}': angular diameter {diameter:.3g}° is above the "
                             "engine's 20°: rendered at 20°")
                diameter = 20.0
            power = units.sun_irradiance_w_m2(data.energy) * y
            if occlusion:
                power *= _visible_fraction(scene, depsgraph, cam_pos, [(-axis, 1.0e9)])
            light.update(type="directional", field_deg=field, angular_diameter_deg=diameter)
        else:
            local = to_cam @ pos
            to_lens = cam_pos - pos
            dist = to_lens.length
            if dist <= 0.0:
                raise FlareInputError(f"lamp '{obj.name}' sits at the camera's origin")
            to_lens.normalize()
            if cam_math.field_deg(tuple(local)) is None:
                raise behind
            cos_axis = axis.dot(to_lens)
            if data.type in ("POINT", "SPOT"):
                intensity = units.point_intensity_w_sr(data.energy)
                if data.type == "SPOT":
                    f = units.spot_factor(cos_axis, data.spot_size, data.spot_blend)
                    if f <= 0.0:
                        notes.append(f"spot '{obj.name}': the camera is outside its cone: left out")
                        continue
                    intensity *= f
                radius_m = data.shadow_soft_size * max(obj.matrix_world.to_scale())
                silhouette_area = math.pi * radius_m ** 2
            elif data.type == "AREA":
                if cos_axis <= 0.0:
                    notes.append(f"area lamp '{obj.name}' faces away from the camera: left out")
                    continue
                scale = obj.matrix_world.to_scale()
                sx = data.size * scale.x
                sy = (data.size_y if data.shape in ("RECTANGLE", "ELLIPSE") else data.size) * scale.y
                if data.shape in ("DISK", "ELLIPSE"):
                    area = math.pi * sx * sy / 4.0
                else:
                    area = sx * sy
                if data.shape != "DISK" or abs(sx - sy) > 1e-6 * max(sx, sy):
                    notes.append(f"area lamp '{obj.name}' ({data.shape.lower()}, "
                                 f"{sx:g} × {sy:g} m) is rendered as a disk of the same area")
                if cos_axis < 0.9:
                    notes.append(f"area lamp '{obj.name}' is seen {math.degrees(math.acos(cos_axis)):.0f}° "
                                 "off its normal: rendered as a disk of its foreshortened area")
                if math.degrees(data.spread) < 179.9:
                    notes.append(f"area lamp '{obj.name}': its spread is ignored")
                intensity = units.area_intensity_w_sr(data.energy, cos_axis)
                silhouette_area = area * cos_axis
                radius_m = math.sqrt(silhouette_area / math.pi)
            else:
                raise FlareInputError(f"lamp '{obj.name}' has an unknown type '{data.type}'")
            power = intensity * y
            position_mm = [local.x * 1000.0, local.y * 1000.0,
                           local.z * 1000.0 + entrance_pupil_z_mm]
            if position_mm[2] >= 0.0:
                raise behind
            if occlusion:
                if radius_m > 0.0:
                    pts = _disk_points(pos, to_lens, radius_m)
                else:
                    pts = [pos]
                segs = []
                for p in pts:
                    d = p - cam_pos
                    segs.append((d.normalized(), d.length * (1.0 - 1e-6)))
                power *= _visible_fraction(scene, depsgraph, cam_pos, segs)
            light["position_mm"] = position_mm
            if radius_m > 0.0:
                # The engine's disk must lie wholly in front of the lens.
                radius_mm = radius_m * 1000.0
                if radius_mm >= -position_mm[2]:
                    raise FlareInputError(f"lamp '{obj.name}' (radius {radius_m:g} m) reaches "
                                          "the camera's lens")
                light.update(type="disk", radius_mm=radius_mm)
            else:
                light["type"] = "point"
        if power <= 0.0:
            notes.append(f"lamp '{obj.name}' is hidden from the camera by scene geometry")
            continue
        light["power"] = power
        lights.append(light)
    return lights


def export_frame(flare, context, settings, frame):
    """The engine scene of `scene` at `frame` (the caller has set the frame)."""
    scene = context.scene
    cam_obj = scene.camera
    if cam_obj is None:
        raise FlareInputError(f"the scene '{scene.name}' has no active camera")
    if cam_obj.data.type != "PERSP":
        raise FlareInputError(f"camera '{cam_obj.name}' is {cam_obj.data.type.lower()}: the "
                              "flare needs a perspective camera")
    notes = []
    r = scene.render
    width_px = r.resolution_x * r.resolution_percentage // 100
    height_px = r.resolution_y * r.resolution_percentage // 100
    frame_mm = cam_math.frame_size_mm(cam_obj.data.sensor_fit, cam_obj.data.sensor_width,
                                      cam_obj.data.sensor_height, width_px, height_px,
                                      r.pixel_aspect_x, r.pixel_aspect_y)
    lens_keys, efl_mm, ep_z_mm, working_f = lens_setup(flare, settings, cam_obj, notes)
    sensor_mm = cam_math.engine_sensor_mm(frame_mm, cam_obj.data.lens, efl_mm)
    # A lens shift: the engine renders a frame centred on the axis that holds the shifted one,
    # and the add-on keeps the window Blender sees.
    crop = None
    if cam_obj.data.shift_x != 0.0 or cam_obj.data.shift_y != 0.0:
        big_w, big_h, x0, y0, note = cam_math.shift_window(
            cam_obj.data.sensor_fit, width_px, height_px, cam_obj.data.shift_x, cam_obj.data.shift_y)
        if note:
            notes.append(note)
        if max(big_w, big_h) > 16384:
            raise FlareInputError(f"camera '{cam_obj.name}': the lens shift needs a {big_w} x {big_h} "
                                  "frame centred on the axis, beyond the engine's 16384 pixels")
        crop = (x0, y0, width_px, height_px)
        sensor_mm = (sensor_mm[0] * big_w / width_px, sensor_mm[1] * big_h / height_px)
        width_px, height_px = big_w, big_h
    depsgraph = context.evaluated_depsgraph_get()
    lights = light_dicts(scene, depsgraph, cam_obj, ep_z_mm, settings.occlusion, notes)
    scene_dict = None
    if lights:
        scene_dict = {
            "description": f"Blender scene '{scene.name}', camera '{cam_obj.name}', frame {frame} "
                           "(written by the flare add-on)",
            **lens_keys,
            "sensor": {"width_mm": sensor_mm[0], "height_mm": sensor_mm[1],
                       "resolution": [width_px, height_px]},
            "lights": lights,
            "render": {"seed": settings.seed, "photons": settings.photons,
                       "diffraction": settings.diffraction},
        }
    else:
        notes.append(f"frame {frame}: no lamp shines into the lens; the flare is black")
    scale = units.flare_to_blender_scale(working_f)
    export = FrameExport(frame, scene_dict, scale, notes, len(lights))
    export.crop = crop
    return export
