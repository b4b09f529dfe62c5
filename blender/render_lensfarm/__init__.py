"""Render on lensfarm: submit the scene to a lensfarm render farm from Render properties, follow it,
and get its linear OpenEXR back into Blender's image editor (docs/blender.md).

The scene travels through Blender's own glTF exporter plus a lensfarm scene file for what glTF does
not carry (export.py); the farm is reached through the lensfarm Python library (library.py)."""

bl_info = {
    "name": "Render on lensfarm",
    "author": "lensfarm",
    "version": (0, 7, 0),
    "blender": (3, 4, 0),
    "location": "Properties > Render > Render on lensfarm",
    "description": "Render the scene on a lensfarm farm and load the image back",
    "category": "Render",
}

if "ui" in locals():
    import importlib

    for module in (convert, materials, export, library, farm, ui):  # noqa: F821 - a reload
        importlib.reload(module)
else:
    from . import convert, export, farm, library, materials, ui


def register():
    ui.register()


def unregister():
    ui.unregister()
