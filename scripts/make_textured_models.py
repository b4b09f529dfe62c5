#!/usr/bin/env python3
"""Writes scenes/models/textured-spheres.gltf (+ .bin and PNG textures): the glTF model of
scenes/textured-spheres.json. Run from the repository root; the output is committed, so the
scene renders without running this. Standard library only.

The model: a ground plane with a checker texture tiled 8 times (KHR_texture_transform), and three
smooth spheres (vertex normals, TEXCOORD_0, no tangents): a bumpy stone sphere (base colour and
tangent-space normal map of a pattern of round bumps), a metal sphere whose metallic-roughness
texture has stripes of polished and rough metal, and a leaf-patterned cut-out sphere
(alphaMode MASK), so one image shows textures, normal maps, metallic-roughness maps and cut-outs.
"""
import json
import math
import os
import struct
import zlib

OUT = "scenes/models"


def png(path, width, height, pixel, channels=3):
    """An 8-bit PNG of `channels` (3 or 4) from pixel(x, y) -> tuple of ints in [0, 255]."""
    raw = bytearray()
    for y in range(height):
        raw.append(0)
        for x in range(width):
            raw.extend(pixel(x, y)[:channels])

    def chunk(kind, data):
        c = struct.pack(">I", len(data)) + kind + data
        return c + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    color_type = 2 if channels == 3 else 6
    data = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, color_type, 0, 0, 0))
    data += chunk(b"IDAT", zlib.compress(bytes(raw), 9)) + chunk(b"IEND", b"")
    with open(os.path.join(OUT, path), "wb") as f:
        f.write(data)


def srgb(v):
    """A linear value in [0, 1] as an 8-bit sRGB code."""
    v = max(0.0, min(1.0, v))
    e = 12.92 * v if v <= 0.0031308 else 1.055 * v ** (1 / 2.4) - 0.055
    return int(round(255 * e))


