"""A Blender scene as a lensfarm job (docs/blender.md "What is carried").

The geometry, materials and textures go through Blender's own glTF exporter (modifiers applied,
instancing kept, only what renders); what glTF does not carry is written into the lensfarm scene
beside it: the camera with its depth of field, the lamps in Cycles' units (area lamps, which glTF
lacks, and point/spot/sun lamps exactly as Cycles means them), the world, the render settings and
the motion of the camera and lamps over the frames. Every setting that cannot be carried is
listed by name in Job.notes, so the user is told before anything is submitted.
"""

import math
import os
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Tuple

import bpy
from mathutils import Matrix

from . import convert
from .materials import material_overrides

MODEL_FILE = "scene.glb"
SCENE_FILE = "scene.json"


@dataclass
class Job:
    scene: dict                                       # the lensfarm-scene/1 JSON
    assets: Dict[str, str] = field(default_factory=dict)  # path in the scene: file on disk
    frames: Optional[Tuple[int, int, int]] = None     # (first, last, step); None: a still
    notes: List[str] = field(default_factory=list)    # every setting not carried, by name


class ExportError(Exception):
    """The scene cannot be rendered at all (no camera, an orthographic camera, ...)."""


def frame_range(scene, settings) -> Optional[Tuple[int, int, int]]:
    if settings.frames == "STILL":
        return None
    if settings.frames == "SCENE":
        return (scene.frame_start, scene.frame_end, max(1, scene.frame_step))
    if settings.frame_last < settings.frame_first:
        raise ExportError(f"Frames: the last frame {settings.frame_last} is before the first {settings.frame_first}")
    return (settings.frame_first, settings.frame_last, max(1, settings.frame_step))


def build_job(context, settings, folder: str) -> Job:
    """Writes the model into `folder` and returns the job; raises ExportError."""
    scene = context.scene
    if scene.camera is None:
        raise ExportError("the scene has no camera (Scene properties > Camera)")
    frames = frame_range(scene, settings)
    job = Job(scene={"format": "lensfarm-scene/1"}, frames=frames)
    original = scene.frame_current
    sampled = list(range(frames[0], frames[1] + 1, frames[2])) if frames else [original]
    try:
        movers = moving_objects(scene, sampled)
        scene.frame_set(sampled[0])
        export_model(context, folder, job, movers)
        job.scene["render"] = render_settings(scene, settings, job.notes)
        job.scene["camera"] = camera(scene, sampled, job.notes)
        job.scene["lights"] = lamps(scene, sampled, job.notes)
        world(scene, folder, job)
        materials, overrides = material_overrides(scene, job.notes)
        used = set()
        for shape in job.scene["shapes"]:
            exported = _glb_material_names(job.assets[shape["file"]])
            mine = {k: v for k, v in overrides.items() if k in exported}
            if mine:
                shape["materials"] = mine
                used |= set(mine.values())
        if used:
            job.scene["materials"] = {k: v for k, v in materials.items() if k in used}
    finally:
        scene.frame_set(original)
    if not job.scene["lights"]:
        del job.scene["lights"]
    # The scene as submitted, beside its model: `lensfarm render scene.json` renders it again.
    import json

    with open(os.path.join(folder, SCENE_FILE), "w") as f:
        json.dump(job.scene, f, indent=2)
    return job


def _export_glb(path, selected):
    """Blender's glTF exporter on the renderable objects `selected` (all of them: None), modifiers
    applied, Y up; lamps and the camera are the add-on's own (below), motion is sampled per frame."""
    kwargs = {}
    if selected is not None:
        kwargs["use_selection"] = True
        for ob in bpy.context.view_layer.objects:
            ob.select_set(ob in selected)
    bpy.ops.export_scene.gltf(filepath=path, export_format="GLB", use_renderable=True, use_visible=False,
                              export_apply=True, export_yup=True, export_cameras=False, export_lights=False,
                              export_animations=False, export_extras=False, export_materials="EXPORT",
                              export_image_format="AUTO", **kwargs)


