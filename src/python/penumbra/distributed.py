"""penumbra on a Dask cluster: comparisons, sweeps and big frames split into jobs.

    from dask.distributed import Client
    import penumbra, penumbra.distributed as pd

    client = Client("tcp://scheduler:8786")             # or LocalCluster(...) on one machine
    results = pd.compare(client, "scenes/bunny.json", methods=["afsm", "pcss"], output="cmp")
    sweep = pd.sweep(client, "scenes/plant.json", "light.size_scale", [0.5, 1, 2], methods=["lam"])
    frame = pd.render(client, "scenes/bunny.json", "reference", spp=4096, resolution=(2048, 2048))

The jobs (docs/distributed.md):
- a comparison: the ground truth once per scene and setting, a job per method measured against
  it (Dask sends the one ground truth to every worker that needs it), the reference ladder once
  the methods are in; the client assembles results.json with the same C++ code as
  `penumbra compare`, and writes the same report;
- a sweep: a comparison per value, all of their jobs at once;
- a frame: image tiles (crop windows of the same camera), each a job; every random number is
  keyed by the pixel and the camera sample, so the tiles put together are the local render's
  image bit for bit.

Meshes reach the workers either shipped (meshes="ship", the default: the client reads every mesh
file and the files it names, sends them once, and each worker writes them to a folder of its
own) or read from a path every worker sees (meshes="shared": the scene's mesh paths made absolute).

A worker that dies takes its jobs with it; the scheduler gives them to another worker (Dask's
`allowed-failures`) and the result is the same, since a job's output depends on its inputs only.
A job that fails (a bad method parameter, say) is reported as that method's error and the others
finish. The command line's `--dask tcp://HOST:PORT` (compare, sweep, render) runs this module:
`python3 -m penumbra.distributed --request FILE`.
"""

import hashlib
import json
import os
import collections
import functools
import shutil
import sys
import tempfile
import threading
import time

import numpy as np

from . import Error, RenderResult, Scene, load_scene  # noqa: F401
from . import _penumbra

__all__ = ["compare", "sweep", "render", "TiledRender"]

# Dask re-runs a job that raised this many more times (a worker that dies is handled by the
# scheduler's own allowed-failures, not by this).
RETRIES = 1


# --- Scenes and meshes on the workers ------------------------------------------------------

def _mesh_companions(path):
    """Files a mesh file names beside itself (relative paths): a glTF's buffers and images,
    an OBJ's material libraries. Data URIs and absolute paths are left alone."""
    out = []
    lower = path.lower()
    try:
        if lower.endswith(".gltf"):
            with open(path, "rb") as f:
                doc = json.loads(f.read().decode("utf-8"))
            for section in ("buffers", "images"):
                for item in doc.get(section, []) or []:
                    uri = item.get("uri") if isinstance(item, dict) else None
                    if isinstance(uri, str) and not uri.startswith("data:") and "://" not in uri:
                        out.append(uri)
        elif lower.endswith(".obj"):
            with open(path, "rb") as f:
                for line in f:
                    if line.startswith(b"mtllib"):
                        out.extend(p.decode("utf-8", "replace") for p in line.split()[1:])
    except (OSError, ValueError):
        pass  # the mesh reader reports an unreadable file with its own message
    return [c for c in out if not os.path.isabs(c)]


def _scatter(client, files):
    """Sends a scene's mesh files (the payload dict of _with_meshes) to the cluster once, as one
    future under a key of its own.

    Scattered as a one-element list: dask scatters a dict value by value under the dict's own
    keys, so every job's payload was "digest" and "files", and a job that scattered them while an
    earlier job's futures of the same keys were being released lost them: its tiles failed with
    "computation on lost data" (1 run in 3 of test_distributed here). ``hash=False`` for the same
    reason with content-hashed keys (dask/distributed#8576).

    Broadcast to every worker: scattered data has no task that could compute it again, so a
    worker that dies holding its only copy would take it with it and the scheduler would cancel
    every job that needs it (test_a_worker_killed_mid_job_changes_nothing failed so in a fresh
    clone's CI on 2026-12-07: the killed worker was the one the payload had gone to). A worker that joins later
    (a nanny's restart) fetches it from a peer that holds it."""
    return client.scatter([files], broadcast=True, hash=False)[0]


