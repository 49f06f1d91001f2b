#!/usr/bin/env python3
"""Mean |dV| of occlusion-textures against the reference, and the images of
docs/methods/occlusion-textures.md.

For the bunny and the plant, at light sizes 0.25x to 2.5x the scene's (10x): the reference
(256 light samples per pixel) and occlusion-textures with 4, 8 and 16 slices and each
pre-filter, all at 256 x 256; `penumbra diff` gives the mean |dV| (the MAE of the V channel).
Then the combination rules (eq. 5 vs sum and max), the thin-occluder fix and the
self-shadowing fade on their own, and the images.

Usage: scripts/occlusion_textures_quality.py [--build build] [--out out/ot-quality] [--images docs/images]
"""
import argparse
import json
import os
import subprocess
import sys

SCALES = [0.25, 0.5, 1.0, 2.5]
SLICES = [4, 8, 16]
PREFILTERS = ["nbuffer", "sat", "mipmap"]
RES = "256x256"


def run(cmd):
    subprocess.run(cmd, check=True)


def scene_variant(root, name, scale, out):
    with open(os.path.join(root, "scenes", name + ".json")) as f:
        doc = json.load(f)
    light = doc["lights"][0]
    if "size" in light:
        light["size"] = [s * scale for s in light["size"]]
    if "radius" in light:
        light["radius"] *= scale
    path = os.path.join(out, f"{name}-{scale}x.json")
    with open(path, "w") as f:
        json.dump(doc, f)
    return path


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--build", default="build")
    ap.add_argument("--out", default="out/ot-quality")
    ap.add_argument("--images", default="docs/images")
    ap.add_argument("--spp", type=int, default=256)
    args = ap.parse_args()
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    cli = os.path.join(args.build, "penumbra")
    os.makedirs(args.out, exist_ok=True)
    os.makedirs(args.images, exist_ok=True)

    def render(scene, exr, method="occlusion-textures", params=(), vis_png=None):
        cmd = [cli, "render", scene, "-m", method, "--resolution", RES, "-o", exr, "-q", "--spp", str(args.spp)]
        for p in params:
            cmd += ["-p", p]
        if vis_png:
            cmd += ["--visibility-out", vis_png]
        if not os.path.exists(exr) or vis_png:
            run(cmd)

    def mae(test, ref):
        out = subprocess.run([cli, "diff", test, ref, "--json"], check=True, capture_output=True, text=True).stdout
        return json.loads(out)["mae"]

    results = {}
    for name in ["bunny", "plant"]:
        for scale in SCALES:
            scene = scene_variant(root, name, scale, args.out)
            ref = os.path.join(args.out, f"{name}-{scale}x-reference.exr")
            render(scene, ref, method="reference")
            for prefilter in PREFILTERS:
                for slices in SLICES:
                    exr = os.path.join(args.out, f"{name}-{scale}x-{prefilter}-{slices}.exr")
                    render(scene, exr, params=[f"prefilter={prefilter}", f"slices={slices}"])
                    results[(name, scale, prefilter, slices)] = mae(exr, ref)
                    print(f"{name} {scale}x {prefilter} S={slices}: mean |dV| {results[(name, scale, prefilter, slices)]:.4f}",
                          file=sys.stderr)

    print("### Mean |dV| against `reference` (256 x 256, reference at %d spp)\n" % args.spp)
    for name in ["bunny", "plant"]:
        print(f"**{name}**\n")
        print("| pre-filter | slices | " + " | ".join(f"light {s}x" for s in SCALES) + " |")
        print("|---|---|" + "---|" * len(SCALES))
        for prefilter in PREFILTERS:
            for slices in SLICES:
                row = " | ".join(f"{results[(name, s, prefilter, slices)]:.4f}" for s in SCALES)
                print(f"| {prefilter} | {slices} | {row} |")
        print()

    # Variants at 16 slices, N-buffers, the scenes' own light.
    variants = [
        ("defaults: eq. 5 product, no thin-occluder fix, fade over 1 slice", []),
        ("combine=sum", ["combine=sum"]),
        ("combine=max", ["combine=max"]),
        ("thin_fix=true", ["thin_fix=true"]),
        ("fade=0 (no fade)", ["fade=0"]),
        ("fade=0.5", ["fade=0.5"]),
        ("fade=2", ["fade=2"]),
        ("cop_distance=1 (instead of the fitted d)", ["cop_distance=1"]),
    ]
    print("### Variants (N-buffers, 16 slices, light 1x)\n")
    print("| variant | bunny | plant |")
    print("|---|---|---|")
    for label, params in variants:
        row = []
        for name in ["bunny", "plant"]:
            scene = os.path.join(args.out, f"{name}-1.0x.json")
            ref = os.path.join(args.out, f"{name}-1.0x-reference.exr")
            tag = "-".join(p.replace("=", "") for p in params) or "default"
            exr = os.path.join(args.out, f"{name}-variant-{tag}.exr")
            render(scene, exr, params=params)
            row.append(f"{mae(exr, ref):.4f}")
        print(f"| {label} | {row[0]} | {row[1]} |")
    print()

    # Images (256 x 256 PNGs; V unless named -color).
    img = lambda n: os.path.join(args.images, n)
    tmp = os.path.join(args.out, "tmp.exr")
    # eisemann2006 Fig. 2 (pre-filters) and Fig. 3 (combination), on the plant's shadow.
    plant = os.path.join(args.out, "plant-1.0x.json")
    render(plant, tmp, method="reference", vis_png=img("ot-plant-reference.png"))
    for prefilter in PREFILTERS:
        render(plant, tmp, params=[f"prefilter={prefilter}"], vis_png=img(f"ot-plant-{prefilter}.png"))
    for combine in ["sum", "max"]:
        render(plant, tmp, params=[f"combine={combine}"], vis_png=img(f"ot-plant-{combine}.png"))
    # Light sizes: the bunny at 0.25x and 2.5x.
    for scale in [0.25, 2.5]:
        scene = os.path.join(args.out, f"bunny-{scale}x.json")
        render(scene, tmp, method="reference", vis_png=img(f"ot-bunny-{scale}x-reference.png"))
        render(scene, tmp, vis_png=img(f"ot-bunny-{scale}x-nbuffer.png"))
    # Light leaks through a thin tilted slab (Fig. 4, 6): without and with the fix, and with
    # 4 slices (wider bands).
    slab = os.path.join(args.out, "slab.json")
    with open(slab, "w") as f:
        json.dump({
            "description": "A thin slab, steep to a small light: its shadow shows the light leaks of occlusion textures.",
            "camera": {"eye": [0.2, 2.4, 2.2], "target": [0.5, 0, 0.5], "fov_y": 45, "resolution": [256, 256]},
            "lights": [{"type": "rect", "center": [-1.2, 3.0, -0.8], "normal": [0.4158, -0.8662, 0.2772],
                        "u": [1, 0, 0], "size": [0.25, 0.25], "radiance": [14, 14, 14]}],
            "objects": [{"name": "ground", "shape": "plane", "size": [8, 8]},
                        {"name": "slab", "shape": "plane", "size": [1, 1], "rotate": [35, 0, 60],
                         "translate": [0.1, 0.8, 0.1]}]}, f)
    slab_ref = os.path.join(args.out, "slab-reference.exr")
    render(slab, slab_ref, method="reference", vis_png=img("ot-slab-reference.png"))
    for label, params in [("nofix", []), ("fix", ["thin_fix=true"]), ("nofix-4", ["slices=4"])]:
        exr = os.path.join(args.out, f"slab-{label}.exr")
        render(slab, exr, params=params, vis_png=img(f"ot-slab-{label}.png"))
        print(f"slab {label}: mean |dV| {mae(exr, slab_ref):.4f}")
    # Self-occlusion inside a slice and the fade (§3.4, Fig. 7-8): the bunny at 512^2, cropped to
    # its body, V and colour.
    bunny = os.path.join(args.out, "bunny-1.0x.json")
    crop = ["-crop", "256x256+110+150", "+repage"]
    for label, method, params in [("reference", "reference", []), ("nbuffer", "occlusion-textures", []),
                                  ("nofade", "occlusion-textures", ["fade=0"])]:
        v, c = os.path.join(args.out, f"crop-{label}-v.png"), os.path.join(args.out, f"crop-{label}-c.png")
        cmd = [cli, "render", bunny, "-m", method, "--resolution", "512x512", "-o", c, "--visibility-out", v, "-q",
               "--spp", str(args.spp)]
        for p in params:
            cmd += ["-p", p]
        run(cmd)
        run(["convert", v] + crop + [img(f"ot-bunny-body-{label}.png")])
        run(["convert", c] + crop + [img(f"ot-bunny-body-{label}-color.png")])


if __name__ == "__main__":
    main()
