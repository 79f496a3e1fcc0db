#!/usr/bin/env python3
"""Writes assets/gltf/volume_demo.glb and volume_demo.gltf + volume_demo.bin with pygltflib, a glTF
writer independent of hadou (pip install pygltflib; written with pygltflib 1.16).

The scene: a translucent cube (KHR_materials_transmission + KHR_materials_volume) back-lit by a
KHR_lights_punctual directional light, a ground plane, two pillars sharing one mesh under a parent
with a non-uniform scale (the right one mirrored), and a perspective camera. tests/gltf_import.rs
checks what hadou reads from it against the numbers below; tests/gltf_render.rs renders it
against the CPU twin. Run from the repository root: python3 assets/gltf/make_volume_demo.py
"""
import math
import os
import struct

import pygltflib as g

HERE = os.path.dirname(os.path.abspath(__file__))


def box(half):
    """A closed box, 24 vertices (4 per face, face normals), faces counter-clockwise outside."""
    pos, nrm, idx = [], [], []
    for axis in range(3):
        for sign in (1.0, -1.0):
            n = [0.0, 0.0, 0.0]
            n[axis] = sign
            u, v = (axis + 1) % 3, (axis + 2) % 3
            base = len(pos)
            for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                p = [0.0, 0.0, 0.0]
                p[axis] = sign * half[axis]
                p[u] = a * half[u]
                p[v] = b * half[v]
                pos.append(p)
                nrm.append(n)
            quad = [0, 1, 2, 0, 2, 3] if sign > 0 else [0, 2, 1, 0, 3, 2]
            idx += [base + q for q in quad]
    return pos, nrm, idx


def quad(size):
    """A square in the xz-plane, normal +y, two triangles counter-clockwise from above."""
    h = size / 2
    pos = [[-h, 0.0, -h], [-h, 0.0, h], [h, 0.0, h], [h, 0.0, -h]]
    return pos, [[0.0, 1.0, 0.0]] * 4, [0, 1, 2, 0, 2, 3]


