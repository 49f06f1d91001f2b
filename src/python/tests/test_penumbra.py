"""The Python module against the command line's files (issue 16, docs/python.md).
Run by CTest (python_module) with PYTHONPATH=build/python and PENUMBRA_CLI set."""
import os
import signal
import subprocess
import threading
import time

import numpy as np
import pytest

import penumbra

SOURCE = os.environ.get("PENUMBRA_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", "..", ".."))
CLI = os.environ.get("PENUMBRA_CLI", os.path.join(SOURCE, "build", "penumbra"))

TINY = {
    "camera": {"eye": [0, 3, 3], "target": [0, 0, 0], "fov_y": 40, "resolution": [40, 30]},
    "lights": [{"type": "rect", "center": [-0.3, 2.5, 0.2], "normal": [0.1, -1, 0], "size": [0.8, 0.8],
                "radiance": [5, 5, 5]}],
    "objects": [{"name": "ground", "shape": "plane", "size": [6, 6]},
                {"name": "box", "shape": "box", "size": [0.5, 0.5, 0.5], "translate": [0.2, 0.45, 0]}],
}


def test_methods_and_their_parameter_tables():
    names = penumbra.methods()
    assert len(names) >= 13 and "reference" in names and "afsm" in names
    table = {p["name"]: p for p in penumbra.method_params("afsm")}
    assert table["resolution"]["type"] == "int"
    assert table["resolution"]["min"] == 8 and table["resolution"]["max"] == 8192
    assert "doc" in table["resolution"]
    with pytest.raises(ValueError, match="nope"):
        penumbra.method_params("nope")


def test_scenes_from_files_and_dicts_with_the_files_errors():
    scene = penumbra.Scene.from_dict(TINY)
    assert scene.resolution == (40, 30)
    assert scene.triangles == 14
    assert scene.to_dict()["lights"][0]["size"] == [0.8, 0.8]
    bad = dict(TINY, lights=[dict(TINY["lights"][0], size=[0, 1])])
    with pytest.raises(penumbra.Error, match=r"lights\[0\]\.size"):
        penumbra.Scene.from_dict(bad)
    assert issubclass(penumbra.Error, ValueError)
    with pytest.raises(ValueError, match="unknown key"):
        penumbra.Scene.from_dict(dict(TINY, colour="red"))
    with pytest.raises(TypeError):
        penumbra.Scene.from_dict([1, 2])
    with pytest.raises(ValueError, match="no such file|cannot"):
        penumbra.load_scene("/nonexistent/scene.json")
    bunny = penumbra.load_scene(os.path.join(SOURCE, "scenes", "bunny.json"))
    assert bunny.triangles > 69000


def test_render_gives_the_cli_pixels(tmp_path):
    path = tmp_path / "tiny.json"
    scene = penumbra.Scene.from_dict(TINY)
    import json
    path.write_text(json.dumps(TINY))
    for method, spp, extra, params in [("reference", 16, ["--seed", "3"], None),
                                       ("pcss", 8, ["-p", "blocker_samples=9"], {"blocker_samples": 9}),
                                       ("afsm", 32, ["--frames", "2"], None)]:
        out = tmp_path / f"{method}.exr"
        subprocess.run([CLI, "render", str(path), "-m", method, "--spp", str(spp), "-o", str(out), "-q"] + extra,
                       check=True)
        seed = 3 if "--seed" in extra else 0
        frames = 2 if "--frames" in extra else 1
        r = penumbra.render(scene, method, spp=spp, seed=seed, params=params, frames=frames)
        assert r.color.shape == (30, 40, 3) and r.color.dtype == np.float32
        assert r.visibility.shape == (30, 40)
        assert np.array_equal(r.visibility, penumbra.read_exr(str(out), "V")), method
        assert np.array_equal(r.color, penumbra.read_exr(str(out))[:, :, :3]), method
        assert r.stats["method"] == method and r.stats["light_samples"] == spp
    small = penumbra.render(scene, "hard", resolution=(16, 8))
    assert small.visibility.shape == (8, 16)


