"""penumbra.distributed on a dask.distributed LocalCluster of 2 worker processes on 127.0.0.1
(issue 16, docs/distributed.md): the cluster's results are the local ones (every number that is
not a time), tiles put together are the local frame bit for bit, a worker killed mid-job does
not change the result, a failing job is reported and the others finish, and the command line's
--dask gives the files the local command gives. Run by CTest (python_module)."""
import json
import os
import signal
import subprocess
import time

import numpy as np
import pytest

import penumbra

distributed = pytest.importorskip("distributed")
import penumbra.distributed as pd  # noqa: E402

SOURCE = os.environ.get("PENUMBRA_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", "..", ".."))
CLI = os.environ.get("PENUMBRA_CLI", os.path.join(SOURCE, "build", "penumbra"))

# A box read from a mesh file (shipped to the workers or read from the shared path) on a plane.
BOX_OBJ = """v -0.25 0 -0.25\nv 0.25 0 -0.25\nv 0.25 0 0.25\nv -0.25 0 0.25
v -0.25 0.5 -0.25\nv 0.25 0.5 -0.25\nv 0.25 0.5 0.25\nv -0.25 0.5 0.25
f 1 2 3\nf 1 3 4\nf 5 8 7\nf 5 7 6\nf 1 5 6\nf 1 6 2\nf 2 6 7\nf 2 7 3\nf 3 7 8\nf 3 8 4\nf 4 8 5\nf 4 5 1
"""


def scene_doc(mesh="box.obj"):
    return {
        "camera": {"eye": [0, 3, 3], "target": [0, 0, 0], "fov_y": 40, "resolution": [48, 36],
                   "samples_per_pixel": 2},
        "lights": [{"type": "rect", "center": [-0.3, 2.5, 0.2], "normal": [0.1, -1, 0], "size": [0.8, 0.8],
                    "radiance": [5, 5, 5]}],
        "objects": [{"name": "ground", "shape": "plane", "size": [6, 6]},
                    {"name": "box", "mesh": mesh, "translate": [0.2, 0.2, 0]}],
    }


@pytest.fixture(scope="module")
def scene_file(tmp_path_factory):
    folder = tmp_path_factory.mktemp("scene")
    (folder / "box.obj").write_text(BOX_OBJ)
    path = folder / "scene.json"
    path.write_text(json.dumps(scene_doc()))
    return path


@pytest.fixture(scope="module")
def cluster():
    from distributed import Client, LocalCluster
    # Worker processes inherit PYTHONPATH (CTest sets it to build/python) and import penumbra.
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None, silence_logs=40) as c, Client(c) as client:
        yield c, client


# The numbers of a results.json entry that do not depend on the machine's speed.
EXACT = ["ok", "error", "params", "light_samples", "v_mae", "v_rmse", "v_max", "v_mean_signed", "color_psnr",
         "flip", "rays_traced", "texels_visited", "memory_bytes", "view_samples", "eq_v_spp", "eq_flip_spp",
         "eq_v_bound", "eq_flip_bound"]


def exact_part(entry):
    return {k: entry.get(k) for k in EXACT}


def test_sweep_on_the_cluster_equals_the_local_sweep(cluster, scene_file, tmp_path):
    _, client = cluster
    args = dict(methods=["hard", "pcss", "reference"], spp=16, reference_spp=64)
    local = penumbra.sweep(str(scene_file), "light.size_scale", [0.5, 2], **args)
    remote = pd.sweep(client, str(scene_file), "light.size_scale", [0.5, 2], output=tmp_path / "sweep", **args)
    assert [(r["value"], r["method"]) for r in remote["rows"]] == [(r["value"], r["method"]) for r in local["rows"]]
    for a, b in zip(local["rows"], remote["rows"]):
        for key in ["ok", "v_mae", "v_rmse", "flip", "color_psnr", "rays_traced", "light_samples"]:
            assert a[key] == b[key], (a["value"], a["method"], key)
    # The ground truth was rendered once per value, and every method measured against it.
    for comparison in remote["comparisons"]:
        assert comparison["ground_truth"]["spp"] == 64
    assert (tmp_path / "sweep" / "sweep.csv").exists() and (tmp_path / "sweep" / "error.svg").exists()
    on_disk = json.loads((tmp_path / "sweep" / "sweep.json").read_text())
    assert on_disk["rows"] == remote["rows"]