def _with_meshes(setup_text, meshes):
    """The setup for the workers and the files to send them: ("ship") each object's mesh and
    its companion files, keyed by a digest of their bytes, the document's paths rewritten to a
    placeholder folder the worker fills in; ("shared") the document's paths made absolute."""
    if meshes not in ("ship", "shared"):
        raise ValueError(f"meshes={meshes!r}: expected 'ship' or 'shared'")
    setup = json.loads(setup_text)
    base = os.path.dirname(os.path.abspath(setup["scene_path"]))
    objects = setup["scene_doc"].get("objects", [])
    files, digest = {}, hashlib.sha256()
    for i, obj in enumerate(objects if isinstance(objects, list) else []):
        if not isinstance(obj, dict) or not isinstance(obj.get("mesh"), str):
            continue
        mesh = obj["mesh"] if os.path.isabs(obj["mesh"]) else os.path.join(base, obj["mesh"])
        if meshes == "shared":
            obj["mesh"] = os.path.abspath(mesh)
            continue
        folder = f"mesh{i}"
        names = [os.path.basename(mesh)] + _mesh_companions(mesh)
        for name in names:
            source = os.path.join(os.path.dirname(mesh), name)
            rel = os.path.normpath(os.path.join(folder, name))
            if rel.startswith("..") or os.path.isabs(rel):
                raise Error(f"{mesh}: names {name}, outside its folder: use meshes='shared'")
            try:
                with open(source, "rb") as f:
                    data = f.read()
                mtime = os.stat(source).st_mtime_ns
            except OSError as e:
                raise Error(f"{source}: cannot read it to send to the workers: {e.strerror}") from None
            files[rel] = (data, mtime)
            digest.update(rel.encode() + b"\0" + hashlib.sha256(data).digest())
        obj["mesh"] = os.path.join("{PENUMBRA_SHIPPED}", folder, names[0])
    payload = {"digest": digest.hexdigest()[:32], "files": files} if files else None
    return json.dumps(setup), payload


def _materialize(setup_text, payload):
    """On a worker: the shipped files written once to a folder of their own (named by their
    digest, written beside and renamed into place, so concurrent jobs never see half a file;
    modification times kept, so cache keys agree across workers), and the setup pointing at it."""
    if payload is None:
        return setup_text
    root = os.path.join(tempfile.gettempdir(), f"penumbra-shipped-{os.getuid()}", payload["digest"])
    if not os.path.isdir(root):
        os.makedirs(os.path.dirname(root), exist_ok=True)
        staging = tempfile.mkdtemp(prefix=".staging-", dir=os.path.dirname(root))
        for rel, (data, mtime) in payload["files"].items():
            path = os.path.join(staging, rel)
            os.makedirs(os.path.dirname(path), exist_ok=True)
            with open(path, "wb") as f:
                f.write(data)
            os.utime(path, ns=(mtime, mtime))
        try:
            os.rename(staging, root)
        except OSError:  # another job on this machine got there first
            shutil.rmtree(staging, ignore_errors=True)
    return setup_text.replace("{PENUMBRA_SHIPPED}", root)


def _worker_threads():
    """Render threads for a job: all of the worker's (its jobs take turns, _RENDER_LOCK)."""
    try:
        from distributed import get_worker
        return max(1, int(get_worker().nthreads))
    except (ImportError, ValueError, AttributeError):
        return 0


# --- The jobs (run on the workers; plain data in and out) -----------------------------------

# One penumbra job at a time in a worker process, with all of the worker's threads: Dask runs
# up to nthreads tasks at once, and each of them rendering with nthreads threads would
# oversubscribe the cores. Waiting here releases the GIL.
_RENDER_LOCK = threading.Lock()
# The frame renderers of the last frames this process rendered tiles of, so the tiles of one
# frame share the Embree scene and the light-space structures (_penumbra._FrameRenderer).
_FRAME_RENDERERS = collections.OrderedDict()
_FRAME_RENDERERS_KEPT = 2


def _locked(job):
    @functools.wraps(job)
    def run(*args):
        with _RENDER_LOCK:
            return job(*args)
    return run


# The scenes this process loaded last, by setup: a comparison's jobs on one worker load it once.
_SCENES = collections.OrderedDict()
_SCENES_KEPT = 2


