"""The Blender add-on's example scene (docs/blender.md): a camera with a 50 mm lens at f/4 at eye
height, the sun 9° right of and 6° above the view's centre, a warm street lamp 25 m ahead and 2 m
left; with geometry, a street of boxes, a lamp post and a sky. The add-on's test
(tests/blender/blender_addon_test.py) and its benchmark (scripts/bench-blender.py) build it.

Inside Blender: build(bpy.context.scene, width, height, with_geometry) on an empty scene.
"""
import math

import bpy
from mathutils import Vector


def look(obj, direction):
    """Turns obj (a camera or a lamp, which look and shine along their −z) along `direction`."""
    obj.rotation_euler = Vector(direction).to_track_quat("-Z", "Y").to_euler()


def build(sc, width, height, with_geometry=False):
    sc.frame_start, sc.frame_end, sc.frame_current = 1, 1, 1
    sc.render.resolution_x, sc.render.resolution_y = width, height
    sc.render.resolution_percentage = 100
    sc.render.pixel_aspect_x = sc.render.pixel_aspect_y = 1.0
    cd = bpy.data.cameras.new("Camera")
    cd.lens = 50.0
    cd.sensor_fit = "AUTO"
    cd.sensor_width = 36.0
    cd.dof.use_dof = True
    cd.dof.focus_distance = 10.0
    cd.dof.aperture_fstop = 4.0
    cam = bpy.data.objects.new("Camera", cd)
    cam.location = (0.0, 0.0, 1.6)
    look(cam, (0.0, 1.0, 0.0))  # looking along +y, x to the right, z up
    sc.collection.objects.link(cam)
    sc.camera = cam
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = 5.0
    sun.data.angle = math.radians(0.53)
    sun.data.color = (1.0, 0.95, 0.85)
    # Seen 9° right of and 6° above the axis: its rays travel the other way.
    look(sun, (-math.tan(math.radians(9)), -1.0, -math.tan(math.radians(6))))
    sc.collection.objects.link(sun)
    lamp = bpy.data.objects.new("Lamp", bpy.data.lights.new("Lamp", "POINT"))
    lamp.data.energy = 2000.0
    lamp.data.shadow_soft_size = 0.0
    lamp.data.color = (1.0, 0.7, 0.4)
    lamp.location = (-2.0, 25.0, 2.4)
    sc.collection.objects.link(lamp)
    sc.flare.lens = "double-gauss-50mm"
    if with_geometry:
        add_geometry(sc)
    return sc


def add_geometry(sc):
    """Ground, four boxes clear of the sun, the lamp's post and a blue sky."""
    bpy.ops.mesh.primitive_plane_add(size=200, location=(0, 60, 0))
    ground = bpy.context.object
    mat = bpy.data.materials.new("ground")
    mat.diffuse_color = (0.25, 0.25, 0.27, 1)
    ground.data.materials.append(mat)
    for x, y, h in ((-6, 30, 5), (14, 40, 9), (-12, 55, 14), (20, 70, 11)):
        bpy.ops.mesh.primitive_cube_add(size=1, location=(x, y, h / 2))
        bpy.context.object.scale = (4, 4, h)
    bpy.ops.mesh.primitive_cylinder_add(radius=0.08, depth=2.3, location=(-2.0, 25.0, 1.15))
    sc.world = bpy.data.worlds.new("sky")
    sc.world.use_nodes = True
    bg = sc.world.node_tree.nodes["Background"]
    bg.inputs[0].default_value = (0.35, 0.45, 0.7, 1)
    bg.inputs[1].default_value = 0.4
