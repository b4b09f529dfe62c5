"""Build a small reference scene in Blender, export it to glTF and render it with Cycles.

Usage (Blender 3.4, tested with Debian's 3.4.1):

    blender -b --factory-startup --python tests/blender/make_scene.py -- OUTDIR [--spp N]
            [--bounces N] [--only point|spot|sun|emission]

    --bounces N  Cycles max_bounces (and every per-type limit) = N; default 8 (diffuse/glossy 4)
    --only X     keep only one light source (the others are deleted, the emitter's strength is 0
                 unless X is 'emission'), to compare renderers light by light
    --thin-glass export the glass sphere without its thickness (glTF then says thin-walled glass,
                 which Cycles does not render: it always treats Blender glass as solid)

Writes:
    OUTDIR/scene.blend   the scene as built here
    OUTDIR/scene.glb     Blender's own glTF exporter, export_lights=True, export_cameras=True,
                         default lighting mode ('SPEC': W -> cd via /(4*pi)*683, sun W/m^2 -> lx *683)
    OUTDIR/cycles.exr    Cycles CPU render, fixed seed, no denoiser, linear float EXR
                         (view transform 'Standard', look None, exposure 0, gamma 1)
and prints one line "RESULT_JSON {...}" with the per-channel image means and a summary of what the
exporter wrote (light intensities, spot cones, camera yfov/aspectRatio, material extensions).

Conventions kept so that the glTF is a faithful description of what Cycles renders:
  * lamp radius / sun angle 0 (glTF punctual lights are points / directions),
  * no world light (world colour black, glTF has no environment),
  * all materials are a single Principled BSDF so the exporter maps them directly.
Known, intentional mismatch left in: Cycles' spot multiplies its intensity by cos(theta) off-axis
and uses smoothstep over (1-cos(size/2))*blend, while glTF spots use innerConeAngle/outerConeAngle.
"""

import json
import math
import os
import struct
import sys
import time

import addon_utils
import bpy
from mathutils import Vector

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
OUTDIR = os.path.abspath(argv[0] if argv and not argv[0].startswith("--") else "blender-out")
SPP = int(argv[argv.index("--spp") + 1]) if "--spp" in argv else 128
BOUNCES = int(argv[argv.index("--bounces") + 1]) if "--bounces" in argv else None
ONLY = argv[argv.index("--only") + 1] if "--only" in argv else None
THIN_GLASS = "--thin-glass" in argv
assert ONLY in (None, "point", "spot", "sun", "emission"), ONLY
WIDTH, HEIGHT = 160, 90
os.makedirs(OUTDIR, exist_ok=True)

t0 = time.time()
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
coll = scene.collection


# ---------------------------------------------------------------- materials
def principled(name, base=(0.8, 0.8, 0.8), metallic=0.0, roughness=0.5, transmission=0.0,
               ior=1.45, emission=(0.0, 0.0, 0.0), emission_strength=1.0):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    nt = m.node_tree
    nt.nodes.clear()
    p = nt.nodes.new("ShaderNodeBsdfPrincipled")
    p.inputs["Base Color"].default_value = (*base, 1.0)
    p.inputs["Metallic"].default_value = metallic
    p.inputs["Roughness"].default_value = roughness
    p.inputs["Transmission"].default_value = transmission
    p.inputs["IOR"].default_value = ior
    p.inputs["Emission"].default_value = (*emission, 1.0)
    p.inputs["Emission Strength"].default_value = emission_strength
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(p.outputs["BSDF"], out.inputs["Surface"])
    return m


floor_mat = principled("Floor", base=(0.8, 0.8, 0.8), roughness=1.0)
box_mat = principled("Box", base=(0.8, 0.25, 0.1), roughness=1.0)
emit_mat = principled("Emitter", base=(0.0, 0.0, 0.0), roughness=1.0,
                      emission=(1.0, 0.6, 0.2), emission_strength=5.0)
glass_mat = principled("Glass", base=(1.0, 1.0, 1.0), roughness=0.0, transmission=1.0, ior=1.5)