def _scene(setup, payload):
    """The setup with its shipped files in place, and its scene (loaded once per process)."""
    setup = _materialize(setup, payload)
    scene = _SCENES.pop(setup, None) or _penumbra._scene_of_setup(setup)
    _SCENES[setup] = scene  # the most recent last
    while len(_SCENES) > _SCENES_KEPT:
        _SCENES.popitem(last=False)
    return setup, scene


@_locked
def _job_truth(setup, payload, cache_dir, timed):
    setup, scene = _scene(setup, payload)
    return _penumbra._ground_truth(setup, scene, cache_dir, _worker_threads(), timed)


@_locked
def _job_method(setup, payload, label, runs, warmup_runs, keep_images):
    _require_device(_penumbra._method_device(setup, label))
    setup, scene = _scene(setup, payload)
    return _penumbra._compare_method(setup, scene, label, runs, warmup_runs, keep_images, _worker_threads())


@_locked
def _job_measure(method_result, truth, keep_images):
    entry, color, visibility = method_result
    return _penumbra._measure_method(entry, color, visibility, truth, keep_images)


@_locked
def _job_ladder(setup, payload, truth, entries, runs, warmup_runs, cache_dir):
    setup, scene = _scene(setup, payload)
    return _penumbra._comparison_ladder(setup, scene, truth, entries, runs, warmup_runs, cache_dir, _worker_threads())


@_locked
def _job_tile(setup, payload, method, spp, seed, params, frames, crop, device="cpu"):
    _require_device(device)
    key = json.dumps([setup, payload["digest"] if payload else None, method, spp, seed, params, frames, device],
                     sort_keys=True)
    renderer = _FRAME_RENDERERS.pop(key, None)
    if renderer is None:
        _, scene = _scene(setup, payload)
        renderer = _penumbra._FrameRenderer(scene, method, spp, seed, params, _worker_threads(), frames, device)
    _FRAME_RENDERERS[key] = renderer  # the most recent last
    while len(_FRAME_RENDERERS) > _FRAME_RENDERERS_KEPT:
        _FRAME_RENDERERS.popitem(last=False)
    r = renderer.render(crop)
    return r.color, r.visibility, r.stats


# --- The client side ------------------------------------------------------------------------

def _client(client):
    if isinstance(client, str):
        from distributed import Client
        try:
            return Client(client, timeout="20s")
        except (OSError, TimeoutError) as e:
            raise Error(f"{client}: cannot reach the Dask scheduler ({e})") from None
    return client


def _setup_of(scene, spp, reference_spp, seed, settings, device="cpu"):
    if isinstance(scene, (str, os.PathLike)):
        scene = load_scene(os.fspath(scene))
    if not isinstance(scene, Scene):
        raise TypeError(f"scene: expected a penumbra.Scene or a path, got {type(scene).__name__}")
    return _penumbra._run_setup(scene, spp, reference_spp, seed, [str(s) for s in settings], device)


def _require_device(device):
    """On a worker, before a GPU job: a usable Vulkan device, or one line naming the worker."""
    if device == "cpu":
        return
    try:
        usable = [d for d in _penumbra.devices() if d["usable"]]
    except Error as e:  # no Vulkan loader at all
        usable, why = [], str(e)
    else:
        why = "no usable Vulkan device"
    index = int(device.split(":")[1]) if ":" in device else None
    if not usable or (index is not None and not any(d["device"] == device for d in usable)):
        try:
            from distributed import get_worker
            where = f"worker {get_worker().address}"
        except (ImportError, ValueError):
            where = "this worker"
        raise Error(f"{where} cannot run a --device {device} job: {why} (run GPU jobs on workers with a GPU, "
                    f"or use --device cpu)")


def _report(progress, done, total, what):
    if progress:
        print(f"\r{what}: {done}/{total} jobs done", end="" if done < total else "\n", file=sys.stderr, flush=True)