def export_model(context, folder, job, movers):
    """The still part of the scene as scene.glb; each object that moves over the frames as a model
    of its own, in its own space, placed at every frame by keyframes."""
    path = os.path.join(folder, MODEL_FILE)
    if movers:
        was = [ob for ob in context.view_layer.objects if ob.select_get()]
        still = [ob for ob in context.view_layer.objects if ob.name not in movers]
        _export_glb(path, still)
    else:
        _export_glb(path, None)
    job.assets[MODEL_FILE] = path
    job.scene["shapes"] = [{"type": "gltf", "file": MODEL_FILE}]
    for i, (name, track) in enumerate(sorted(movers.items())):
        ob = context.scene.objects[name]
        rel = f"moving-{i}.glb"
        _export_glb(os.path.join(folder, rel), [ob])
        _strip_root_transforms(os.path.join(folder, rel))
        job.assets[rel] = os.path.join(folder, rel)
        job.scene["shapes"].append({"type": "gltf", "file": rel, "name": name,
                                    "keyframes": [{"frame": f, "transform": _transform(m)} for f, m in track]})
    if movers:
        for ob in context.view_layer.objects:
            ob.select_set(ob in was)


def _strip_root_transforms(path):
    """The .glb with its root nodes' transforms removed: the object in its own space (Y up), which
    the shape's keyframes then place. (The exporter bakes the object's world transform into its
    node; an animated object cannot be moved to the origin for it, its animation would win.)"""
    import json
    import struct

    with open(path, "rb") as f:
        data = f.read()
    length = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20:20 + length])
    roots = doc.get("scenes", [{}])[doc.get("scene", 0)].get("nodes", [])
    for i in roots:
        for key in ("translation", "rotation", "scale", "matrix"):
            doc["nodes"][i].pop(key, None)
    text = json.dumps(doc, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)  # chunks are 4-byte aligned (glTF 2.0, GLB)
    rest = data[20 + length:]
    out = data[:8] + struct.pack("<I", 12 + 8 + len(text) + len(rest)) + struct.pack("<I", len(text)) + b"JSON" + text
    with open(path, "wb") as f:
        f.write(out + rest)


# Blender's Z-up frame to the scene's Y-up one: (x, y, z) -> (x, z, -y).
def _to_y_up():
    return Matrix(((1, 0, 0, 0), (0, 0, 1, 0), (0, -1, 0, 0), (0, 0, 0, 1)))


def _transform(m):
    """A world matrix as lensfarm's transform (M = T R S, scene/transform.h) in the Y-up frame."""
    c = _to_y_up()
    loc, rot, scale = (c @ m @ c.inverted()).decompose()
    axis, angle = rot.to_axis_angle()
    out = {"translate": convert.clean(list(loc)), "scale": convert.clean(list(scale))}
    if abs(angle) > 1e-12:
        out["rotate"] = {"axis": convert.clean(list(axis)), "degrees": convert.clean(math.degrees(angle))}
    return out


def _glb_material_names(path):
    """The material names of the exported .glb (its JSON chunk)."""
    import json
    import struct

    with open(path, "rb") as f:
        head = f.read(20)
        length = struct.unpack_from("<I", head, 12)[0]
        doc = json.loads(f.read(length))
    return {m.get("name", "") for m in doc.get("materials", [])}


# ---- render settings ---------------------------------------------------------------------------