def mark_solid(material, thickness):
    """Tell glTF the object is solid, as an author does in Blender: the exporter's own "glTF Material
    Output" node group with a Thickness, which it writes as KHR_materials_volume (without it, glTF
    transmission is a thin wall, while Cycles renders a solid)."""
    from io_scene_gltf2.blender.com.gltf2_blender_material_helpers import create_settings_group, get_gltf_node_name
    group = bpy.data.node_groups.get(get_gltf_node_name()) or create_settings_group(get_gltf_node_name())
    node = material.node_tree.nodes.new("ShaderNodeGroup")
    node.node_tree = group
    node.inputs["Thickness"].default_value = thickness


if not THIN_GLASS:
    mark_solid(glass_mat, 1.0)  # the glass sphere's diameter
metal_mat = principled("Metal", base=(0.9, 0.9, 0.9), metallic=1.0, roughness=0.3)


# ---------------------------------------------------------------- geometry
def add(obj, mat):
    obj.data.materials.append(mat)
    return obj


bpy.ops.mesh.primitive_plane_add(size=10.0, location=(0, 0, 0))
add(bpy.context.active_object, floor_mat).name = "Floor"
bpy.ops.mesh.primitive_cube_add(size=1.0, location=(-1.6, 0.6, 0.5), rotation=(0, 0, math.radians(25)))
add(bpy.context.active_object, box_mat).name = "Box"
for name, mat, loc in [("EmissiveSphere", emit_mat, (1.7, 1.0, 0.5)),
                       ("GlassSphere", glass_mat, (-0.1, -0.6, 0.5)),
                       ("MetalSphere", metal_mat, (1.3, -1.1, 0.5))]:
    bpy.ops.mesh.primitive_uv_sphere_add(segments=48, ring_count=24, radius=0.5, location=loc)
    ob = add(bpy.context.active_object, mat)
    ob.name = name
    bpy.ops.object.shade_smooth()


# ---------------------------------------------------------------- lights
def look_at(obj, target):
    d = Vector(target) - obj.location
    obj.rotation_euler = d.to_track_quat("-Z", "Y").to_euler()


def lamp(name, kind, energy, loc, target=None, **props):
    ld = bpy.data.lights.new(name, kind)
    ld.energy = energy
    ld.color = (1.0, 1.0, 1.0)
    if kind == "SUN":
        ld.angle = 0.0
    else:
        ld.shadow_soft_size = 0.0
    for k, v in props.items():
        setattr(ld, k, v)
    ob = bpy.data.objects.new(name, ld)
    ob.location = loc
    coll.objects.link(ob)
    if target is not None:
        look_at(ob, target)
    return ob


lamp("Point", "POINT", 300.0, (-2.0, -2.0, 3.0))                 # W
lamp("Spot", "SPOT", 500.0, (2.0, -1.0, 4.0), target=(1.0, -0.5, 0.0),
     spot_size=math.radians(50.0), spot_blend=0.2)                 # W
sun = lamp("Sun", "SUN", 1.0, (0.0, 0.0, 10.0))                    # W/m^2
sun.rotation_euler = (math.radians(40.0), 0.0, math.radians(30.0))

if ONLY is not None:
    for ob in [o for o in bpy.data.objects if o.type == "LIGHT" and o.name.lower() != ONLY]:
        bpy.data.objects.remove(ob)
    if ONLY != "emission":
        emit_mat.node_tree.nodes["Principled BSDF"].inputs["Emission Strength"].default_value = 0.0

# ---------------------------------------------------------------- world: black
world = bpy.data.worlds.new("Black")
world.use_nodes = True
bg = world.node_tree.nodes["Background"]
bg.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
bg.inputs["Strength"].default_value = 0.0
scene.world = world

# ---------------------------------------------------------------- camera 16:9
cam_data = bpy.data.cameras.new("Camera")
cam_data.lens = 35.0
cam_data.sensor_width = 36.0
cam_data.sensor_fit = "AUTO"       # horizontal for a landscape image
cam_data.clip_start = 0.05
cam_data.clip_end = 100.0
cam = bpy.data.objects.new("Camera", cam_data)
cam.location = (0.0, -7.5, 3.2)
coll.objects.link(cam)
look_at(cam, (0.0, 0.0, 0.6))
scene.camera = cam