def test_compare_on_the_cluster_with_a_failing_job(cluster, scene_file, tmp_path):
    _, client = cluster
    methods = ["hard", "pcss", "pcss:blocker_samples=0", "afsm"]
    local = penumbra.compare(str(scene_file), methods=methods, spp=16, reference_spp=64, equal_quality=True)
    for meshes in ["ship", "shared"]:
        out = tmp_path / meshes
        remote = pd.compare(client, str(scene_file), methods=methods, spp=16, reference_spp=64, meshes=meshes,
                            output=out)
        assert [m["method"] for m in remote["methods"]] == methods
        for a, b in zip(local["methods"], remote["methods"]):
            assert exact_part(a) == exact_part(b), (meshes, a["method"])
        bad = remote["methods"][2]
        assert not bad["ok"] and "blocker_samples" in bad["error"]
        assert all(m["ok"] for i, m in enumerate(remote["methods"]) if i != 2)
        assert remote["reference_ladder"]["rungs"] == local["reference_ladder"]["rungs"] or all(
            (x["spp"], x["v_mae"], x["flip"]) == (y["spp"], y["v_mae"], y["flip"])
            for x, y in zip(remote["reference_ladder"]["rungs"], local["reference_ladder"]["rungs"]))
        # The same report as `penumbra compare`: page, JSON, CSV and the images of every method.
        assert (out / "index.html").exists() and (out / "results.csv").exists()
        assert json.loads((out / "results.json").read_text())["methods"][0]["v_mae"] == remote["methods"][0]["v_mae"]
        truth = penumbra.read_exr(str(out / "images" / "ground-truth.exr"), "V")
        afsm = penumbra.read_exr(str(out / "images" / "afsm.exr"), "V")
        assert truth.shape == afsm.shape == (36, 48)
        assert abs(float(np.abs(afsm - truth).mean()) - remote["methods"][3]["v_mae"]) < 1e-6


@pytest.mark.parametrize("method", ["reference", "afsm", "occlusion-textures", "pcss"])
def test_a_tiled_render_is_the_local_render_bit_for_bit(cluster, scene_file, method):
    _, client = cluster
    scene = penumbra.load_scene(str(scene_file))
    local = penumbra.render(scene, method, spp=16, resolution=(70, 45), seed=5)
    tiled = pd.render(client, scene, method, spp=16, resolution=(70, 45), seed=5, tile=24)
    # pcss fits its light view to the rendered pixels (not tile-exact): one job, the whole frame.
    assert tiled.stats["tiles"] == (1 if method == "pcss" else 3 * 2)
    assert np.array_equal(tiled.visibility, local.visibility)
    assert np.array_equal(tiled.color, local.color)
    assert tiled.stats["view_samples"] == local.stats["view_samples"]


def test_a_worker_killed_mid_job_changes_nothing(cluster, scene_file):
    c, client = cluster
    scene = penumbra.load_scene(str(scene_file))
    args = dict(spp=4096, resolution=(64, 64), seed=1)
    local = penumbra.render(scene, "reference", **args)
    from distributed import wait
    # The tiled render, started in the background; once a tile is being rendered, its worker
    # process dies (the nanny starts a new one) and the scheduler gives the tile to a worker.
    setup = pd._setup_of(scene, args["spp"], args["spp"], args["seed"], ["resolution=64x64"])
    job_setup, files = pd._with_meshes(setup, "ship")
    payload = pd._scatter(client, files)
    tiles = list(pd._tiles(64, 64, 16))  # 16 jobs of about 0.1 s each
    futures = [client.submit(pd._job_tile, job_setup, payload, "reference", args["spp"], args["seed"], None, 1, t,
                             pure=False) for t in tiles]
    victim = None
    deadline = time.monotonic() + 60
    while victim is None and time.monotonic() < deadline:
        busy = {w: keys for w, keys in client.processing().items() if keys}
        if busy:
            victim = sorted(busy)[0]
            break
        time.sleep(0.02)
    assert victim is not None, "no tile started"
    time.sleep(0.2)
    assert any(f.status == "pending" for f in futures), "the tiles finished before the worker could be killed"
    pid = client.run(os.getpid, workers=[victim])[victim]
    os.kill(pid, signal.SIGKILL)  # as a machine that goes away: no goodbye to the scheduler
    wait(futures, timeout=120)
    color = np.zeros((64, 64, 3), np.float32)
    visibility = np.ones((64, 64), np.float32)
    for (x0, y0, x1, y1), f in zip(tiles, futures):
        col, vis, _ = f.result()
        color[y0:y1, x0:x1] = col
        visibility[y0:y1, x0:x1] = vis
    assert np.array_equal(visibility, local.visibility)
    assert np.array_equal(color, local.color)
    # The worker really died: the scheduler no longer knows its address.
    assert victim not in client.scheduler_info()["workers"]
    client.wait_for_workers(2, timeout=60)