def render_settings(scene, settings, notes) -> dict:
    r = scene.render
    width = max(1, round(r.resolution_x * r.resolution_percentage / 100))
    height = max(1, round(r.resolution_y * r.resolution_percentage / 100))
    cycles = getattr(scene, "cycles", None)
    out = {"resolution": [width, height]}
    if settings.samples_from == "CYCLES" and cycles is not None:
        out["samples_per_pixel"] = int(cycles.samples)
    else:
        out["samples_per_pixel"] = int(settings.samples)
    if settings.target_error > 0:
        out["target_error"] = settings.target_error / 100.0
    if settings.deadline > 0:
        out["time_limit"] = float(settings.deadline)
    if cycles is not None:
        # Cycles' Max Bounces counts the bounces after the first hit; lensfarm's B counts that hit
        # too (docs/other-renderers.md: Total = B - 1).
        out["max_bounces"] = int(cycles.max_bounces) + 1
        out["seed"] = int(cycles.seed)
        cycles_notes(scene, cycles, notes)
    else:
        notes.append(f"Render engine {scene.render.engine}: its settings are not read (lensfarm takes Cycles')")
    if r.pixel_aspect_x != r.pixel_aspect_y:
        notes.append("Format > Aspect X/Y: pixels are square in lensfarm")
    if r.use_border:
        notes.append("Output > Render Region: lensfarm renders the whole frame")
    if r.film_transparent:
        notes.append("Film > Transparent: lensfarm's background is the world (no alpha)")
    if r.use_motion_blur:
        notes.append("Motion Blur: not rendered (each frame is an instant)")
    aovs = [name for name, on in (("albedo", settings.aov_albedo), ("normal", settings.aov_normal),
                                  ("depth", settings.aov_depth), ("variance", settings.aov_variance)) if on]
    if settings.denoise:
        aovs = sorted(set(aovs) | {"albedo", "normal", "variance"})  # what lensfarm denoise is guided by
    if aovs:
        out["aovs"] = aovs
    if settings.tile_size > 0:
        out["tile_size"] = int(settings.tile_size)
    return out


def cycles_notes(scene, c, notes):
    """The Cycles settings lensfarm has no counterpart of, when they are not at the values lensfarm
    renders as."""
    if c.use_adaptive_sampling:
        notes.append("Cycles' Sampling > Noise Threshold: lensfarm stops the whole image at its Target error instead")
    if c.use_denoising:
        notes.append("Cycles' Sampling > Denoise: use the panel's Denoise (lensfarm's denoiser on the farm's image)")
    for name, label in (("diffuse_bounces", "Diffuse"), ("glossy_bounces", "Glossy"),
                        ("transmission_bounces", "Transmission")):
        value = getattr(c, name, None)
        if value is not None and value < c.max_bounces:
            notes.append(f"Cycles' Light Paths > Max Bounces > {label} ({value}): lensfarm limits only the total")
    if not c.caustics_reflective or not c.caustics_refractive:
        notes.append("Cycles' Light Paths > Caustics toggles: not used (lensfarm renders every caustic)")
    if c.blur_glossy > 0:
        notes.append("Cycles' Light Paths > Filter Glossy: not used")
    if c.sample_clamp_direct > 0 or c.sample_clamp_indirect > 0:
        notes.append("Cycles' Light Paths > Clamping: not used (lensfarm's samples are unclamped)")
    if getattr(c, "use_light_tree", False) is False and hasattr(c, "use_light_tree"):
        notes.append("Cycles' Light Tree off: lensfarm chooses by itself")
    if c.pixel_filter_type != "BOX" or abs(c.filter_width - 1.0) > 1e-6:
        notes.append(f"Cycles' Film > Pixel Filter ({c.pixel_filter_type.replace('_', '-').title()}, "
                     f"{c.filter_width:g} px): lensfarm's pixel is a 1-pixel box (edges are a little sharper)")
    if c.film_exposure != 1.0:
        notes.append("Cycles' Film > Exposure: not applied to the EXR (it is linear radiance)")
    if scene.view_settings.view_transform not in ("Standard", "Raw"):
        notes.append(f"Color Management > View Transform {scene.view_settings.view_transform}: the EXR is linear "
                     "scene radiance; lensfarm's PNG preview has its own tone map")


# ---- the camera --------------------------------------------------------------------------------

def _frame_of(ob):
    m = ob.matrix_world
    position = m.translation
    forward = -(m.to_3x3() @ _vec(0, 0, 1)).normalized()
    up = (m.to_3x3() @ _vec(0, 1, 0)).normalized()
    return position, forward, up


