#!/usr/bin/env python3
"""Writes the project's own asset files in scenes/assets/ (issue 20):

leaf_cards.gltf: leaf cards as asset libraries ship foliage.

Three quads ("cards") share one material whose base colour texture is an RGBA leaf image,
with glTF's alphaMode MASK (alphaCutoff 0.5) and doubleSided: the leaf is where the image's
alpha is, the rest of each card is a hole. Everything is embedded (buffer and PNG as data
URIs), so the file stands alone. The leaf outline is the plant generator's
(src/penumbra/scene/generators/plant.cpp, LeafOutline): half width 0.46 sin(pi v) (1 - 0.3 v)
around u = 0.5, v from the base (0) to the tip (1).

Card 0 lies flat at y = 0.8 over [-0.5, 0.5] x [-0.5, 0.5], u along +x, its base at z = +0.5
and its tip at z = -0.5 (tests look through it). Cards 1 and 2 are tilted copies beside it.

stained_glass.png: a window for a textured rect light (sintorn2008 §1: "a stained-glass
window"): 64 x 64, four coloured panes (red, green, blue, amber) in dark lead cames, a lighter
diamond in the middle.

Python's standard library only; run from the repository root:
    /usr/bin/python3 scripts/make_assets.py
"""
import base64
import json
import math
import struct
import zlib

SIZE = 64  # texels per side


def half_width(v):
    return 0.46 * math.sin(math.pi * v) * (1.0 - 0.3 * v)


def inside(u, v):
    return 0.0 <= v <= 1.0 and abs(u - 0.5) <= half_width(v)


def png(rows, colour_type):
    """An 8-bit PNG from rows of bytes (colour_type 2: RGB, 6: RGBA), each row's filter byte first."""
    width = (len(rows[0]) - 1) // (3 if colour_type == 2 else 4)

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    header = struct.pack(">IIBBBBB", width, len(rows), 8, colour_type, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(b"".join(rows), 9)) + chunk(b"IEND", b"")


def stained_glass_png():
    size = 64
    panes = [[(200, 30, 30), (40, 160, 60)], [(40, 70, 200), (230, 170, 40)]]  # sRGB, [image row half][column half]
    rows = []
    for y in range(size):
        row = bytearray([0])
        for x in range(size):
            lead = x % 32 in (0, 31) or y % 32 in (0, 31)
            diamond = abs(x - 31.5) + abs(y - 31.5) < 12
            if lead:
                c = (25, 25, 25)
            elif diamond:
                c = (245, 240, 220)
            else:
                c = panes[y // 32][x // 32]
            row += bytes(c)
        rows.append(bytes(row))
    return png(rows, 2)


def leaf_png():
    """RGBA, 8 bits: alpha = coverage of the outline (4 x 4 samples per texel), green with a
    lighter midrib; row 0 at the top is the tip (glTF's v = 0 is the image's top)."""
    rows = []
    for y in range(SIZE):
        row = bytearray([0])  # PNG filter: none
        for x in range(SIZE):
            covered = sum(
                inside((x + (i + 0.5) / 4) / SIZE, 1.0 - (y + (j + 0.5) / 4) / SIZE) for j in range(4) for i in range(4))
            midrib = abs((x + 0.5) / SIZE - 0.5) < 0.02
            r, g, b = (150, 194, 124) if midrib else (130, 180, 97)  # sRGB of linear (0.3, 0.55, 0.2) / (0.22, 0.45, 0.12)
            row += bytes([r, g, b, round(255 * covered / 16)])
        rows.append(bytes(row))
    return png(rows, 6)


def card(origin, across, along):
    """A card's 4 corners (base-left, base-right, tip-right, tip-left) and glTF uvs (v down)."""
    corners = [origin, [origin[k] + across[k] for k in range(3)],
               [origin[k] + across[k] + along[k] for k in range(3)], [origin[k] + along[k] for k in range(3)]]
    uvs = [[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]]
    return corners, uvs


def main():
    cards = [
        card([-0.5, 0.8, 0.5], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]),
        card([0.7, 0.5, 0.4], [0.8, 0.0, 0.0], [0.0, 0.45, -0.8]),
        card([-1.6, 0.6, 0.3], [0.0, 0.2, -0.9], [0.7, 0.3, 0.0]),
    ]
    positions, uvs, indices = [], [], []
    for corners, card_uvs in cards:
        base = len(positions)
        positions += corners
        uvs += card_uvs
        indices += [base, base + 1, base + 2, base, base + 2, base + 3]
    buf = b"".join(struct.pack("<3f", *p) for p in positions)
    uv_offset = len(buf)
    buf += b"".join(struct.pack("<2f", *t) for t in uvs)
    index_offset = len(buf)
    buf += b"".join(struct.pack("<H", i) for i in indices)
    while len(buf) % 4:
        buf += b"\0"
    lo = [min(p[k] for p in positions) for k in range(3)]
    hi = [max(p[k] for p in positions) for k in range(3)]
    doc = {
        "asset": {"version": "2.0", "generator": "penumbra scripts/make_assets.py"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "name": "leaf_cards"}],
        "meshes": [{"name": "leaf_cards", "primitives": [
            {"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2, "material": 0}]}],
        "materials": [{"name": "leaf", "doubleSided": True, "alphaMode": "MASK", "alphaCutoff": 0.5,
                       "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0.0}}],
        "textures": [{"source": 0, "sampler": 0}],
        "samplers": [{"magFilter": 9729, "minFilter": 9729, "wrapS": 10497, "wrapT": 10497}],
        "images": [{"uri": "data:image/png;base64," + base64.b64encode(leaf_png()).decode("ascii")}],
        "buffers": [{"byteLength": len(buf),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(buf).decode("ascii")}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": uv_offset, "target": 34962},
            {"buffer": 0, "byteOffset": uv_offset, "byteLength": index_offset - uv_offset, "target": 34962},
            {"buffer": 0, "byteOffset": index_offset, "byteLength": 2 * len(indices), "target": 34963},
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": len(positions), "type": "VEC3", "min": lo, "max": hi},
            {"bufferView": 1, "componentType": 5126, "count": len(uvs), "type": "VEC2"},
            {"bufferView": 2, "componentType": 5123, "count": len(indices), "type": "SCALAR"},
        ],
    }
    with open("scenes/assets/leaf_cards.gltf", "w") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")
    with open("scenes/assets/stained_glass.png", "wb") as f:
        f.write(stained_glass_png())


if __name__ == "__main__":
    main()
