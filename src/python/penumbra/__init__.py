"""penumbra: soft shadows from area lights, five papers and their ground truth.

    import penumbra
    scene = penumbra.load_scene("scenes/bunny.json")
    r = penumbra.render(scene, "afsm", spp=256)
    r.visibility      # H x W float32: the fraction of the light each pixel sees
    r.color           # H x W x 3 float32, linear RGB
    r.stats           # the --stats-json document as a dict

The same scene files, method names and parameters as the `penumbra` command line, and the
same pixels for the same arguments (docs/python.md). Errors are penumbra.Error (a ValueError)
with the one-line message the command line prints; Ctrl-C stops a render and raises KeyboardInterrupt.
"""

import json as _json
import os as _os

from ._penumbra import (  # noqa: F401  (the extension module, src/python/module.cpp)
    Error,
    RenderResult,
    Scene,
    _compare as _penumbra_compare,
    _sweep as _penumbra_sweep,
    devices,
    load_scene,
    method_devices,
    method_params,
    methods,
    read_exr,
    render,
)

__all__ = ["Error", "Scene", "RenderResult", "load_scene", "methods", "method_params", "method_devices", "devices",
           "render", "compare", "sweep", "read_exr"]


def _scene_from_dict(d, base_path="."):
    """A scene from a dict in the scene-file schema (docs/scene-format.md), validated as a
    file is: a bad key raises ValueError naming it. Relative mesh paths start at base_path."""
    if not isinstance(d, dict):
        raise TypeError(f"Scene.from_dict: expected a dict, got {type(d).__name__}")
    try:
        text = _json.dumps(d, allow_nan=False)
    except (TypeError, ValueError) as e:
        raise ValueError(f"Scene.from_dict: not a JSON document: {e}") from None
    return Scene._from_json(text, _os.fspath(base_path))


def _scene_to_dict(self):
    """The scene's document (as loaded, or as given to from_dict)."""
    return _json.loads(self._document())


Scene.from_dict = staticmethod(_scene_from_dict)
Scene.to_dict = _scene_to_dict


def compare(scene, methods=("all",), spp=256, reference_spp=1024, seed=0, settings=(), runs=1,
            equal_quality=False, cache_dir="", device="cpu", objects=()):
    """Every method in `methods` against the reference (the ground truth) on `scene`: the
    results.json structure of `penumbra compare` as Python data. `settings` are the
    command line's -p/--set keys ("light.size_scale=2", "pcss.variant=xie2007", ...).
    device: where the methods render ("cpu", "gpu", "gpu:N"); an entry "NAME@gpu" picks its own.
    objects: `--objects`, names or shell-style patterns over object names ("ground", "*.leaves"):
    every method's V error also over each one's pixels (results["object_groups"], and per method
    "v_objects" in the same order)."""
    if isinstance(scene, (str, _os.PathLike)):
        scene = load_scene(_os.fspath(scene))
    if isinstance(methods, str):
        methods = [methods]
    if isinstance(objects, str):
        objects = [objects]
    return _json.loads(_penumbra_compare(scene, list(methods), spp, reference_spp, seed, list(settings), runs,
                                         equal_quality, _os.fspath(cache_dir), device, list(objects)))


def sweep(scene, key, values, methods=("all",), spp=256, reference_spp=1024, seed=0, settings=(), runs=1,
          cache_dir="", device="cpu"):
    """One settings key (as `penumbra sweep --param KEY=V1,V2,...`: "light.size_scale",
    "spp", "pcss.pcf_samples", ...) varied over `values`, a comparison per value: the
    sweep.json structure of `penumbra sweep` as Python data."""
    if isinstance(scene, (str, _os.PathLike)):
        scene = load_scene(_os.fspath(scene))
    if isinstance(methods, str):
        methods = [methods]
    return _json.loads(_penumbra_sweep(scene, key, [str(v) for v in values], list(methods), spp, reference_spp, seed,
                                       list(settings), runs, _os.fspath(cache_dir), device))