def test_the_command_line_on_the_cluster(cluster, scene_file, tmp_path):
    c, _ = cluster
    address = c.scheduler_address
    common = ["--spp", "16", "--reference-spp", "64", "--methods", "hard,pcss", "-q", "--no-cache"]
    subprocess.run([CLI, "compare", str(scene_file), "-o", str(tmp_path / "local")] + common, check=True)
    subprocess.run([CLI, "compare", str(scene_file), "-o", str(tmp_path / "dask"), "--dask", address] + common,
                   check=True)
    local = json.loads((tmp_path / "local" / "results.json").read_text())
    remote = json.loads((tmp_path / "dask" / "results.json").read_text())
    for a, b in zip(local["methods"], remote["methods"]):
        assert exact_part(a) == exact_part(b), a["method"]
    assert "--dask" in remote["command"]

    subprocess.run([CLI, "sweep", str(scene_file), "--param", "spp=4,16", "-m", "pcss", "--reference-spp", "64", "-q",
                    "--no-cache", "-o", str(tmp_path / "sweep"), "--dask", address], check=True)
    rows = json.loads((tmp_path / "sweep" / "sweep.json").read_text())["rows"]
    assert [r["value"] for r in rows] == ["4", "16"] and all(r["ok"] for r in rows)

    render = ["render", str(scene_file), "-m", "reference", "--spp", "16", "--resolution", "50x30", "-q"]
    subprocess.run([CLI] + render + ["-o", str(tmp_path / "local.exr")], check=True)
    subprocess.run([CLI] + render + ["-o", str(tmp_path / "dask.exr"), "--dask", address, "--tile", "16",
                                     "--stats-json", str(tmp_path / "stats.json")], check=True)
    for channel in ["", "V"]:
        assert np.array_equal(penumbra.read_exr(str(tmp_path / "local.exr"), channel),
                              penumbra.read_exr(str(tmp_path / "dask.exr"), channel))
    assert json.loads((tmp_path / "stats.json").read_text())["tiles"] == 4 * 2

    # Errors: one line naming the thing at fault, a non-zero exit.
    bad = subprocess.run([CLI, "compare", str(scene_file), "--dask", "localhost:1"] + common, capture_output=True,
                         text=True)
    assert bad.returncode != 0 and "--dask localhost:1" in bad.stderr and bad.stderr.count("\n") == 1
    unreachable = subprocess.run([CLI] + render + ["-o", str(tmp_path / "x.exr"), "--dask", "tcp://127.0.0.1:9"],
                                 capture_output=True, text=True, timeout=120)
    assert unreachable.returncode != 0 and "tcp://127.0.0.1:9" in unreachable.stderr
    assert not (tmp_path / "x.exr").exists()


def test_sigterm_stops_the_command_line_and_its_cluster_client(cluster, scene_file, tmp_path):
    c, client = cluster
    out = tmp_path / "never.exr"
    proc = subprocess.Popen([CLI, "render", str(scene_file), "-m", "reference", "--spp", "262144", "--resolution",
                             "48x32", "-q", "-o", str(out), "--dask", c.scheduler_address, "--tile", "16"],
                            stderr=subprocess.PIPE, text=True)
    time.sleep(2.0)  # Python started, the tiles submitted
    start = time.monotonic()
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode != 0 and "interrupted" in err
    assert time.monotonic() - start < 3.0
    assert not out.exists()
    # The tiles already running finish on their workers; the cluster serves the next client.
    client.wait_for_workers(2, timeout=60)


def test_gpu_tiles_on_the_cluster_are_the_local_gpu_render(cluster, scene_file):
    _, client = cluster
    local = penumbra.render(penumbra.load_scene(str(scene_file)), "reference", spp=4, seed=1, device="gpu")
    tiled = pd.render(client, str(scene_file), "reference", spp=4, seed=1, tile=16, device="gpu")
    assert np.array_equal(tiled.visibility, local.visibility)
    assert np.array_equal(tiled.color, local.color)


def test_a_worker_without_a_gpu_refuses_a_gpu_job(scene_file):
    from distributed import Client, LocalCluster
    # A worker whose Vulkan loader finds no driver (VK_DRIVER_FILES names none): no device.
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None,
                      silence_logs=40, env={"VK_DRIVER_FILES": "/nonexistent/icd.json"}) as c, Client(c) as client:
        with pytest.raises(penumbra.Error, match=r"cannot run a --device gpu job"):
            pd.render(client, str(scene_file), "hard", tile=64, device="gpu")
        # The same worker still renders on its CPU.
        assert pd.render(client, str(scene_file), "hard", tile=64).visibility.shape == (36, 48)