def _vec(x, y, z):
    from mathutils import Vector

    return Vector((x, y, z))


def camera(scene, frames, notes) -> dict:
    ob = scene.camera
    cam = ob.data
    r = scene.render
    width = max(1, round(r.resolution_x * r.resolution_percentage / 100))
    height = max(1, round(r.resolution_y * r.resolution_percentage / 100))
    if cam.type != "PERSP":
        raise ExportError(f"camera '{ob.name}': {cam.type.lower()} cameras are not rendered (only perspective)")
    if cam.shift_x or cam.shift_y:
        notes.append(f"camera '{ob.name}' Shift X/Y: not carried (lensfarm's lens is centred)")
    unit = scene.unit_settings.scale_length or 1.0
    dof = cam.dof
    keys = []
    for f in frames:
        scene.frame_set(f)
        position, forward, up = _frame_of(ob)
        horizontal = convert.sensor_fit_horizontal(cam.sensor_fit, width, height)
        sensor = cam.sensor_height if cam.sensor_fit == "VERTICAL" else cam.sensor_width
        key = {"frame": f}
        if dof.use_dof:
            focus = dof.focus_distance
            if dof.focus_object is not None:
                focus = max(1e-4, (dof.focus_object.matrix_world.translation - position).dot(forward))
            fstop = dof.aperture_fstop
            if fstop < 0.5:
                if f == frames[0]:
                    notes.append(f"camera '{ob.name}' F-stop {fstop:g}: below f/0.5, the widest a lens in air can be; "
                                 "rendered at f/0.5")
                fstop = 0.5
            fields = convert.thin_lens(cam.lens, sensor, horizontal, width, height, fstop,
                                       max(focus, cam.lens / 1000.0 / unit * 1.001), unit)
            look_at = position + forward * fields["focus_distance"]
            key.update(fields)
        else:
            look_at = position + forward
            key["angle_of_view"] = convert.angle_of_view(cam.lens, sensor)
        key["position"] = convert.y_up(position)
        key["look_at"] = convert.y_up(look_at)
        key["up"] = convert.y_up(up)
        keys.append(convert.clean(key))
    out = {"type": "thin_lens" if dof.use_dof else "pinhole"}
    if dof.use_dof:
        if dof.aperture_blades >= 3:
            out["aperture_blades"] = int(dof.aperture_blades)
            out["aperture_rotation"] = convert.clean(math.degrees(dof.aperture_rotation))
        if abs(dof.aperture_ratio - 1.0) > 1e-6:
            notes.append(f"camera '{ob.name}' Aperture Ratio {dof.aperture_ratio:g}: lensfarm's aperture is round")
    else:
        horizontal = convert.sensor_fit_horizontal(cam.sensor_fit, width, height)
        out["fov_axis"] = "horizontal" if horizontal else "vertical"
    return _static_or_keyed(out, keys)


def _static_or_keyed(out, keys):
    """One object: values the same at every frame written once, the others as keyframes."""
    names = [k for k in keys[0] if k != "frame"]
    moving = [n for n in names if any(k[n] != keys[0][n] for k in keys)]
    for n in names:
        if n not in moving:
            out[n] = keys[0][n]
    if moving:
        out["keyframes"] = [{"frame": k["frame"], **{n: k[n] for n in moving}} for k in keys]
    return out


# ---- lamps and the world -----------------------------------------------------------------------

