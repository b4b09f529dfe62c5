"""Blender materials glTF cannot describe, written as lensfarm materials (docs/blender.md).

Blender's glTF exporter understands the Principled BSDF (and Emission); other shader nodes it
replaces by a default. Where the material's output is fed directly by a node lensfarm has an exact
counterpart of, the add-on writes that material and maps the model's material to it by name
(the gltf shape's `materials`): Glass BSDF -> dielectric, Diffuse BSDF -> lambertian, smooth
Glossy BSDF -> mirror, rough Glossy BSDF -> conductor (F0 = colour), Emission -> two-sided
emissive (Cycles emits from both faces). Everything else is left to the exporter and, when the
exporter drops something, listed by name.
"""

from . import convert

SMOOTH = 0.0316  # below this perceptual roughness lensfarm's microfacet surfaces are smooth


def _rgb(socket, notes, where):
    c = list(socket.default_value)[:3]
    if any(v > 1 for v in c):
        notes.append(f"{where}: a colour above 1 is clamped to 1 (it would make light)")
    return convert.clean([0.0 if v < 1e-6 else min(1.0, v) for v in c])


def _surface_node(material):
    if not material.use_nodes or material.node_tree is None:
        return None
    nodes = material.node_tree.nodes
    outputs = [n for n in nodes if n.type == "OUTPUT_MATERIAL" and n.target in ("ALL", "CYCLES")]
    output = next((n for n in outputs if n.is_active_output), outputs[0] if outputs else None)
    if output is None or not output.inputs["Surface"].is_linked:
        return None
    if output.inputs["Volume"].is_linked:
        return output.inputs["Surface"].links[0].from_node, "volume"
    return output.inputs["Surface"].links[0].from_node, None


def _used_materials(scene):
    seen = {}
    for ob in scene.objects:
        if ob.hide_render or ob.type not in ("MESH", "CURVE", "SURFACE", "META", "FONT"):
            continue
        for slot in ob.material_slots:
            if slot.material is not None:
                seen[slot.material.name] = slot.material
    return seen


def material_overrides(scene, notes):
    """({lensfarm name: material}, {model material name: lensfarm name})."""
    materials, overrides = {}, {}
    principled = []
    for name, material in sorted(_used_materials(scene).items()):
        found = _surface_node(material)
        if found is None:
            continue
        node, volume = found
        where = f"material '{name}'"
        if volume:
            notes.append(f"{where}: its Volume output is not carried (lensfarm media are written in the scene file)")
        inputs = node.inputs
        written = None
        if node.type == "BSDF_PRINCIPLED":
            principled.append(name)
            for socket, label in (("Subsurface", "Subsurface"), ("Sheen", "Sheen"), ("Clearcoat", "Clearcoat"),
                                  ("Anisotropic", "Anisotropic")):
                if socket in inputs and (inputs[socket].is_linked or inputs[socket].default_value > 0):
                    notes.append(f"{where}: Principled {label} is not carried")
        elif node.type == "BSDF_GLASS":
            if inputs["Color"].is_linked or inputs["Roughness"].is_linked or inputs["IOR"].is_linked:
                notes.append(f"{where}: a texture on Glass BSDF is not carried (its default values are)")
            written = {"type": "dielectric", "ior": max(1.0, min(10.0, inputs["IOR"].default_value)),
                       "transmittance": _rgb(inputs["Color"], notes, where),
                       "roughness": convert.clean(min(1.0, max(0.0, inputs["Roughness"].default_value)))}
        elif node.type == "BSDF_DIFFUSE":
            if inputs["Color"].is_linked:
                continue  # a texture: the exporter carries Image Textures of a Diffuse BSDF's colour
            if inputs["Roughness"].default_value > 0:
                notes.append(f"{where}: Diffuse BSDF Roughness (Oren-Nayar) is not carried: Lambertian")
            written = {"type": "lambertian", "albedo": _rgb(inputs["Color"], notes, where)}
        elif node.type == "BSDF_GLOSSY":
            roughness = min(1.0, max(0.0, inputs["Roughness"].default_value))
            colour = _rgb(inputs["Color"], notes, where)
            if roughness < SMOOTH:
                written = {"type": "mirror", "reflectance": colour}
            else:
                notes.append(f"{where}: rough Glossy BSDF as a conductor of F0 = its colour (Cycles' has no "
                             "Fresnel: lensfarm's brightens towards grazing)")
                written = {"type": "conductor", "reflectance": colour, "roughness": convert.clean(roughness)}
        elif node.type == "EMISSION":
            strength = inputs["Strength"].default_value
            colour = [c * strength for c in list(inputs["Color"].default_value)[:3]]
            written = {"type": "emissive", "radiance": convert.clean(colour), "two_sided": True}
        else:
            notes.append(f"{where}: its {node.bl_label} node is not carried; rendered as Blender's glTF exporter "
                         "writes it")
        if written is not None:
            key = f"blender: {name}"
            materials[key] = written
            overrides[name] = key
    if principled:
        notes.append("Principled BSDF (" + ", ".join(principled) + "): rendered as glTF's metallic-roughness model "
                     "(a Lambertian base under a Fresnel-weighted specular layer); Cycles' diffuse is Burley's, "
                     "brighter towards grazing light (docs/other-renderers.md)")
    return materials, overrides