class _Comparison:
    """The futures of one comparison (one scene and setting) on the cluster."""

    def __init__(self, client, setup, payload, methods, ground_truth, runs, warmup_runs, keep_images, cache_dir):
        self.setup, self.payload, self.methods = setup, payload, methods
        # The methods render while the ground truth does (they need it only to be measured):
        # each method's images then meet the ground truth in a small job, where the images are.
        # Without `reference` among the methods the speed-ups divide the ground truth's time,
        # which must then be one the worker measured with its own threads (issue 32).
        timed = "reference" not in methods
        self.truth = (client.submit(_job_truth, setup, payload, cache_dir, timed, pure=False, retries=RETRIES,
                                    priority=10)
                      if ground_truth else None)
        renders = [client.submit(_job_method, setup, payload, label, runs, warmup_runs,
                                 keep_images or ground_truth, pure=False, retries=RETRIES) for label in methods]
        self.runs = renders if not ground_truth else [
            client.submit(_job_measure, r, self.truth, keep_images, pure=False, retries=RETRIES, priority=5)
            for r in renders]

    def futures(self):
        return ([self.truth] if self.truth is not None else []) + self.runs

    def method_results(self):
        """Each method's (entry, colour, V); a job that failed is its method's error."""
        out = []
        for label, f in zip(self.methods, self.runs):
            try:
                out.append(f.result())
            except Exception as e:  # noqa: BLE001 (any job error is that method's row)
                entry = {"method": label, "ok": False, "error": _one_line(e)}
                out.append((json.dumps(entry), None, None))
        return out


def _one_line(e):
    text = str(e).strip().splitlines()
    return text[0] if text else type(e).__name__


def _wait(client, futures, what, progress):
    """Waits for the futures (reporting progress); job errors stay in their futures."""
    from distributed import as_completed
    total = len(futures)
    done = 0
    _report(progress, done, total, what)
    for _ in as_completed(futures):
        done += 1
        _report(progress, done, total, what)


def _compare_setup(client, setup, methods, ground_truth=True, runs=1, warmup_runs=0, equal_quality=True,
                   cache_dir="", meshes="ship", output=None, heatmap_scale=0.0, write_images=True, command="",
                   progress=False):
    started = time.monotonic()
    client = _client(client)
    methods = _penumbra._expand_methods(list(methods))
    if not methods:
        raise Error("compare: no methods to run")
    _penumbra._check_methods(setup, methods)
    job_setup, files = _with_meshes(setup, meshes)
    payload = _scatter(client, files) if files else None
    keep = output is not None
    c = _Comparison(client, job_setup, payload, methods, ground_truth, runs, warmup_runs, keep, cache_dir)
    _wait(client, c.futures(), "compare", progress)
    truth = c.truth.result() if c.truth is not None else None  # a failed ground truth ends the comparison
    method_runs = c.method_results()
    ladder = None
    if truth is not None and equal_quality:
        ladder = client.submit(_job_ladder, job_setup, payload, truth, [r[0] for r in method_runs], runs,
                               warmup_runs, cache_dir, pure=False, retries=RETRIES).result()
    results = _penumbra._assemble_comparison(setup, truth[0] if truth else None, [r[0] for r in method_runs], ladder,
                                             (time.monotonic() - started) * 1000.0, command)
    if output is not None:
        images = {json.loads(r[0])["method"]: (r[1], r[2]) for r in method_runs if r[1] is not None}
        _penumbra._write_comparison(results, (truth[1], truth[2]) if truth else None, images, os.fspath(output),
                                    float(heatmap_scale), bool(write_images))
    return json.loads(results)


def compare(client, scene, methods=("all",), spp=256, reference_spp=1024, seed=0, settings=(), runs=1, warmup_runs=0,
            equal_quality=True, cache_dir="", meshes="ship", output=None, progress=False, device="cpu"):
    """penumbra.compare on a cluster: the ground truth rendered once and shared, a job per
    method, the reference ladder; returns the results.json structure (the same numbers as a
    local compare, times apart) and, with `output`, writes `penumbra compare`'s report there.
    `client`: a dask.distributed.Client or a scheduler address."""
    if isinstance(methods, str):
        methods = [methods]
    setup = _setup_of(scene, spp, reference_spp, seed, settings, device)
    return _compare_setup(client, setup, methods, True, runs, warmup_runs, equal_quality, os.fspath(cache_dir),
                          meshes, output, progress=progress)


