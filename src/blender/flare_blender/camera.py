"""A Blender camera → the scene's lens state and sensor. Pure Python over plain values (no bpy),
so the arithmetic is testable outside Blender; export.py reads the values from the camera."""

import math

from .engine import FlareInputError


def frame_size_mm(sensor_fit, sensor_width_mm, sensor_height_mm, width_px, height_px,
                  pixel_aspect_x=1.0, pixel_aspect_y=1.0):
    """The (width, height) in mm that Blender's pinhole camera images onto its frame, as Blender
    reads its sensor settings: AUTO fits the sensor width to the frame's longer side,
    HORIZONTAL to its width, VERTICAL fits the sensor height to its height. The engine has square
    pixels only, so a pixel aspect other than 1:1 is refused."""
    if abs(pixel_aspect_x - pixel_aspect_y) > 1e-6 * max(pixel_aspect_x, pixel_aspect_y):
        raise FlareInputError(
            f"the pixel aspect is {pixel_aspect_x:g}:{pixel_aspect_y:g}; the flare engine renders "
            "square pixels only (Output Properties > Format > Aspect X and Y must be equal)")
    if sensor_fit == "AUTO":
        if width_px >= height_px:
            width_mm = sensor_width_mm
            height_mm = width_mm * height_px / width_px
        else:
            height_mm = sensor_width_mm
            width_mm = height_mm * width_px / height_px
    elif sensor_fit == "HORIZONTAL":
        width_mm = sensor_width_mm
        height_mm = width_mm * height_px / width_px
    elif sensor_fit == "VERTICAL":
        height_mm = sensor_height_mm
        width_mm = height_mm * width_px / height_px
    else:
        raise FlareInputError(f"the camera's sensor fit '{sensor_fit}' is not supported "
                              "(use Auto, Horizontal or Vertical)")
    return (width_mm, height_mm)


def zoom_setting(entry, camera_focal_mm):
    """(zoom value for the scene, note or None): a zoom lens follows the camera's focal length
    inside its range; at or beyond an end it is set to that end's named position (a focal length
    there could fall just outside the paraxial EFLs the nominal figures round); a prime has no
    zoom key."""
    positions = entry.get("zoom_positions") if entry else None
    if not positions:
        return (None, None)
    focals = entry["zoom_focal_lengths_mm"]
    ends = sorted(zip(focals, positions))
    (lo, lo_name), (hi, hi_name) = ends[0], ends[-1]
    if camera_focal_mm <= lo or camera_focal_mm >= hi:
        name, f = (lo_name, lo) if camera_focal_mm <= lo else (hi_name, hi)
        note = None
        if camera_focal_mm < lo or camera_focal_mm > hi:
            note = (f"the camera's {camera_focal_mm:g} mm lies outside the zoom range "
                    f"{lo:g}-{hi:g} mm of '{entry['id']}': the lens is set to {name} ({f:g} mm)")
        return (name, note)
    return (camera_focal_mm, None)


def engine_sensor_mm(frame_mm, camera_focal_mm, lens_efl_mm):
    """The engine's sensor for the camera's field of view through a lens of another focal
    length: Blender's frame scaled by lens EFL / camera focal length, so that a lamp's image and
    its ghosts land where Blender draws the lamp."""
    scale = lens_efl_mm / camera_focal_mm
    return (frame_mm[0] * scale, frame_mm[1] * scale)


def focus_distance_mm(focus_m, entrance_pupil_z_mm):
    """Blender's focus distance is from the camera's origin, its pinhole: the lens's entrance
    pupil. The engine's is from the first vertex, which lies entrance_pupil_z_mm in front of the
    pupil (lens space: the first vertex at z = 0, the pupil at z = entrance_pupil_z_mm)."""
    if focus_m is None:
        return "infinity"
    d = focus_m * 1000.0 - entrance_pupil_z_mm
    if d <= 0.0:
        raise FlareInputError(
            f"the camera focuses at {focus_m:g} m, inside the lens (its first vertex is "
            f"{-entrance_pupil_z_mm / 1000.0:g} m from the entrance pupil)")
    return d


def field_deg(direction_seen):
    """Field angles [X, Y] (docs/scene-format.md) of a direction from the camera in its own frame
    (x right, y up, looking along −z), or None when it is not in front of the lens."""
    x, y, z = direction_seen
    if z >= 0.0:
        return None
    fx = math.degrees(math.atan2(x, -z))
    fy = math.degrees(math.atan2(y, -z))
    if abs(fx) > 89.9 or abs(fy) > 89.9:
        return None
    return [fx, fy]


def shift_window(sensor_fit, width_px, height_px, shift_x, shift_y):
    """Blender's lens shift as a window in a larger frame centred on the lens's axis (the engine's
    frame always is): (big width, big height, first column, first row, note or None). Blender
    shifts by shift × the fitted side in pixels (Auto: the longer side); the shift is rounded to
    whole pixels so that the window's pixels are the big frame's."""
    if sensor_fit == "AUTO":
        fit_px = max(width_px, height_px)
    elif sensor_fit == "HORIZONTAL":
        fit_px = width_px
    else:
        fit_px = height_px
    dx, dy = shift_x * fit_px, shift_y * fit_px   # pixels; x right, y up
    ix, iy = round(dx), round(dy)
    note = None
    if abs(dx - ix) > 0.01 or abs(dy - iy) > 0.01:
        note = (f"the lens shift ({dx:.2f}, {dy:.2f}) px is rounded to whole pixels "
                f"({ix}, {iy}) for the flare")
    big_w, big_h = width_px + 2 * abs(ix), height_px + 2 * abs(iy)
    return big_w, big_h, abs(ix) + ix, abs(iy) - iy, note
