#!/usr/bin/env python3
"""Writes scenes/models/night-street.gltf (+ .bin): the glTF model of scenes/night-street.json, a
street at night lit by its windows and lamps. Run from the repository root; the output is
committed, so the scene renders without running this. Standard library only; the layout is drawn
from a fixed seed, so the file is the same on every run.

The model (metres, y up, the street along +z): an asphalt road and pavements, a row of buildings
on each side (boxes of varied width, depth and height, their facades facing the street), each
facade a grid of windows 1.0 m x 1.5 m, about 65 % of them lit (small emissive quads 2 cm in front
of the wall, in four colours and strengths: warm, neutral, cool and the blue of a screen), and a
street lamp every 25 m on both sides (an emissive quad facing down under a dark housing). More
than ten thousand small emitters, of which a point on the street sees a few hundred that matter:
the scene of the light tree's goal (docs/performance.md, "Many lights").
"""
import json
import os
import random

from make_textured_models import Buffer

OUT = "scenes/models"
STREET_HALF = 9.0  # facades at x = +-9
LENGTH = 700.0


class Mesh:
    """Triangles of one material: positions and indices, appended quad by quad."""

    def __init__(self):
        self.p, self.idx = [], []

    def quad(self, corner, e1, e2):
        """The quad corner, corner + e1, corner + e1 + e2, corner + e2; its front is e1 x e2."""
        base = len(self.p) // 3
        for v in (corner, [corner[i] + e1[i] for i in range(3)], [corner[i] + e1[i] + e2[i] for i in range(3)],
                  [corner[i] + e2[i] for i in range(3)]):
            self.p += v
        self.idx += [base, base + 1, base + 2, base, base + 2, base + 3]

    def box(self, lo, hi):
        """An axis-aligned box, faces outwards (no bottom)."""
        (x0, y0, z0), (x1, y1, z1) = lo, hi
        dx, dy, dz = x1 - x0, y1 - y0, z1 - z0
        self.quad([x0, y0, z0], [0, dy, 0], [dx, 0, 0])  # -z
        self.quad([x0, y0, z1], [dx, 0, 0], [0, dy, 0])  # +z
        self.quad([x0, y0, z0], [0, 0, dz], [0, dy, 0])  # -x
        self.quad([x1, y0, z0], [0, dy, 0], [0, 0, dz])  # +x
        self.quad([x0, y1, z0], [0, 0, dz], [dx, 0, 0])  # top