# ---------------------------------------------------------------- render settings
r = scene.render
r.engine = "CYCLES"
r.resolution_x, r.resolution_y, r.resolution_percentage = WIDTH, HEIGHT, 100
r.pixel_aspect_x = r.pixel_aspect_y = 1.0
r.film_transparent = False
r.use_persistent_data = False
c = scene.cycles
c.device = "CPU"
c.samples = SPP
c.use_adaptive_sampling = False
c.use_denoising = False
c.seed = 0
c.use_animated_seed = False
c.max_bounces = 8
c.diffuse_bounces = 4
c.glossy_bounces = 4
c.transmission_bounces = 8
c.transparent_max_bounces = 8
c.caustics_reflective = True
c.caustics_refractive = True
c.sample_clamp_direct = 0.0
c.sample_clamp_indirect = 0.0
c.blur_glossy = 0.0
if BOUNCES is not None:
    c.max_bounces = c.diffuse_bounces = c.glossy_bounces = c.transmission_bounces = BOUNCES
scene.view_settings.view_transform = "Standard"
scene.view_settings.look = "None"
scene.view_settings.exposure = 0.0
scene.view_settings.gamma = 1.0
scene.display_settings.display_device = "sRGB"
scene.sequencer_colorspace_settings.name = "Linear"
im = r.image_settings
im.file_format = "OPEN_EXR"
im.color_mode = "RGBA"
im.color_depth = "32"
im.exr_codec = "ZIP"

# ---------------------------------------------------------------- save + export
blend_path = os.path.join(OUTDIR, "scene.blend")
glb_path = os.path.join(OUTDIR, "scene.glb")
exr_path = os.path.join(OUTDIR, "cycles.exr")
bpy.ops.wm.save_as_mainfile(filepath=blend_path)

addon_utils.enable("io_scene_gltf2", default_set=True)
bpy.ops.export_scene.gltf(filepath=glb_path, export_format="GLB",
                          export_cameras=True, export_lights=True,
                          export_apply=True, export_yup=True)
# (lighting mode left at its default, convert_lighting_mode='SPEC')

# ---------------------------------------------------------------- render
t_render = time.time()
r.filepath = exr_path
bpy.ops.render.render(write_still=True)
t_render = time.time() - t_render

img = bpy.data.images.load(exr_path)
w, h = img.size
px = img.pixels[:]
n = w * h
means = [sum(px[ch::4]) / n for ch in range(3)]


# ---------------------------------------------------------------- summarise what the exporter wrote
def glb_json(path):
    with open(path, "rb") as f:
        data = f.read()
    length, ctype = struct.unpack_from("<I4s", data, 12)
    assert ctype == b"JSON"
    return json.loads(data[20:20 + length])


g = glb_json(glb_path)
lights = g.get("extensions", {}).get("KHR_lights_punctual", {}).get("lights", [])
summary = {
    "outdir": OUTDIR,
    "blender": bpy.app.version_string,
    "resolution": [w, h],
    "spp": SPP,
    "only": ONLY,
    "max_bounces": [c.max_bounces, c.diffuse_bounces, c.glossy_bounces, c.transmission_bounces],
    "mean_rgb": means,
    "render_seconds": round(t_render, 2),
    "total_seconds": round(time.time() - t0, 2),
    "blender_lamps": {o.name: {"type": o.data.type, "energy": o.data.energy,
                               **({"spot_size_deg": math.degrees(o.data.spot_size),
                                   "spot_blend": o.data.spot_blend} if o.data.type == "SPOT" else {})}
                      for o in bpy.data.objects if o.type == "LIGHT"},
    "gltf_lights": lights,
    "gltf_cameras": g.get("cameras", []),
    "gltf_materials": [{k: m[k] for k in ("name", "pbrMetallicRoughness", "emissiveFactor", "extensions")
                        if k in m} for m in g.get("materials", [])],
    "gltf_extensionsUsed": g.get("extensionsUsed", []),
}
with open(os.path.join(OUTDIR, "summary.json"), "w") as f:
    json.dump(summary, f, indent=1)
print("RESULT_JSON " + json.dumps(summary))
