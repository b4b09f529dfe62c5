"""A Cornell box with a copper sphere, built in Blender, exported to glTF and rendered by Cycles at
several sample counts: the scene bench/cycles_compare.sh measures lensfarm against Cycles on.

Usage (Blender 3.4, Debian's):

    blender -b --factory-startup --python bench/cycles/cornell_copper.py -- OUTDIR
            [--spp 16,64,256] [--reference-spp 4096] [--size 200] [--bounces 3] [--threads 2]
            [--material copper|white|glass]

    --bounces B  lensfarm's max_bounces B (bounces between the lens and the light; B = 1 is direct
                 light): Cycles' Max Bounces B - 1 for every kind (docs/other-renderers.md)
    --material   the sphere's: copper (metallic 1, roughness 0.3), white (a diffuse principled
                 sphere: the glTF box as a whole), glass (solid, IOR 1.5, roughness 0)

Writes OUTDIR/scene.glb (Blender's own glTF exporter), OUTDIR/cycles-N.exr per sample count and
OUTDIR/cycles-reference.exr, and prints one line "RESULT_JSON {...}" with each render's seconds
(bpy.ops.render.render, the scene already built: Cycles' own sync, BVH build and sampling).

Everything is principled (glTF metallic-roughness, Blender's default specular 0.5), the light an
emissive quad under the ceiling (glTF has no area lamps), the walls flat and the sphere smooth, as
an artist's scene would be. Cycles: CPU, fixed seed, no denoiser, no adaptive sampling, no
clamping, no light tree (3.4 has none), filter width 1.5 px Blackman-Harris (its default).
"""

import json
import math
import os
import sys
import time

import addon_utils
import bpy
from mathutils import Vector

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []


def arg(name, default):
    return argv[argv.index(name) + 1] if name in argv else default


OUTDIR = os.path.abspath(argv[0] if argv and not argv[0].startswith("--") else "cycles-out")
SPPS = [int(s) for s in arg("--spp", "16,64,256").split(",")]
REFERENCE_SPP = int(arg("--reference-spp", "4096"))
SIZE = int(arg("--size", "200"))
BOUNCES = int(arg("--bounces", "3"))
THREADS = int(arg("--threads", "2"))
MATERIAL = arg("--material", "copper")
assert MATERIAL in ("copper", "white", "glass"), MATERIAL
os.makedirs(OUTDIR, exist_ok=True)

bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
coll = scene.collection


def principled(name, base, metallic=0.0, roughness=1.0, transmission=0.0, emission=None, strength=1.0):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    p = m.node_tree.nodes["Principled BSDF"]
    p.inputs["Base Color"].default_value = (*base, 1.0)
    p.inputs["Metallic"].default_value = metallic
    p.inputs["Roughness"].default_value = roughness
    p.inputs["Transmission"].default_value = transmission
    p.inputs["IOR"].default_value = 1.5
    if emission is not None:
        p.inputs["Base Color"].default_value = (0.0, 0.0, 0.0, 1.0)
        p.inputs["Emission"].default_value = (*emission, 1.0)
        p.inputs["Emission Strength"].default_value = strength
    return m


white = principled("White", (0.73, 0.73, 0.73))
red = principled("Red", (0.63, 0.065, 0.05))
green = principled("Green", (0.14, 0.45, 0.091))
lamp = principled("Lamp", (0, 0, 0), emission=(1.0, 0.85, 0.6), strength=17.0)
sphere_mat = {
    "copper": lambda: principled("Copper", (0.955, 0.638, 0.538), metallic=1.0, roughness=0.3),
    "white": lambda: principled("Sphere", (0.73, 0.73, 0.73)),
    "glass": lambda: principled("Glass", (1.0, 1.0, 1.0), roughness=0.0, transmission=1.0),
}[MATERIAL]()
if MATERIAL == "glass":
    # Solid glass in glTF: the exporter's "glTF Material Output" group with a thickness
    # (KHR_materials_volume); without it glTF transmission is a thin wall.
    from io_scene_gltf2.blender.com.gltf2_blender_material_helpers import create_settings_group, get_gltf_node_name
    group = bpy.data.node_groups.get(get_gltf_node_name()) or create_settings_group(get_gltf_node_name())
    node = sphere_mat.node_tree.nodes.new("ShaderNodeGroup")
    node.node_tree = group
    node.inputs["Thickness"].default_value = 0.9