def main():
    rng = random.Random(2026)
    ground, pavement, housing = Mesh(), Mesh(), Mesh()
    walls = [Mesh() for _ in range(3)]
    lit = [Mesh() for _ in range(4)]
    lamps = Mesh()
    ground.quad([-60, 0, -20], [0, 0, LENGTH + 40], [120, 0, 0])
    for side in (-1, 1):
        x = side * STREET_HALF
        # The pavement, 3 m wide and 15 cm high, in front of the facades.
        x0 = min(x, x - side * 3.0)
        pavement.box([x0, 0, -20], [x0 + 3.0, 0.15, LENGTH + 20])
        z = 0.0
        while z < LENGTH:
            width = rng.uniform(14, 30)
            floors = rng.randint(8, 50)
            depth = rng.uniform(15, 25)
            height = 3.0 * floors + 1.0
            facade_x = x
            far_x = x + side * depth
            walls[rng.randrange(3)].box([min(facade_x, far_x), 0, z], [max(facade_x, far_x), height, z + width - 0.5])
            # Windows on the facade, 2 cm towards the street, facing it (-side along x).
            columns = int((width - 2.0) / 1.8)
            left = z + 0.5 * (width - 0.5 - columns * 1.8) + 0.4
            for f in range(1, floors):
                for c in range(columns):
                    if rng.random() > 0.65:
                        continue
                    kind = rng.choices(range(4), weights=[5, 3, 2, 1])[0]
                    wz, wy = left + c * 1.8, 3.0 * f + 0.7
                    wx = facade_x - side * 0.02
                    if side < 0:  # facing +x
                        lit[kind].quad([wx, wy, wz], [0, 1.5, 0], [0, 0, 1.0])
                    else:  # facing -x
                        lit[kind].quad([wx, wy, wz], [0, 0, 1.0], [0, 1.5, 0])
            z += width
        # Street lamps: a head 6 m up, 1.5 m out over the road, its lamp facing down.
        for k in range(int(LENGTH / 25.0)):
            lz = 10.0 + 25.0 * k + (12.5 if side > 0 else 0.0)
            lx = x - side * 4.5
            housing.box([lx - 0.35, 6.0, lz - 0.2], [lx + 0.35, 6.15, lz + 0.2])
            housing.box([lx - 0.06, 0.15, lz - 0.06], [lx + 0.06, 6.0, lz + 0.06])
            lamps.quad([lx - 0.3, 5.99, lz - 0.15], [0.6, 0, 0], [0, 0, 0.3])  # faces -y

    buf = Buffer()
    meshes, nodes = [], []

    def add(name, mesh, material):
        if not mesh.idx:
            return
        nv = len(mesh.p) // 3
        prim = {"attributes": {"POSITION": buf.add("f", mesh.p, "VEC3", nv, 34962, True)},
                "indices": buf.add("I", mesh.idx, "SCALAR", len(mesh.idx), 34963), "material": material}
        nodes.append({"name": name, "mesh": len(meshes)})
        meshes.append({"name": name, "primitives": [prim]})

    materials = [
        {"name": "asphalt", "pbrMetallicRoughness": {"baseColorFactor": [0.06, 0.06, 0.065, 1], "metallicFactor": 0,
                                                     "roughnessFactor": 0.9}},
        {"name": "pavement", "pbrMetallicRoughness": {"baseColorFactor": [0.25, 0.24, 0.22, 1], "metallicFactor": 0,
                                                      "roughnessFactor": 0.9}},
        {"name": "housing", "pbrMetallicRoughness": {"baseColorFactor": [0.05, 0.05, 0.05, 1], "metallicFactor": 0.5,
                                                     "roughnessFactor": 0.5}},
    ]
    for i, colour in enumerate([[0.42, 0.36, 0.3], [0.3, 0.3, 0.32], [0.5, 0.45, 0.4]]):
        materials.append({"name": "wall %d" % i, "pbrMetallicRoughness": {
            "baseColorFactor": colour + [1], "metallicFactor": 0, "roughnessFactor": 0.85}})
    window_colours = [([1.0, 0.7, 0.4], 6.0), ([1.0, 0.9, 0.75], 5.0), ([0.75, 0.85, 1.0], 4.0), ([0.3, 0.45, 1.0], 3.0)]
    for i, (colour, strength) in enumerate(window_colours):
        materials.append({"name": "window %d" % i, "emissiveFactor": colour,
                          "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": strength}},
                          "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0,
                                                   "roughnessFactor": 1}})
    materials.append({"name": "street lamp", "emissiveFactor": [1.0, 0.8, 0.55],
                      "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 400.0}},
                      "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0,
                                               "roughnessFactor": 1}})
    add("road", ground, 0)
    add("pavements", pavement, 1)
    add("lamp housings", housing, 2)
    for i, m in enumerate(walls):
        add("buildings %d" % i, m, 3 + i)
    for i, m in enumerate(lit):
        add("lit windows %d" % i, m, 6 + i)
    add("street lamps", lamps, 10)
    doc = {
        "asset": {"version": "2.0", "generator": "lensfarm scripts/make_night_street.py"},
        "extensionsUsed": ["KHR_materials_emissive_strength"],
        "scene": 0,
        "scenes": [{"nodes": list(range(len(nodes)))}],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "buffers": [{"uri": "night-street.bin", "byteLength": len(buf.data)}],
        "bufferViews": buf.views,
        "accessors": buf.accessors,
    }
    os.makedirs(OUT, exist_ok=True)
    with open(os.path.join(OUT, "night-street.bin"), "wb") as f:
        f.write(buf.data)
    with open(os.path.join(OUT, "night-street.gltf"), "w") as f:
        json.dump(doc, f, indent=1)
    windows = sum(len(m.idx) // 6 for m in lit)
    print("%d lit windows, %d street lamps, %d bytes" % (windows, len(lamps.idx) // 6, len(buf.data)))


if __name__ == "__main__":
    main()
