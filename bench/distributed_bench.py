"""Scaling of penumbra.distributed on one machine (docs/distributed.md, "Measured").

    PYTHONPATH=build/python /usr/bin/python3 bench/distributed_bench.py [--runs 3] [--quick]

For each workload, side by side in one run, the median of --runs:
- the plain command line (`penumbra render|compare`, all cores);
- the same work as Dask jobs on a LocalCluster of 1 worker and of 2 workers (1 thread each, so
  2 workers use the 2 cores the command line uses), through `penumbra ... --dask`, the
  command line's own path to the cluster, so both sides include loading the scene and writing
  the outputs;
and per job: its time on the worker and the bytes its result sent back. The overhead of the
Dask path is (2 workers) / (command line) - 1. Workloads:
- tiled: the ground truth of the bunny (reference, 1024 light samples at 1024x1024) in 128x128
  tiles (issue 16's "4096 light samples at 2048x2048" is the same job shape, 16x the work);
- compare: all 13 methods against the ground truth on the bunny at 512x512, 256 light
  samples, no cache (the ground truth is rendered in the run), no reference ladder.
Prints a Markdown table and writes the measurements as JSON (--json FILE).
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CLI = os.environ.get("PENUMBRA_CLI", os.path.join(ROOT, "build", "penumbra"))


def timed(cmd):
    start = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - start


def job_profile(client, run, kinds_wanted):
    """Runs `run()` on the cluster and returns, per kind of job (_job_truth, _job_method,
    _job_tile, ...), the count, the summed and the longest compute time (s) and the bytes the
    jobs' results hold, from Dask's task stream."""
    from distributed import get_task_stream
    with get_task_stream(client) as ts:
        run()
    kinds = {}
    for task in ts.data:
        kind = task["key"].split("-")[0] if isinstance(task["key"], str) else str(task["key"])
        if kind not in kinds_wanted:
            continue
        compute = sum(s["stop"] - s["start"] for s in task["startstops"] if s["action"] == "compute")
        k = kinds.setdefault(kind, {"count": 0, "compute_s": 0.0, "longest_s": 0.0, "result_bytes": 0})
        k["count"] += 1
        k["compute_s"] += compute
        k["longest_s"] = max(k["longest_s"], compute)
        k["result_bytes"] += task.get("nbytes", 0) or 0
    return kinds


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--quick", action="store_true", help="smaller workloads (a check that the script works)")
    ap.add_argument("--json", default="")
    ap.add_argument("--only", default="", help="run only the workloads whose name contains this")
    args = ap.parse_args()
    from distributed import Client, LocalCluster

    bunny = os.path.join(ROOT, "scenes", "bunny.json")
    scale = 8 if args.quick else 1
    workloads = {
        "tiled reference render": ["render", bunny, "-m", "reference", "--spp", str(1024 // scale), "--resolution",
                                   str(1024 // scale), "-q", "--tile", "128"],
        "13-method compare": ["compare", bunny, "--methods", "all", "--spp", "256", "--reference-spp",
                              str(1024 // scale), "--resolution", str(512 // scale), "--no-cache",
                              "--no-equal-quality", "-q"],
    }
    workloads = {k: v for k, v in workloads.items() if args.only in k}
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        def command(name, dask=None):
            base = list(workloads[name])
            out = os.path.join(tmp, "out.exr" if base[0] == "render" else "cmp")
            if dask is None and base[0] == "render":
                base.remove("--tile")
                base.remove("128")
            return [CLI] + base + ["-o", out] + (["--dask", dask] if dask else [])

        clusters = {}
        for n in (1, 2):
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                                   dashboard_address=":0", silence_logs=40)
            clusters[n] = (cluster, Client(cluster))
        try:
            for name in workloads:
                times = {"cli": [], 1: [], 2: []}
                for _ in range(args.runs):  # interleaved: a change of load reaches every variant alike
                    times["cli"].append(timed(command(name)))
                    for n in (1, 2):
                        times[n].append(timed(command(name, clusters[n][0].scheduler_address)))
                med = {k: statistics.median(v) for k, v in times.items()}
                results[name] = {"runs": times, "median_s": {str(k): v for k, v in med.items()},
                                 "speedup_2_over_1": med[1] / med[2], "overhead_2_workers": med[2] / med["cli"] - 1}
            # Per job, for the projection to N machines: the Python API on 2 workers.
            sys.path.insert(0, os.path.join(ROOT, "build", "python"))
            import penumbra.distributed as pd
            client = clusters[2][1]
            profiles = {
                "tiled reference render": (lambda: pd.render(
                    client, bunny, "reference", spp=1024 // scale, resolution=(1024 // scale, 1024 // scale),
                    tile=128), {"_job_tile"}),
                "13-method compare": (lambda: pd.compare(
                    client, bunny, methods=["all"], spp=256, reference_spp=1024 // scale, equal_quality=False,
                    settings=[f"resolution={512 // scale}"]), {"_job_truth", "_job_method", "_job_measure"}),
            }
            for name in results:
                results[name]["jobs"] = job_profile(client, *profiles[name])
        finally:
            for cluster, client in clusters.values():
                client.close()
                cluster.close()
    print(f"load average at the end: {os.getloadavg()[0]:.2f}, runs: {args.runs}")
    print("| workload | command line | Dask, 1 worker | Dask, 2 workers | 2 vs 1 worker | overhead (2 workers vs CLI) |")
    print("|---|---|---|---|---|---|")
    for name, r in results.items():
        m = r["median_s"]
        print(f"| {name} | {m['cli']:.2f} s | {m['1']:.2f} s | {m['2']:.2f} s | {r['speedup_2_over_1']:.2f}x | "
              f"{100 * r['overhead_2_workers']:+.1f}% |")
    print("\n| workload | job | count | summed compute | longest | result bytes |")
    print("|---|---|---|---|---|---|")
    for name, r in results.items():
        for kind, k in sorted(r.get("jobs", {}).items()):
            print(f"| {name} | {kind} | {k['count']} | {k['compute_s']:.2f} s | {k['longest_s']:.2f} s | "
                  f"{k['result_bytes'] / 1e6:.2f} MB |")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=2)


if __name__ == "__main__":
    sys.exit(main())