def quad(name, corners, material):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([Vector(c) for c in corners], [], [(0, 1, 2, 3)])
    mesh.materials.append(material)
    ob = bpy.data.objects.new(name, mesh)
    coll.objects.link(ob)
    return ob


# The box: x in [-1, 1], y in [-1, 1] (open towards -y, where the camera is), z in [0, 2]; every
# face's normal points into the box.
quad("Floor", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], white)
quad("Ceiling", [(-1, -1, 2), (-1, 1, 2), (1, 1, 2), (1, -1, 2)], white)
quad("Back", [(-1, 1, 0), (1, 1, 0), (1, 1, 2), (-1, 1, 2)], white)
quad("Left", [(-1, -1, 0), (-1, 1, 0), (-1, 1, 2), (-1, -1, 2)], red)
quad("Right", [(1, -1, 0), (1, -1, 2), (1, 1, 2), (1, 1, 0)], green)
quad("Lamp", [(-0.25, -0.25, 1.99), (-0.25, 0.25, 1.99), (0.25, 0.25, 1.99), (0.25, -0.25, 1.99)], lamp)
bpy.ops.mesh.primitive_uv_sphere_add(segments=64, ring_count=32, radius=0.45, location=(0.25, 0.1, 0.45))
sphere = bpy.context.active_object
sphere.name = "Sphere"
sphere.data.materials.append(sphere_mat)
bpy.ops.object.shade_smooth()
bpy.ops.mesh.primitive_cube_add(size=1.0, location=(-0.45, 0.35, 0.6), rotation=(0, 0, math.radians(20)))
block = bpy.context.active_object
block.name = "Block"
block.scale = (0.55, 0.55, 1.2)
block.data.materials.append(white)

world = bpy.data.worlds.new("Black")
world.use_nodes = True
world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
scene.world = world

cam_data = bpy.data.cameras.new("Camera")
cam_data.lens = 35.0
cam_data.sensor_width = 36.0
cam = bpy.data.objects.new("Camera", cam_data)
cam.location = (0.0, -3.0, 1.0)
cam.rotation_euler = Vector((0.0, 1.0, 0.0)).to_track_quat("-Z", "Y").to_euler()
coll.objects.link(cam)
scene.camera = cam

r = scene.render
r.engine = "CYCLES"
r.resolution_x = r.resolution_y = SIZE
r.resolution_percentage = 100
r.threads_mode = "FIXED"
r.threads = THREADS
r.use_persistent_data = False
c = scene.cycles
c.device = "CPU"
c.use_adaptive_sampling = False
c.use_denoising = False
c.seed = 0
c.use_animated_seed = False
c.max_bounces = c.diffuse_bounces = c.glossy_bounces = c.transmission_bounces = BOUNCES - 1
c.transparent_max_bounces = 8
c.caustics_reflective = c.caustics_refractive = True
c.sample_clamp_direct = c.sample_clamp_indirect = 0.0
c.blur_glossy = 0.0
scene.view_settings.view_transform = "Standard"
scene.view_settings.look = "None"
im = r.image_settings
im.file_format = "OPEN_EXR"
im.color_mode = "RGB"
im.color_depth = "32"
im.exr_codec = "ZIP"

addon_utils.enable("io_scene_gltf2", default_set=True)
bpy.ops.export_scene.gltf(filepath=os.path.join(OUTDIR, "scene.glb"), export_format="GLB", export_cameras=True,
                          export_lights=True, export_apply=True, export_yup=True)


def render(spp, name):
    c.samples = spp
    r.filepath = os.path.join(OUTDIR, name)
    start = time.time()
    bpy.ops.render.render(write_still=True)
    return time.time() - start


seconds = {spp: round(render(spp, f"cycles-{spp}.exr"), 3) for spp in SPPS}
reference = round(render(REFERENCE_SPP, "cycles-reference.exr"), 3)
print("RESULT_JSON " + json.dumps({"blender": bpy.app.version_string, "size": SIZE, "bounces": BOUNCES,
                                   "material": MATERIAL, "seconds": seconds, "reference_spp": REFERENCE_SPP,
                                   "reference_seconds": reference}))