def test_map_cache_reads_lams_maps_back(tmp_path):
    scene = penumbra.Scene.from_dict(TINY)
    maps = tmp_path / "maps"
    first = penumbra.render(scene, "lam", spp=16, params={"resolution": 64}, map_cache=str(maps))
    second = penumbra.render(scene, "lam", spp=16, params={"resolution": 64}, map_cache=str(maps))
    assert first.stats["map_cache"]["misses"] == 1 and first.stats["map_cache"]["stored"] == 1
    assert second.stats["map_cache"]["hits"] == 1 and second.stats["stats"]["prepare_count"] == 0
    assert np.array_equal(first.visibility, second.visibility)
    assert "map_cache" not in penumbra.render(scene, "hard").stats
    (tmp_path / "file").write_text("x")
    with pytest.raises(penumbra.Error, match="--map-cache .*file: exists and is not a folder"):
        penumbra.render(scene, "lam", map_cache=str(tmp_path / "file"))


def test_wrong_types_and_values_raise_never_crash():
    scene = penumbra.Scene.from_dict(TINY)
    with pytest.raises(TypeError):
        penumbra.render(scene, 123)
    with pytest.raises(TypeError):
        penumbra.render("not a scene")
    with pytest.raises(ValueError, match="nope"):
        penumbra.render(scene, "nope")
    with pytest.raises(ValueError, match="spp"):
        penumbra.render(scene, spp=0)
    with pytest.raises(ValueError, match="resolution"):
        penumbra.render(scene, resolution=(0, 5))
    with pytest.raises(ValueError, match="unknown parameter"):
        penumbra.render(scene, "pcss", params={"nope": 1})
    with pytest.raises(TypeError):
        penumbra.render(scene, "pcss", params={"bias": object()})


def test_render_releases_the_gil():
    scene = penumbra.load_scene(os.path.join(SOURCE, "scenes", "contact.json"))
    ticks = 0
    done = threading.Event()

    def count():
        nonlocal ticks
        while not done.is_set():
            ticks += 1
            time.sleep(0.001)

    t = threading.Thread(target=count)
    t.start()
    start = time.perf_counter()
    penumbra.render(scene, "reference", spp=64, resolution=(128, 128))
    elapsed = time.perf_counter() - start
    done.set()
    t.join()
    # Python code ran while the render did: about one tick per millisecond of it.
    assert ticks > elapsed * 1000 * 0.3, (ticks, elapsed)


def test_ctrl_c_interrupts_a_render():
    scene = penumbra.load_scene(os.path.join(SOURCE, "scenes", "contact.json"))
    timer = threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    start = time.perf_counter()
    with pytest.raises(KeyboardInterrupt):
        penumbra.render(scene, "reference", spp=65536)
    assert time.perf_counter() - start < 3.0
    timer.join()
    # The module still works afterwards.
    assert penumbra.render(scene, "hard", resolution=(8, 8)).visibility.shape == (8, 8)


def test_compare_returns_the_results_json_structure():
    scene = penumbra.Scene.from_dict(TINY)
    res = penumbra.compare(scene, methods=["hard", "pcss"], spp=16, reference_spp=64)
    runs = {r["method"]: r for r in res["methods"]}
    assert set(runs) == {"hard", "pcss"}
    assert runs["pcss"]["v_mae"] < runs["hard"]["v_mae"]
    with pytest.raises(ValueError, match="nope"):
        penumbra.compare(scene, methods=["nope"])
    # Errors by object: the ground's and the box's pixels add up to every surface's.
    res = penumbra.compare(scene, methods=["hard"], spp=16, reference_spp=64, objects=["ground", "box", "*"])
    groups = res["object_groups"]
    assert [g["pattern"] for g in groups] == ["ground", "box", "*"]
    assert groups[0]["pixels"] + groups[1]["pixels"] == groups[2]["pixels"] > 0
    by = res["methods"][0]["v_objects"]
    assert abs(by[0]["v_mae"] * by[0]["pixels"] + by[1]["v_mae"] * by[1]["pixels"] -
               by[2]["v_mae"] * by[2]["pixels"]) < 1e-9
    with pytest.raises(Exception, match="'leaf' matches no object"):
        penumbra.compare(scene, methods=["hard"], spp=16, reference_spp=64, objects="leaf")