def _sweep_setup(client, setup, key, values, methods, ground_truth=True, runs=1, warmup_runs=0, cache_dir="",
                 meshes="ship", output=None, plots=(), x_scale="auto", y_scale="auto", command="", progress=False):
    started = time.monotonic()
    client = _client(client)
    values = [str(v) for v in values]
    methods = _penumbra._expand_methods(list(methods))
    setups = _penumbra._sweep_setups(setup, key, values, methods)  # a bad value fails before any job
    jobs = []
    payloads = {}
    for s in setups:
        job_setup, files = _with_meshes(s, meshes)
        if files and files["digest"] not in payloads:
            payloads[files["digest"]] = _scatter(client, files)
        payload = payloads[files["digest"]] if files else None
        jobs.append(_Comparison(client, job_setup, payload, methods, ground_truth, runs, warmup_runs, False,
                                cache_dir))
    _wait(client, [f for c in jobs for f in c.futures()], f"sweep {key}", progress)
    comparisons = []
    for s, c, value in zip(setups, jobs, values):
        truth = c.truth.result() if c.truth is not None else None
        runs_ = c.method_results()
        comparisons.append(_penumbra._assemble_comparison(s, truth[0] if truth else None, [r[0] for r in runs_], None,
                                                          0.0, f"(sweep {key}={value})"))
    result = _penumbra._assemble_sweep(setup, key, values, methods, ground_truth, comparisons,
                                       (time.monotonic() - started) * 1000.0, command,
                                       os.fspath(output) if output is not None else "", list(plots), x_scale, y_scale)
    return json.loads(result)


def sweep(client, scene, key, values, methods=("all",), spp=256, reference_spp=1024, seed=0, settings=(), runs=1,
          warmup_runs=0, ground_truth=True, cache_dir="", meshes="ship", output=None, plots=(), progress=False,
          device="cpu"):
    """penumbra.sweep on a cluster: every value's comparison as jobs, all at once; returns the
    sweep.json structure and, with `output`, writes sweep.csv, sweep.json and the plots there."""
    if isinstance(methods, str):
        methods = [methods]
    setup = _setup_of(scene, spp, reference_spp, seed, settings, device)
    return _sweep_setup(client, setup, key, values, methods, ground_truth, runs, warmup_runs, os.fspath(cache_dir),
                        meshes, output, plots, progress=progress)


class TiledRender:
    """A frame rendered as tiles: .color (H x W x 3), .visibility (H x W), .stats (the first
    tile's document with the frame's size, the tiles' counters and times summed, and `tiles`)."""

    def __init__(self, color, visibility, stats):
        self.color, self.visibility, self.stats = color, visibility, stats


def _tiles(width, height, tile):
    for y0 in range(0, height, tile):
        for x0 in range(0, width, tile):
            yield (x0, y0, min(width, x0 + tile), min(height, y0 + tile))


def _merge_stats(stats, width, height, tile, wall_ms):
    out = dict(stats[0])
    out["resolution"] = [width, height]
    out["tiles"] = len(stats)
    out["tile_size"] = tile
    out["wall_ms"] = wall_ms
    for key in ("view_samples", "camera_pass_ms", "total_ms"):
        out[key] = sum(s[key] for s in stats)
    inner = dict(out["stats"])
    for key in ("rays_traced", "texels_visited", "total_ms", "prepare_count"):
        inner[key] = sum(s["stats"].get(key, 0) for s in stats)
    inner["memory_bytes"] = max(s["stats"].get("memory_bytes", 0) for s in stats)
    phases = {}
    for s in stats:
        for name, ms in s["stats"].get("phases_ms", {}).items():
            phases[name] = phases.get(name, 0.0) + ms
    inner["phases_ms"] = phases
    out["stats"] = inner
    out.pop("crop", None)
    return out


