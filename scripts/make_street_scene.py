# Writes scenes/street.json (issue 34: a street of boxes, a wide scene for compare and bench --suite wide).
# Deterministic; run from the repository root: python3 scripts/make_street_scene.py
import json, random
rng = random.Random(34)
objs = [{"name": "ground", "shape": "plane", "size": [60, 140], "material": {"albedo": [0.6, 0.6, 0.62]}}]
# Two rows of buildings along z, the street between x = -6 and 6, sidewalks to +-9.
for side in (-1, 1):
    z = -64.0
    i = 0
    while z < 64:
        w = rng.uniform(6, 12); d = rng.uniform(8, 14); h = rng.uniform(6, 24)
        x = side * (9 + d / 2)
        objs.append({"name": f"building{'LR'[side > 0]}{i}", "shape": "box", "size": [round(d, 2), round(h, 2), round(w, 2)],
                     "translate": [round(x, 2), round(h / 2, 2), round(z + w / 2, 2)],
                     "material": {"albedo": [round(rng.uniform(.5, .8), 2)] * 3}})
        # Balconies: thin slabs on the street side.
        for f in range(int(h // 3) - 1):
            if rng.random() < 0.5:
                objs.append({"name": f"balcony{'LR'[side > 0]}{i}.{f}", "shape": "box", "size": [1.2, 0.15, round(w * 0.5, 2)],
                             "translate": [round(side * 8.4, 2), round(3 * (f + 1), 2), round(z + w / 2, 2)]})
        z += w + rng.uniform(0.0, 2.5)
        i += 1
# Street lamps (a post and an arm) and parked cars on both kerbs, trees in between.
for k in range(12):
    z = -60 + k * 10.5
    for side in (-1, 1):
        x = side * 6.6
        objs.append({"name": f"lamp{k}{'LR'[side > 0]}.post", "shape": "box", "size": [0.15, 5, 0.15], "translate": [x, 2.5, z]})
        objs.append({"name": f"lamp{k}{'LR'[side > 0]}.arm", "shape": "box", "size": [1.4, 0.12, 0.2], "translate": [x - side * 0.7, 5, z]})
        if rng.random() < 0.7:
            objs.append({"name": f"car{k}{'LR'[side > 0]}", "shape": "box", "size": [1.8, 1.4, 4.2],
                         "translate": [side * 4.9, 0.7, round(z + 5 + rng.uniform(-1, 1), 2)],
                         "material": {"albedo": [round(rng.uniform(.2, .9), 2), round(rng.uniform(.2, .9), 2), round(rng.uniform(.2, .9), 2)]}})
    if k % 2 == 0:
        objs.append({"name": f"tree{k}", "generator": "plant", "params": {"seed": k + 1, "leaves": 6000, "leaf_size": 0.05},
                     "scale": 6, "translate": [7.6 if k % 4 == 0 else -7.6, 0, z + 2.5]})
scene = {
  "description": "A wide scene (issue 34): a 128 m street of boxes — two rows of buildings 6-24 m tall with balconies, street lamps, parked cars and six generated trees (about 76 k triangles) — under a small, far, sun-like light from the side: long shadows across the street, thin casters (posts, lamp arms) and dense foliage, most of it far from the camera.",
  "camera": {"eye": [2.5, 9.0, -70.0], "target": [0, 2.0, 0.0], "up": [0, 1, 0], "fov_y": 45,
             "resolution": [512, 512], "samples_per_pixel": 1},
  "lights": [{"type": "rect", "center": [-30.0, 90.0, -20.0], "normal": [0.3096, -0.9288, 0.2064], "u": [0, 0, 1],
              "size": [4, 4], "radiance": [900, 900, 900]}],
  "objects": objs,
}
json.dump(scene, open("scenes/street.json", "w"), indent=1)
print(len(objs), "objects")