def lamps(scene, frames, notes) -> list:
    out = []
    for ob in scene.objects:
        if ob.type != "LIGHT" or ob.hide_render or not ob.visible_get():
            continue
        light = ob.data
        colour = list(light.color)
        keys = []
        for f in frames:
            scene.frame_set(f)
            keys.append(convert.clean(_lamp_at(ob, light, colour, notes if f == frames[0] else [])))
            keys[-1]["frame"] = f
        static = {k: v for k, v in keys[0].items() if k != "frame"}
        kind = static["type"]
        movable = {"point": ["position"], "spot": ["position", "look_at"],
                   "quad": ["corner", "edge1", "edge2"]}.get(kind, [])
        moving = [n for n in static if any(k[n] != static[n] for k in keys)]
        if moving and (kind == "directional" or any(n not in movable for n in moving)):
            notes.append(f"light '{ob.name}': its {', '.join(moving)} changes over the frames; lensfarm keeps "
                         "its first frame's (a sun cannot move, nor a lamp's power)")
            moving = []
        for n in moving:
            del static[n]
        if moving:
            static["keyframes"] = [{"frame": k["frame"], **{n: k[n] for n in moving}} for k in keys]
        out.append(static)
    return out


def _lamp_at(ob, light, colour, notes) -> dict:
    m = ob.matrix_world
    position = m.translation
    axis = (m.to_3x3() @ _vec(0, 0, -1)).normalized()
    name = ob.name
    if getattr(light, "use_nodes", False) and light.node_tree and len(light.node_tree.nodes) > 2:
        notes.append(f"light '{name}': its node tree is not read (Color and Power are)")
    if light.type in ("POINT", "SPOT"):
        if light.shadow_soft_size > 0:
            notes.append(f"light '{name}' Radius {light.shadow_soft_size:g} m: rendered as a point (hard shadows)")
        lamp = {"type": "point", "name": name, "position": convert.y_up(position),
                "intensity": convert.point_intensity(colour, light.energy)}
        if light.type == "SPOT":
            cone, start = convert.spot_cone(light.spot_size, light.spot_blend)
            # Cycles 3.4's spot_attenuation starts from cos(theta) off the axis before its smoothstep;
            # lensfarm's spot (pbrt-v4's) has no such factor.
            edge = 100.0 * (1.0 / math.cos(math.radians(min(cone, 89.0))) - 1.0)
            notes.append(f"light '{name}': Cycles 3.4 dims a spot by cos(angle) off its axis, lensfarm does not "
                         f"(up to {edge:.0f} % brighter at its {cone:.0f} degree edge)")
            lamp.update(type="spot", look_at=convert.y_up(position + axis), cone_angle=cone, falloff_start=start)
        return lamp
    if light.type == "SUN":
        lamp = {"type": "directional", "name": name, "direction": convert.y_up(-axis),
                "irradiance": convert.sun_irradiance(colour, light.energy)}
        if light.angle > 0:
            lamp["angular_diameter"] = min(90.0, math.degrees(light.angle))
        return lamp
    # AREA: a rectangle in the lamp's XY plane, emitting along its -Z axis.
    sx = light.size
    sy = light.size if light.shape in ("SQUARE", "DISK") else light.size_y
    if light.shape in ("DISK", "ELLIPSE"):
        notes.append(f"light '{name}' Shape {light.shape.title()}: rendered as the rectangle of the same area and power")
        sx, sy = sx * math.sqrt(math.pi) / 2, sy * math.sqrt(math.pi) / 2
    if getattr(light, "spread", math.pi) < math.pi - 1e-6:
        notes.append(f"light '{name}' Spread {math.degrees(light.spread):g} degrees: lensfarm's area lamp emits into "
                     "the whole hemisphere")
    m3 = m.to_3x3()
    ex, ey = m3 @ _vec(sx, 0, 0), m3 @ _vec(0, sy, 0)
    corner = position - ex / 2 - ey / 2
    area = ex.cross(ey).length
    # edge1 x edge2 must point along the emitting -Z side: y x x = -z.
    return {"type": "quad", "name": name, "corner": convert.y_up(corner), "edge1": convert.y_up(ey),
            "edge2": convert.y_up(ex), "radiance": convert.area_radiance(colour, light.energy, max(area, 1e-12)),
            "visible_to_camera": False}