def _render_setup(client, setup, method="reference", spp=256, seed=0, params=None, frames=1, tile=256,
                  meshes="ship", progress=False, device="cpu"):
    started = time.monotonic()
    client = _client(client)
    if not isinstance(tile, int) or tile < 1 or tile > 16384:
        raise Error(f"tile={tile}: expected an integer in [1, 16384]")
    scene = _penumbra._scene_of_setup(setup)  # the camera (and a bad scene fails here, not on a worker)
    width, height = scene.resolution
    job_setup, files = _with_meshes(setup, meshes)
    payload = _scatter(client, files) if files else None
    # A method whose light views are fitted to the rendered pixels (MethodInfo::tile_exact) would
    # give tiles that differ from the whole frame's: it renders as one job.
    if not _penumbra._tile_exact(method):
        tile = max(width, height)
    tiles = list(_tiles(width, height, tile))
    futures = [client.submit(_job_tile, job_setup, payload, method, spp, seed, params, frames, crop, device,
                             pure=False, retries=RETRIES) for crop in tiles]
    _wait(client, futures, "render", progress)
    color = np.zeros((height, width, 3), np.float32)
    visibility = np.ones((height, width), np.float32)
    stats = []
    for (x0, y0, x1, y1), f in zip(tiles, futures):
        c, v, s = f.result()  # a tile that failed (a bad parameter) raises its error here
        color[y0:y1, x0:x1] = c
        visibility[y0:y1, x0:x1] = v
        stats.append(s)
    return TiledRender(color, visibility, _merge_stats(stats, width, height, tile,
                                                       (time.monotonic() - started) * 1000.0))


def render(client, scene, method="reference", spp=256, resolution=None, seed=0, params=None, frames=1, tile=256,
           meshes="ship", progress=False, device="cpu"):
    """penumbra.render on a cluster, one job per `tile` x `tile` pixels: the same pixels as
    penumbra.render(scene, method, spp, resolution, seed, params, frames=frames, device=device), bit
    for bit. device='gpu': every tile on its worker's GPU; a worker without one refuses the job with
    one line naming it."""
    settings = []
    if resolution is not None:
        w, h = resolution
        settings.append(f"resolution={int(w)}x{int(h)}")
    setup = _setup_of(scene, spp, spp, seed, settings, device)
    return _render_setup(client, setup, method, spp, seed, params, frames, tile, meshes, progress, device)


# --- `penumbra compare|sweep|render --dask ADDRESS` -------------------------------------------

def _run_request(request):
    client = _client(request["scheduler"])
    command = request["command"]
    setup = json.dumps(request["setup"])  # the run setup (run_setup_json) as its jobs carry it
    meshes = request.get("meshes", "ship")
    progress = request.get("progress", False)
    if command == "compare":
        _compare_setup(client, setup, request["methods"], request.get("ground_truth", True),
                       request["runs"], request.get("warmup_runs", 0), request["equal_quality"], request["cache_dir"],
                       meshes, request["output"], request["heatmap_scale"], request["write_images"],
                       request["command_line"], progress)
    elif command == "sweep":
        _sweep_setup(client, setup, request["key"], request["values"], request["methods"],
                     request["ground_truth"], request["runs"], request["warmup_runs"], request["cache_dir"], meshes,
                     request["output"], request["plots"], request["x_scale"], request["y_scale"],
                     request["command_line"], progress)
    elif command == "render":
        params = dict(kv.split("=", 1) for kv in request["params"])
        r = _render_setup(client, setup, request["method"], request["spp"], request["seed"], params,
                          request["frames"], request["tile"], meshes, progress, request.get("device", "cpu"))
        _penumbra._write_frame(request["frame_out"], r.color, r.visibility)
        with open(request["stats_out"], "w") as f:
            json.dump(r.stats, f)
    else:
        raise Error(f"request: unknown command {command!r}")


def main(argv=None):
    import argparse
    parser = argparse.ArgumentParser(prog="python3 -m penumbra.distributed",
                                     description="Runs a `penumbra ... --dask` request on a Dask cluster.")
    parser.add_argument("--request", required=True, help="the request file the command line wrote (JSON)")
    args = parser.parse_args(argv)
    try:
        with open(args.request) as f:
            request = json.load(f)
        _run_request(request)
    except KeyboardInterrupt:
        print("penumbra: interrupted", file=sys.stderr)
        return 130
    except (Error, ValueError, OSError, KeyError, TypeError) as e:
        print(f"penumbra: error: {_one_line(e)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    # Run as `python3 -m penumbra.distributed`, this file is __main__: the jobs must be those of
    # the imported module, which the workers import by name (a function of __main__ would be
    # pickled by value, with the module's globals).
    from penumbra.distributed import main as _main
    sys.exit(_main())
