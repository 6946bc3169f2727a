"""Rendering one exported frame with the engine and writing its files beside Blender's render:
`<frame>.flare.json` (the engine scene, for `flare render`), `<frame>.flare-layers.exr` (every
layer, sensor irradiance in W/m² as the CLI writes it) and `<frame>.flare.exr` (the main image in
Blender's pixel units, the one the compositor adds). No bpy here: the modal operator runs this in
a worker thread while Blender's UI keeps going (the engine releases the GIL)."""

import json
import os

import numpy as np

from .engine import FlareInputError


class Cancelled(Exception):
    pass


class RenderSettings:
    """The add-on's settings as plain values (bpy properties must not be read off the main thread)."""

    def __init__(self, props):
        self.quality = props.quality            # 'PREVIEW' or 'FINAL'
        self.stop = props.stop                  # 'TIME', 'ERROR' or 'PHOTONS'
        self.time_s = props.time_s
        self.target_error = props.target_error
        self.photons = props.photons
        self.passes = props.passes
        self.seed = props.seed
        self.threads = props.threads
        self.ghost_layers = props.ghost_layers


def output_paths(render_frame_path):
    """The three files beside Blender's render of a frame (its path from scene.render.frame_path)."""
    root, _ = os.path.splitext(render_frame_path)
    return {"json": root + ".flare.json", "layers": root + ".flare-layers.exr",
            "image": root + ".flare.exr"}


def check_writable(paths):
    """Before any work: every folder exists (or can be made) and no target is a folder."""
    for p in paths.values():
        folder = os.path.dirname(p) or "."
        if os.path.exists(p) and os.path.isdir(p):
            raise FlareInputError(f"cannot write '{p}': it is a folder")
        if os.path.exists(folder) and not os.path.isdir(folder):
            raise FlareInputError(f"cannot write into '{folder}': it is not a folder")


def run_engine(flare, export, settings, progress=None):
    """The engine's images for one exported frame (a dict: '' and the layers), or None for a frame
    without lamps. `progress(fraction)` returning False cancels (final renders: between passes)."""
    if export.scene is None:
        return None
    scene = flare.parse_scene(export.scene, file_name=f"frame {export.frame}")
    if settings.quality == "PREVIEW":
        kwargs = {"layers": True, "seed": settings.seed, "threads": settings.threads}
        if settings.stop == "TIME":
            kwargs["time"] = settings.time_s
        else:
            kwargs["passes"] = settings.passes
        images = dict(flare.preview(scene, **kwargs))
        if not settings.ghost_layers:  # the per-ghost layers only when asked: ~50 MB a frame
            images = {k: v for k, v in images.items() if not k.startswith("ghost_")}
        return images
    kwargs = {"seed": settings.seed, "threads": settings.threads,
              "layers": True if settings.ghost_layers else False}
    if settings.stop == "TIME":
        kwargs["time_s"] = settings.time_s
    elif settings.stop == "ERROR":
        kwargs["target_error"] = settings.target_error
        kwargs["photons"] = settings.photons  # the budget: whichever comes first
    else:
        kwargs["photons"] = settings.photons
    cancelled = []

    def on_pass(state):
        if progress is not None and progress(state["fraction"]) is False:
            cancelled.append(True)
            return False
        return True

    result = flare.render(scene, progress=on_pass, **kwargs)
    if cancelled:
        raise Cancelled()
    images = dict(result.images)
    images["__report__"] = result.report
    return images


def write_outputs(flare, export, images, paths, width_px, height_px):
    """Writes the frame's files, each all or nothing (flare.write_exr; the JSON through a
    temporary name); returns the Blender-units image."""
    report = None
    if images is not None and export.crop is not None:
        # A shifted camera: the window Blender sees, of every layer (per-ghost footprints whole).
        x0, y0, w, h = export.crop
        images = {k: (v if k == "__report__" else
                      np.ascontiguousarray(np.asarray(v, dtype=np.float32)[y0:y0 + h, x0:x0 + w]))
                  for k, v in images.items()}
    if images is None:
        images = {"": np.zeros((height_px, width_px, 3), np.float32)}
    else:
        report = images.pop("__report__", None)
    main = np.asarray(images[""], dtype=np.float32)
    blender_image = (main * np.float32(export.to_blender_scale)).astype(np.float32)
    metadata = {"flare_frame": str(export.frame),
                "flare_crop": "none" if export.crop is None else
                "x {} y {} width {} height {} of the scene's frame".format(*export.crop),
                "flare_units": "sensor irradiance, W/m2 (linear Rec.709)",
                "flare_to_blender_scale": repr(export.to_blender_scale)}
    # All float: a faint ghost's values lie below half precision's normal range.
    flare.write_exr(paths["layers"], images, metadata=metadata)
    flare.write_exr(paths["image"], {"": blender_image},
                    metadata={"flare_frame": str(export.frame),
                              "flare_units": "Blender scene-linear (sensor irradiance x flare_to_blender_scale)",
                              "flare_to_blender_scale": repr(export.to_blender_scale)})
    if export.scene is not None:
        doc = dict(export.scene)
        text = json.dumps(doc, indent=2) + "\n"
        tmp = paths["json"] + ".part"
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(text)
        os.replace(tmp, paths["json"])
    return blender_image, report
