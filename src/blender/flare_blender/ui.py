"""Panels: the flare settings in Output Properties, a lamp's 'Flare' switch in Object Properties."""

import bpy


class FLARE_PT_settings(bpy.types.Panel):
    bl_label = "Lens Flare"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "output"

    def draw(self, context):
        s = context.scene.flare
        layout = self.layout
        col = layout.column()
        col.prop(s, "lens_filter", icon="VIEWZOOM")
        col.prop(s, "lens_pick")
        col.prop(s, "lens")
        col.separator()
        col.prop(s, "quality")
        col.prop(s, "stop")
        if s.stop == "TIME":
            col.prop(s, "time_s")
        elif s.quality == "FINAL":
            if s.stop == "ERROR":
                col.prop(s, "target_error")
            col.prop(s, "photons")
        else:
            col.prop(s, "passes")
        col.prop(s, "seed")
        col.prop(s, "threads")
        row = col.row()
        row.prop(s, "diffraction")
        row.prop(s, "occlusion")
        col.prop(s, "ghost_layers")
        row = layout.row()
        row.operator("flare.render", text="Flare: Frame", icon="LIGHT_SUN").animation = False
        row.operator("flare.render", text="Flare: Animation", icon="RENDER_ANIMATION").animation = True


class FLARE_PT_lamp(bpy.types.Panel):
    bl_label = "Lens Flare"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "object"

    @classmethod
    def poll(cls, context):
        return context.object is not None and context.object.type == "LIGHT"

    def draw(self, context):
        self.layout.prop(context.object, "flare_include")


classes = (FLARE_PT_settings, FLARE_PT_lamp)


def register():
    for c in classes:
        bpy.utils.register_class(c)


def unregister():
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
