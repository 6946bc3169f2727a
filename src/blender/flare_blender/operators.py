"""The operator: render the flare of the current frame or the animation. Every frame is exported
(and checked) before anything is rendered or written, so bad input stops with a message and no
files. From the UI it runs modally: the engine works in a thread, the status bar shows progress
and Esc cancels (between passes of a final render, between frames of a preview); the frames done
stay, the one under way is dropped. From a script (EXEC_DEFAULT, blender -b) it blocks."""

import os
import threading
import time

import bpy

from . import compositing
from . import job as job_mod
from .engine import FlareInputError
from .export import export_frame
from .props import engine


class _Plan:
    def __init__(self, flare, exports, paths, settings, size):
        self.flare = flare
        self.exports = exports
        self.paths = paths
        self.settings = settings
        self.size = size
        self.done = []        # (frame, path of the Blender-units image), in order
        self.fraction = 0.0   # of the whole job
        self.error = None
        self.cancel = False
        self.finished = False
        self.started = time.monotonic()

    def run(self):
        """Renders and writes every frame (any thread); stops at cancel or the first error."""
        n = len(self.exports)
        try:
            for i, export in enumerate(self.exports):
                if self.cancel:
                    raise job_mod.Cancelled()

                def progress(f, i=i):
                    self.fraction = (i + min(max(f, 0.0), 1.0)) / n
                    return not self.cancel

                images = job_mod.run_engine(self.flare, export, self.settings, progress)
                if self.cancel:
                    raise job_mod.Cancelled()
                paths = self.paths[i]
                job_mod.write_outputs(self.flare, export, images, paths, *self.size)
                self.done.append((export.frame, paths["image"]))
                self.fraction = (i + 1) / n
        except job_mod.Cancelled:
            self.error = "cancelled"
        except (ValueError, RuntimeError, OSError) as e:
            self.error = str(e)
        finally:
            self.finished = True


def _frames(scene, animation):
    if not animation:
        return [scene.frame_current]
    return list(range(scene.frame_start, scene.frame_end + 1, scene.frame_step))


def _prepare(context, animation):
    """Exports every frame and checks the outputs; raises FlareInputError, writes nothing."""
    scene = context.scene
    flare = engine(context)
    settings = scene.flare
    frames = _frames(scene, animation)
    original = scene.frame_current
    exports = []
    try:
        for f in frames:
            scene.frame_set(f)
            export = export_frame(flare, context, settings, f)
            if export.scene is not None:
                try:  # the engine's own check of every value, before anything is written
                    flare.parse_scene(export.scene, file_name=f"frame {f}")
                except ValueError as e:
                    raise FlareInputError(f"frame {f}: {e}") from None
            exports.append(export)
    finally:
        scene.frame_set(original)
    paths = [job_mod.output_paths(bpy.path.abspath(scene.render.frame_path(frame=f))) for f in frames]
    for p in paths:
        job_mod.check_writable(p)
        os.makedirs(os.path.dirname(p["image"]) or ".", exist_ok=True)
    r = scene.render
    size = (r.resolution_x * r.resolution_percentage // 100, r.resolution_y * r.resolution_percentage // 100)
    return _Plan(flare, exports, paths, job_mod.RenderSettings(settings), size)


def _report_notes(op, plan):
    seen = set()
    for e in plan.exports:
        for n in e.notes:
            if n not in seen:
                seen.add(n)
                op.report({"WARNING"}, n)


def _finish(op, context, plan):
    """Main thread: the images into Blender and the compositor group over the render."""
    for frame, path in plan.done:
        compositing.load_frame_image(path, frame)
    if plan.done:
        frames = [f for f, _ in plan.done]
        image = (compositing.sequence_image(plan.done[0][1], frames) if len(frames) > 1
                 else bpy.data.images[compositing.frame_image_name(frames[0])])
        compositing.install(context.scene, image, frames)
    seconds = time.monotonic() - plan.started
    if plan.error:
        kind = {"INFO"} if plan.error == "cancelled" else {"ERROR"}
        op.report(kind, f"flare: {plan.error} after {len(plan.done)} of {len(plan.exports)} "
                        f"frame(s); the frames done are written")
        return {"CANCELLED"}
    op.report({"INFO"}, f"flare: {len(plan.done)} frame(s) in {seconds:.1f} s, beside the "
                        f"render ({plan.paths[0]['image']})")
    return {"FINISHED"}


class FLARE_OT_render(bpy.types.Operator):
    """Render the lens flare of the scene's camera and lamps and add it over the render"""
    bl_idname = "flare.render"
    bl_label = "Render Flare"
    bl_options = {"REGISTER"}

    animation: bpy.props.BoolProperty(name="Animation", default=False,
                                      description="Every frame of the scene's range, else the current frame")

    _timer = None
    _plan = None
    _thread = None

    def _start(self, context):
        try:
            plan = _prepare(context, self.animation)
        except FlareInputError as e:
            self.report({"ERROR"}, f"flare: {e}")
            return None
        _report_notes(self, plan)
        return plan

    def execute(self, context):
        plan = self._start(context)
        if plan is None:
            return {"CANCELLED"}
        plan.run()
        return _finish(self, context, plan)

    def invoke(self, context, event):
        if bpy.app.background or context.window is None:
            return self.execute(context)  # no event loop to run a modal operator in
        plan = self._start(context)
        if plan is None:
            return {"CANCELLED"}
        self._plan = plan
        self._thread = threading.Thread(target=plan.run, name="flare render", daemon=True)
        self._thread.start()
        wm = context.window_manager
        wm.progress_begin(0, 1000)
        self._timer = wm.event_timer_add(0.25, window=context.window)
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        plan = self._plan
        if event.type == "ESC":
            plan.cancel = True
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        wm = context.window_manager
        wm.progress_update(int(1000 * plan.fraction))
        n = len(plan.exports)
        frame = min(len(plan.done) + 1, n)
        text = (f"Flare: frame {frame}/{n}, {100 * plan.fraction:.0f}% "
                f"({time.monotonic() - plan.started:.0f} s)" +
                (" — cancelling" if plan.cancel else " — Esc to cancel"))
        if context.workspace is not None:
            context.workspace.status_text_set(text)
        if not plan.finished:
            return {"RUNNING_MODAL"}
        self._thread.join()
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        if context.workspace is not None:
            context.workspace.status_text_set(None)
        return _finish(self, context, plan)


classes = (FLARE_OT_render,)


def register():
    for c in classes:
        bpy.utils.register_class(c)


def unregister():
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
