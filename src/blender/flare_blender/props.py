"""The add-on's settings (scene.flare, object.flare_include, the preferences) and the lens
picker: a search over the engine's library by maker, focal length and name."""

import re

import bpy

from .engine import import_flare, FlareInputError

# EnumProperty item callbacks must keep their strings alive (Blender holds raw pointers).
_lens_items_cache = []
MAX_LISTED = 200


def addon_prefs(context):
    addon = context.preferences.addons.get(__package__)
    return addon.preferences if addon else None


def engine(context):
    prefs = addon_prefs(context)
    return import_flare(prefs.module_dir if prefs else "")


def search_lenses(flare, text):
    """Lenses matching every word of `text`: numbers ('50', '50mm', '24-70') select by focal
    length (a prime within 0.5 mm, a zoom whose range holds it), other words by id, maker, model,
    name, patent or tags (flare.lens_search). Shipped lenses first, then the library's."""
    words = text.split()
    focal = []
    other = []
    for w in words:
        m = re.fullmatch(r"(\d+(?:\.\d+)?)(?:-(\d+(?:\.\d+)?))?(?:mm)?", w.lower())
        if m:
            focal.append((float(m.group(1)), float(m.group(2)) if m.group(2) else None))
        else:
            other.append(w)
    library = flare.lens_search(" ".join(other)) if other else flare.lens_list()
    shipped = []
    for name in flare.lens_names():
        if any(e["id"] == name for e in library):
            continue
        if all(w.lower() in name.lower() for w in other) and name in _shipped_names(flare):
            info = flare.load_lens(name).info()
            positions = info.get("zoom_positions") or []
            focals = [p["focal_length_mm"] for p in positions] or [info["efl_mm"]]
            shipped.append({"id": name, "name": f"{name} (shipped)",
                            "focal_range_mm": [min(focals), max(focals)]})

    def focal_ok(entry):
        lo, hi = entry["focal_range_mm"]
        for a, b in focal:
            want_lo, want_hi = (a, b) if b is not None else (a, a)
            if want_hi < lo - 0.5 or want_lo > hi + 0.5:
                return False
        return True

    return [e for e in shipped + library if focal_ok(e)]


_shipped_cache = []


def _shipped_names(flare):
    if not _shipped_cache:
        ids = {e["id"] for e in flare.lens_list()}
        _shipped_cache.extend(n for n in flare.lens_names() if n not in ids)
    return _shipped_cache


def _lens_items(self, context):
    _lens_items_cache.clear()
    try:
        flare = engine(context)
        found = search_lenses(flare, self.lens_filter)
    except (FlareInputError, ValueError) as e:
        _lens_items_cache.append(("", "(engine not found)", str(e)))
        return _lens_items_cache
    if not found:
        _lens_items_cache.append(("", "(no lens matches)", "change the search text"))
    for e in found[:MAX_LISTED]:
        lo, hi = e["focal_range_mm"]
        focal = f"{lo:g} mm" if lo == hi else f"{lo:g}-{hi:g} mm"
        _lens_items_cache.append((e["id"], f"{e['name']}", f"{e['id']}: {focal}"))
    return _lens_items_cache


def _on_pick(self, context):
    if self.lens_pick:
        self.lens = self.lens_pick


class FlarePreferences(bpy.types.AddonPreferences):
    bl_idname = __package__

    module_dir: bpy.props.StringProperty(
        name="Engine module folder", subtype="DIR_PATH",
        description="Folder holding the engine's Python module flare.cpython-*.so (the build's "
                    "build/python); empty: FLARE_PYTHON_PATH, then the copy bundled in the add-on")

    def draw(self, context):
        self.layout.prop(self, "module_dir")


class FlareSettings(bpy.types.PropertyGroup):
    lens: bpy.props.StringProperty(
        name="Lens", default="double-gauss-50mm",
        description="Lens id from the library (flare lens list) or a shipped lens name")
    lens_filter: bpy.props.StringProperty(
        name="Search", default="",
        description="Words to look for in the maker, model and name; numbers pick focal lengths "
                    "(50, 24-70)")
    lens_pick: bpy.props.EnumProperty(name="Matches", items=_lens_items, update=_on_pick)
    quality: bpy.props.EnumProperty(
        name="Quality", default="PREVIEW",
        items=[("PREVIEW", "Preview", "The render's beams without photons: ghosts and starburst, fast"),
               ("FINAL", "Final", "The photon render: ghosts, higher-order chains and scattering")])
    stop: bpy.props.EnumProperty(
        name="Stop", default="TIME",
        items=[("TIME", "Time", "Seconds per frame"),
               ("ERROR", "Target error", "Final: until the estimated relative error (within the photon budget); "
                                         "preview: a number of passes"),
               ("PHOTONS", "Photons", "Final: a fixed photon budget (reproducible by `flare render --photons`); "
                                      "preview: a number of passes")])
    time_s: bpy.props.FloatProperty(name="Seconds", default=5.0, min=0.01)
    target_error: bpy.props.FloatProperty(name="Error", default=0.02, min=1e-4, max=1.0)
    photons: bpy.props.IntProperty(name="Photons", default=1000000, min=1)
    passes: bpy.props.IntProperty(name="Passes", default=2, min=1)
    seed: bpy.props.IntProperty(name="Seed", default=1, min=0)
    threads: bpy.props.IntProperty(name="Threads", default=0, min=0, description="0: all cores")
    diffraction: bpy.props.BoolProperty(name="Starburst", default=True,
                                        description="The lens's diffraction pattern of each lamp")
    occlusion: bpy.props.BoolProperty(
        name="Occlusion", default=False,
        description="Dim lamps hidden by scene geometry (rays from the camera to the lamp)")
    ghost_layers: bpy.props.BoolProperty(
        name="Per-ghost layers", default=False,
        description="A layer per ghost in the layers EXR (about 50 MB a frame at 480 x 320 for the "
                    "double Gauss's 50 ghosts)")


classes = (FlarePreferences, FlareSettings)


def register():
    for c in classes:
        bpy.utils.register_class(c)
    bpy.types.Scene.flare = bpy.props.PointerProperty(type=FlareSettings)
    bpy.types.Object.flare_include = bpy.props.BoolProperty(
        name="Flare", default=True, description="This lamp's light enters the flare")


def unregister():
    del bpy.types.Object.flare_include
    del bpy.types.Scene.flare
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