def world(scene, folder, job):
    w = scene.world
    if w is None:
        return
    if not w.use_nodes or w.node_tree is None:
        colour = list(w.color)
        if max(colour) > 0:
            job.scene["environment"] = {"radiance": convert.clean(colour)}
        return
    nodes = w.node_tree.nodes
    output = next((n for n in nodes if n.type == "OUTPUT_WORLD" and n.is_active_output), None)
    link = output.inputs["Surface"].links[0] if output and output.inputs["Surface"].is_linked else None
    if link is None:
        return
    bg = link.from_node
    if bg.type != "BACKGROUND":
        job.notes.append(f"World '{w.name}': its {bg.name} node is not read (only a Background node is)")
        return
    strength = bg.inputs["Strength"].default_value
    if bg.inputs["Strength"].is_linked:
        job.notes.append(f"World '{w.name}': a linked Strength is not read ({strength:g} is used)")
    colour_in = bg.inputs["Color"]
    if not colour_in.is_linked:
        colour = [c * strength for c in list(colour_in.default_value)[:3]]
        if max(colour) > 0:
            job.scene["environment"] = {"radiance": convert.clean(colour)}
        return
    tex = colour_in.links[0].from_node
    if tex.type != "TEX_ENVIRONMENT" or tex.image is None:
        job.notes.append(f"World '{w.name}': the {tex.name} node feeding the Background is not read (only an "
                         "Environment Texture is); the world is black")
        return
    path = bpy.path.abspath(tex.image.filepath, library=tex.image.library)
    ext = os.path.splitext(path)[1].lower()
    if ext not in (".exr", ".hdr") or not os.path.isfile(path):
        job.notes.append(f"World '{w.name}': the environment image {tex.image.name} is not an .exr or .hdr file on "
                         "disk; the world is black")
        return
    if tex.projection != "EQUIRECTANGULAR":
        job.notes.append(f"World '{w.name}': {tex.projection.title()} projection is not read (equirectangular is)")
    rel = "world" + ext
    # A copy beside the scene, so the folder renders on its own (`lensfarm render scene.json`).
    import shutil

    shutil.copyfile(path, os.path.join(folder, rel))
    job.assets[rel] = os.path.join(folder, rel)
    # Cycles looks an equirectangular image up at u = 0.5 - atan2(y, x) / 2 pi (Z up), lensfarm at
    # u = 0.5 + atan2(x, -z) / 2 pi (Y up, docs/scene-format.md "Conventions"), a quarter turn
    # apart: the same image is seen as Blender shows it turned by -90 degrees, and a Mapping
    # node's turn of the lookup by +theta about Z turns the sky by -theta.
    rotation = -90.0 - _mapping_z_rotation(tex, job.notes, w.name)
    rotation = math.remainder(rotation, 360.0)
    job.scene["environment"] = convert.clean({"file": rel, "strength": float(strength), "rotation": rotation})


def _mapping_z_rotation(tex, notes, world_name) -> float:
    """The world's turn about Blender's up axis, in degrees, from a Mapping node before the texture."""
    vector = tex.inputs["Vector"]
    if not vector.is_linked:
        return 0.0
    node = vector.links[0].from_node
    if node.type != "MAPPING":
        return 0.0
    rot = node.inputs["Rotation"].default_value
    if abs(rot[0]) > 1e-6 or abs(rot[1]) > 1e-6:
        notes.append(f"World '{world_name}': the Mapping's X/Y rotation is not carried (Z is)")
    return math.degrees(rot[2])


def moving_objects(scene, frames):
    """{name: [(frame, world matrix)]} of the renderable objects whose place changes over `frames`."""
    if len(frames) < 2:
        return {}
    tracks = {}
    for f in frames:
        scene.frame_set(f)
        for ob in scene.objects:
            if ob.type in ("MESH", "CURVE", "SURFACE", "META", "FONT") and not ob.hide_render:
                tracks.setdefault(ob.name, []).append((f, ob.matrix_world.copy()))
    return {name: track for name, track in tracks.items() if any(m != track[0][1] for _, m in track)}