def textures():
    # Checker: two greys, 2x2 squares per tile.
    png("checker.png", 64, 64, lambda x, y: (srgb(0.7),) * 3 if ((x // 32) + (y // 32)) % 2 == 0 else (srgb(0.15),) * 3)

    # Bumps: a grid of round bumps as a height field h, its normal map from the gradient, and a
    # stone colour darker in the grooves.
    n = 256
    cells = 8

    def height(x, y):
        u, v = (x + 0.5) / n * cells, (y + 0.5) / n * cells
        du, dv = u - math.floor(u) - 0.5, v - math.floor(v) - 0.5
        r = math.hypot(du, dv) / 0.45
        return math.cos(min(r, 1.0) * math.pi / 2) ** 2

    def normal(x, y):
        # Tangent space: x along +u (image right), y up in the image (decreasing v).
        s = 0.08 * n / cells
        hx = (height((x + 1) % n, y) - height((x - 1) % n, y)) * s
        hy = (height(x, (y - 1) % n) - height(x, (y + 1) % n)) * s
        nx, ny, nz = -hx, -hy, 1.0
        l = math.sqrt(nx * nx + ny * ny + nz * nz)
        return tuple(int(round(255 * (c / l * 0.5 + 0.5))) for c in (nx, ny, nz))

    png("bumps-normal.png", n, n, normal)
    png("bumps-color.png", n, n, lambda x, y: (srgb(0.2 + 0.45 * height(x, y)), srgb(0.18 + 0.35 * height(x, y)),
                                                  srgb(0.15 + 0.25 * height(x, y))))
    # Metallic-roughness: B metallic 1, G roughness in stripes along v (0.08 and 0.6).
    png("stripes-mr.png", 8, 64, lambda x, y: (0, int(255 * (0.08 if (y // 8) % 2 == 0 else 0.6)), 255))
    # Leaves: a green base colour whose alpha cuts out a pattern of round holes.
    png("leaves.png", 128, 128,
        lambda x, y: (srgb(0.2), srgb(0.55), srgb(0.12),
                      0 if math.hypot((x % 32) - 15.5, (y % 32) - 15.5) < 10 else 255), channels=4)


class Buffer:
    def __init__(self):
        self.data = bytearray()
        self.views, self.accessors = [], []

    def add(self, fmt, values, kind, count, target=None, minmax=False):
        while len(self.data) % 4:
            self.data.append(0)
        offset = len(self.data)
        self.data.extend(struct.pack("<" + fmt * len(values), *values))
        view = {"buffer": 0, "byteOffset": offset, "byteLength": len(self.data) - offset}
        if target:
            view["target"] = target
        self.views.append(view)
        acc = {"bufferView": len(self.views) - 1, "componentType": 5126 if fmt == "f" else 5125, "count": count,
               "type": kind}
        if minmax:
            acc["min"] = [min(values[i::3]) for i in range(3)]
            acc["max"] = [max(values[i::3]) for i in range(3)]
        self.accessors.append(acc)
        return len(self.accessors) - 1


def sphere(buf, rings=48, segments=96):
    p, nrm, uv, idx = [], [], [], []
    for r in range(rings + 1):
        t = math.pi * r / rings
        for s in range(segments + 1):
            f = 2 * math.pi * s / segments
            x, y, z = math.sin(t) * math.cos(f), math.cos(t), -math.sin(t) * math.sin(f)
            p += [x, y, z]
            nrm += [x, y, z]
            uv += [2.0 * s / segments, 1.0 * r / rings]  # the texture twice around
    for r in range(rings):
        for s in range(segments):
            a, b = r * (segments + 1) + s, (r + 1) * (segments + 1) + s
            if r > 0:
                idx += [a, b, a + 1]
            if r < rings - 1:
                idx += [a + 1, b, b + 1]
    nv = len(p) // 3
    return {"POSITION": buf.add("f", p, "VEC3", nv, 34962, True), "NORMAL": buf.add("f", nrm, "VEC3", nv, 34962),
            "TEXCOORD_0": buf.add("f", uv, "VEC2", nv, 34962)}, buf.add("I", idx, "SCALAR", len(idx), 34963)


def main():
    os.makedirs(OUT, exist_ok=True)
    textures()
    buf = Buffer()
    g = 6.0
    ground = {"POSITION": buf.add("f", [-g, 0, -g, -g, 0, g, g, 0, g, g, 0, -g], "VEC3", 4, 34962, True),
              "NORMAL": buf.add("f", [0, 1, 0] * 4, "VEC3", 4, 34962),
              "TEXCOORD_0": buf.add("f", [0, 0, 0, 1, 1, 1, 1, 0], "VEC2", 4, 34962)}
    ground_idx = buf.add("I", [0, 1, 2, 0, 2, 3], "SCALAR", 6, 34963)
    attrs, idx = sphere(buf)
    images = ["checker.png", "bumps-color.png", "bumps-normal.png", "stripes-mr.png", "leaves.png"]
    doc = {
        "asset": {"version": "2.0", "generator": "lensfarm scripts/make_textured_models.py"},
        "extensionsUsed": ["KHR_texture_transform"],
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2, 3]}],
        "nodes": [
            {"name": "ground", "mesh": 0},
            {"name": "stone", "mesh": 1, "translation": [-1.25, 0.55, 0], "scale": [0.55, 0.55, 0.55]},
            {"name": "metal", "mesh": 2, "translation": [0, 0.55, -0.3], "scale": [0.55, 0.55, 0.55]},
            {"name": "leaves", "mesh": 3, "translation": [1.25, 0.55, 0], "scale": [0.55, 0.55, 0.55],
             "rotation": [0, math.sin(math.radians(20)), 0, math.cos(math.radians(20))]},
        ],
        "meshes": [
            {"name": "ground", "primitives": [{"attributes": ground, "indices": ground_idx, "material": 0}]},
            {"name": "stone", "primitives": [{"attributes": attrs, "indices": idx, "material": 1}]},
            {"name": "metal", "primitives": [{"attributes": attrs, "indices": idx, "material": 2}]},
            {"name": "leaves", "primitives": [{"attributes": attrs, "indices": idx, "material": 3}]},
        ],
        "materials": [
            {"name": "checker", "pbrMetallicRoughness": {
                "baseColorTexture": {"index": 0, "extensions": {"KHR_texture_transform": {"scale": [8, 8]}}},
                "metallicFactor": 0.0, "roughnessFactor": 0.8}},
            {"name": "stone", "pbrMetallicRoughness": {"baseColorTexture": {"index": 1}, "metallicFactor": 0.0,
                                                       "roughnessFactor": 0.7},
             "normalTexture": {"index": 2, "scale": 1.0}},
            {"name": "striped metal", "pbrMetallicRoughness": {"baseColorFactor": [0.95, 0.64, 0.54, 1.0],
                                                               "metallicRoughnessTexture": {"index": 3}}},
            {"name": "leaves", "alphaMode": "MASK", "alphaCutoff": 0.5, "doubleSided": True,
             "pbrMetallicRoughness": {"baseColorTexture": {"index": 4}, "metallicFactor": 0.0,
                                      "roughnessFactor": 0.6}},
        ],
        "samplers": [{"wrapS": 10497, "wrapT": 10497}],
        "textures": [{"source": i, "sampler": 0} for i in range(len(images))],
        "images": [{"uri": name} for name in images],
        "buffers": [{"uri": "textured-spheres.bin", "byteLength": len(buf.data)}],
        "bufferViews": buf.views,
        "accessors": buf.accessors,
    }
    with open(os.path.join(OUT, "textured-spheres.bin"), "wb") as f:
        f.write(buf.data)
    with open(os.path.join(OUT, "textured-spheres.gltf"), "w") as f:
        json.dump(doc, f, indent=1)


if __name__ == "__main__":
    main()
