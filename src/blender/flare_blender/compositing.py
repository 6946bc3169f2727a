"""Putting the flare into Blender: an image datablock per frame and a compositor node group,
"Flare Over", that adds the flare image over the render (render + strength × flare)."""

import bpy

GROUP_NAME = "Flare Over"
GROUP_NODE = "Flare Over"
IMAGE_NODE = "Flare Image"
SEQUENCE_IMAGE = "Flare Sequence"


def frame_image_name(frame):
    return f"Flare {frame:04d}"


def load_frame_image(path, frame):
    """The frame's flare (Blender units) as an image datablock, reloaded if it exists."""
    name = frame_image_name(frame)
    img = bpy.data.images.get(name)
    if img is not None and bpy.path.abspath(img.filepath) == path:
        img.reload()
    else:
        if img is not None:
            bpy.data.images.remove(img)
        img = bpy.data.images.load(path, check_existing=False)
        img.name = name
    img.colorspace_settings.name = "Linear"  # EXR data is scene-linear; never a view transform
    return img


def _group():
    group = bpy.data.node_groups.get(GROUP_NAME)
    if group is not None:
        return group
    group = bpy.data.node_groups.new(GROUP_NAME, "CompositorNodeTree")
    group.inputs.new("NodeSocketColor", "Image")
    group.inputs.new("NodeSocketColor", "Flare")
    strength = group.inputs.new("NodeSocketFloat", "Strength")
    strength.default_value = 1.0
    strength.min_value = 0.0
    group.outputs.new("NodeSocketColor", "Image")
    g_in = group.nodes.new("NodeGroupInput")
    g_out = group.nodes.new("NodeGroupOutput")
    add = group.nodes.new("CompositorNodeMixRGB")
    add.blend_type = "ADD"       # Image + Fac × Flare; the render's alpha passes through
    add.use_clamp = False
    g_in.location, add.location, g_out.location = (-300, 0), (0, 0), (250, 0)
    group.links.new(g_in.outputs["Strength"], add.inputs["Fac"])
    group.links.new(g_in.outputs["Image"], add.inputs[1])
    group.links.new(g_in.outputs["Flare"], add.inputs[2])
    group.links.new(add.outputs["Image"], g_out.inputs["Image"])
    return group


def sequence_image(first_path, frames):
    """One image for the compositor over all rendered frames (a sequence for an animation)."""
    img = bpy.data.images.get(SEQUENCE_IMAGE)
    if img is None:
        img = bpy.data.images.load(first_path, check_existing=False)
        img.name = SEQUENCE_IMAGE
    else:
        img.filepath = first_path
    img.source = "SEQUENCE" if len(frames) > 1 else "FILE"
    img.colorspace_settings.name = "Linear"
    img.reload()
    return img


def install(scene, image, frames):
    """Adds (once) the group between the render and the Composite output, and points its image
    node at `image`; the frames map 1:1 onto the scene's frames."""
    scene.use_nodes = True
    tree = scene.node_tree
    group_node = tree.nodes.get(GROUP_NODE)
    if group_node is None:
        composite = next((n for n in tree.nodes if n.type == "COMPOSITE"), None)
        if composite is None:
            composite = tree.nodes.new("CompositorNodeComposite")
        source = composite.inputs["Image"].links[0].from_socket if composite.inputs["Image"].links else None
        if source is None:
            layers = next((n for n in tree.nodes if n.type == "R_LAYERS"), None) or \
                tree.nodes.new("CompositorNodeRLayers")
            source = layers.outputs["Image"]
        group_node = tree.nodes.new("CompositorNodeGroup")
        group_node.name = group_node.label = GROUP_NODE
        group_node.node_tree = _group()
        group_node.location = (composite.location.x - 220, composite.location.y)
        composite.location.x += 60
        tree.links.new(source, group_node.inputs["Image"])
        tree.links.new(group_node.outputs["Image"], composite.inputs["Image"])
        for viewer in (n for n in tree.nodes if n.type == "VIEWER"):
            tree.links.new(group_node.outputs["Image"], viewer.inputs["Image"])
    image_node = tree.nodes.get(IMAGE_NODE)
    if image_node is None:
        image_node = tree.nodes.new("CompositorNodeImage")
        image_node.name = image_node.label = IMAGE_NODE
        image_node.location = (group_node.location.x - 300, group_node.location.y - 250)
        tree.links.new(image_node.outputs["Image"], group_node.inputs["Flare"])
    image_node.image = image
    if len(frames) > 1:
        # Image frame = scene frame − frame_start + 1 + offset: the scene's frame numbers.
        image_node.frame_start = frames[0]
        image_node.frame_offset = frames[0] - 1
        image_node.frame_duration = frames[-1] - frames[0] + 1
        image_node.use_auto_refresh = True
    return group_node