def test_sweep_returns_the_sweep_json_structure():
    scene = penumbra.Scene.from_dict(TINY)
    res = penumbra.sweep(scene, "light.size_scale", [0.5, 2], methods=["pcss"], spp=16, reference_spp=64)
    assert res["key"] == "light.size_scale"
    rows = res["rows"]
    assert [r["value"] for r in rows] == ["0.5", "2"]
    assert all(r["method"] == "pcss" for r in rows)
    with pytest.raises(ValueError, match="no_such_key"):
        penumbra.sweep(scene, "no_such_key", [1], methods=["hard"])


# --- The GPU (docs/gpu.md; issue 30 part 3): on this machine's Vulkan device (lavapipe in CI).

def test_devices_and_what_runs_where():
    devices = penumbra.devices()
    assert devices and devices[0]["device"] == "gpu:0"
    assert any(d["usable"] for d in devices)
    assert all(d["subgroup_size"] > 0 for d in devices if d["usable"])
    assert penumbra.method_devices("reference") == ["cpu", "gpu"]
    assert penumbra.method_devices("lam") == ["cpu", "gpu"]
    with pytest.raises(penumbra.Error, match="unknown shadow method"):
        penumbra.method_devices("no-such-method")


def test_render_on_the_gpu_gives_the_cpus_picture(tmp_path):
    scene = penumbra.Scene.from_dict(TINY)
    for method, spp in [("hard", 1), ("reference", 8)]:
        cpu = penumbra.render(scene, method, spp=spp, seed=2)
        gpu = penumbra.render(scene, method, spp=spp, seed=2, device="gpu")
        assert gpu.stats["device"] != "cpu" and "gpu_ms" in gpu.stats
        assert np.abs(cpu.visibility - gpu.visibility).mean() <= 1e-3, method
    # The same pixels as `penumbra render --device gpu`.
    import json
    path = tmp_path / "tiny.json"
    path.write_text(json.dumps(TINY))
    out = tmp_path / "gpu.exr"
    subprocess.run([CLI, "render", str(path), "-m", "reference", "--spp", "8", "--seed", "2", "--device", "gpu",
                    "-o", str(out), "-q"], check=True)
    r = penumbra.render(scene, "reference", spp=8, seed=2, device="gpu")
    assert np.array_equal(r.visibility, penumbra.read_exr(str(out), "V"))
    # Kernel profiling (PENUMBRA_GPU_PROFILE=1, read as the render starts): each kernel's GPU time.
    assert "gpu_kernels" not in r.stats
    os.environ["PENUMBRA_GPU_PROFILE"] = "1"
    try:
        profiled = penumbra.render(scene, "reference", spp=8, seed=2, device="gpu")
    finally:
        del os.environ["PENUMBRA_GPU_PROFILE"]
    kernels = profiled.stats["gpu_kernels"]
    assert kernels["reference_fans"]["dispatches"] >= 1 and kernels["camera_pass"]["ms"] >= 0
    assert np.array_equal(profiled.visibility, r.visibility)
    # Bad devices and CPU-only methods: penumbra.Error with the command line's line.
    with pytest.raises(penumbra.Error, match="expected cpu, gpu or gpu:N"):
        penumbra.render(scene, "hard", device="tpu")
    with pytest.raises(penumbra.Error, match="this machine has"):
        penumbra.render(scene, "hard", device="gpu:97")
    # A method without a GPU version (the first by name; the registry's own answer).
    cpu_only = [m for m in penumbra.methods() if penumbra.method_devices(m) == ["cpu"]]
    if cpu_only:
        with pytest.raises(penumbra.Error, match=cpu_only[0] + " has no GPU version"):
            penumbra.render(scene, cpu_only[0], device="gpu")


def test_compare_puts_cpu_and_gpu_versions_side_by_side():
    scene = penumbra.Scene.from_dict(TINY)
    r = penumbra.compare(scene, ["hard", "hard@gpu"], spp=4, reference_spp=16)
    rows = {m["method"]: m for m in r["methods"]}
    assert rows["hard"]["ok"] and rows["hard@gpu"]["ok"]
    assert abs(rows["hard"]["v_mae"] - rows["hard@gpu"]["v_mae"]) <= 1e-3
    r = penumbra.compare(scene, ["hard"], spp=4, reference_spp=16, device="gpu")
    assert r["methods"][0]["ok"]