def rotation_between(a, b):
    """The unit quaternion [x, y, z, w] turning unit vector a onto unit vector b."""
    c = [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    w = 1.0 + sum(x * y for x, y in zip(a, b))
    n = math.sqrt(sum(x * x for x in c) + w * w)
    return [c[0] / n, c[1] / n, c[2] / n, w / n]


def normalize(v):
    n = math.sqrt(sum(x * x for x in v))
    return [x / n for x in v]


class Blob:
    def __init__(self):
        self.data = bytearray()
        self.views = []
        self.accessors = []

    def add(self, fmt, values, count, type_, ctype, target, minmax=None):
        while len(self.data) % 4:
            self.data += b"\0"
        offset = len(self.data)
        self.data += struct.pack("<%d%s" % (len(values), fmt), *values)
        self.views.append(g.BufferView(buffer=0, byteOffset=offset, byteLength=len(self.data) - offset, target=target))
        acc = g.Accessor(bufferView=len(self.views) - 1, componentType=ctype, count=count, type=type_)
        if minmax:
            acc.min, acc.max = minmax
        self.accessors.append(acc)
        return len(self.accessors) - 1

    def mesh(self, pos, nrm, idx, material, index_type):
        lo = [min(p[k] for p in pos) for k in range(3)]
        hi = [max(p[k] for p in pos) for k in range(3)]
        p = self.add("f", [c for v in pos for c in v], len(pos), "VEC3", g.FLOAT, g.ARRAY_BUFFER, (lo, hi))
        n = self.add("f", [c for v in nrm for c in v], len(nrm), "VEC3", g.FLOAT, g.ARRAY_BUFFER)
        fmt, ctype = {"u8": ("B", g.UNSIGNED_BYTE), "u16": ("H", g.UNSIGNED_SHORT)}[index_type]
        i = self.add(fmt, idx, len(idx), "SCALAR", ctype, g.ELEMENT_ARRAY_BUFFER)
        prim = g.Primitive(attributes=g.Attributes(POSITION=p, NORMAL=n), indices=i, material=material, mode=g.TRIANGLES)
        return g.Mesh(primitives=[prim])


# Numbers the tests read back (tests/gltf_import.rs `independent_writer_volume_demo`).
CUBE_HALF = 0.8
CUBE_TURN_DEG = 30.0
ATTENUATION_COLOR = [0.55, 0.85, 0.6]
ATTENUATION_DISTANCE = 0.6
LIGHT_DIRECTION = normalize([0.25, -0.45, 1.0])  # travels toward the camera: the cube is back-lit
KEY_DIRECTION = normalize([0.5, -1.0, -0.8])  # a weaker key light from the camera's side
CAMERA_POSITION = [0.0, 1.6, 6.5]


def build():
    blob = Blob()
    materials = [
        g.Material(
            name="jade glass",
            pbrMetallicRoughness=g.PbrMetallicRoughness(baseColorFactor=[0.75, 0.95, 0.8, 1.0], metallicFactor=0.0),
            extensions={
                "KHR_materials_transmission": {"transmissionFactor": 1.0},
                "KHR_materials_volume": {
                    "thicknessFactor": 2 * CUBE_HALF,
                    "attenuationColor": ATTENUATION_COLOR,
                    "attenuationDistance": ATTENUATION_DISTANCE,
                },
            },
        ),
        g.Material(name="stone", pbrMetallicRoughness=g.PbrMetallicRoughness(baseColorFactor=[0.55, 0.5, 0.45, 1.0])),
        g.Material(name="ground", pbrMetallicRoughness=g.PbrMetallicRoughness(baseColorFactor=[0.35, 0.37, 0.4, 1.0])),
    ]
    meshes = [
        blob.mesh(*box([CUBE_HALF] * 3), material=0, index_type="u8"),
        blob.mesh(*box([0.5, 0.5, 0.5]), material=1, index_type="u16"),
        blob.mesh(*quad(14.0), material=2, index_type="u8"),
    ]
    half = math.radians(CUBE_TURN_DEG) / 2
    camera_target = [0.0, 0.1, 0.0]
    forward = normalize([t - p for t, p in zip(camera_target, CAMERA_POSITION)])
    nodes = [
        g.Node(name="glass cube", mesh=0, rotation=[0.0, math.sin(half), 0.0, math.cos(half)]),
        g.Node(name="pillars", scale=[0.5, 2.5, 0.5], translation=[0.0, 0.25, -1.5], children=[2, 3]),
        g.Node(name="left pillar", mesh=1, translation=[-5.0, 0.0, 0.0]),
        g.Node(name="right pillar (mirrored)", mesh=1, translation=[5.0, 0.0, 0.0], scale=[-1.0, 1.0, 1.0]),
        g.Node(name="ground", mesh=2, translation=[0.0, -1.0, 0.0]),
        g.Node(name="sun", rotation=rotation_between([0.0, 0.0, -1.0], LIGHT_DIRECTION),
               extensions={"KHR_lights_punctual": {"light": 0}}),
        g.Node(name="key", rotation=rotation_between([0.0, 0.0, -1.0], KEY_DIRECTION),
               extensions={"KHR_lights_punctual": {"light": 1}}),
        g.Node(name="camera", camera=0, translation=CAMERA_POSITION,
               rotation=rotation_between([0.0, 0.0, -1.0], forward)),
    ]
    gltf = g.GLTF2(
        asset=g.Asset(version="2.0", generator="pygltflib (assets/gltf/make_volume_demo.py)"),
        scene=0,
        scenes=[g.Scene(nodes=[0, 1, 4, 5, 6, 7])],
        nodes=nodes,
        meshes=meshes,
        materials=materials,
        cameras=[g.Camera(type="perspective", perspective=g.Perspective(yfov=0.7, znear=0.1, zfar=30.0, aspectRatio=1.5))],
        accessors=blob.accessors,
        bufferViews=blob.views,
        buffers=[g.Buffer(byteLength=len(blob.data))],
        extensionsUsed=["KHR_materials_transmission", "KHR_materials_volume", "KHR_lights_punctual"],
        extensions={"KHR_lights_punctual": {"lights": [
            {"type": "directional", "name": "back light", "color": [1.0, 0.97, 0.9], "intensity": 1.6},
            {"type": "directional", "name": "key light", "color": [0.9, 0.95, 1.0], "intensity": 0.5}]}},
    )
    return gltf, bytes(blob.data)


def main():
    gltf, data = build()
    gltf.set_binary_blob(data)
    gltf.save_binary(os.path.join(HERE, "volume_demo.glb"))
    gltf, data = build()
    with open(os.path.join(HERE, "volume_demo.bin"), "wb") as f:
        f.write(data)
    gltf.buffers[0].uri = "volume_demo.bin"
    gltf.save_json(os.path.join(HERE, "volume_demo.gltf"))


if __name__ == "__main__":
    main()
