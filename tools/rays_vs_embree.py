#!/usr/bin/env python3
"""rift's ray queries against Embree's on the same triangles and rays, in one run.

`rift bench rays --dump DIR` writes its height field and incoherent rays; this script times
Embree 4 (the `embreex` package: pip install embreex) on exactly those, alternating with rift's
own measurement, and prints each round and the medians with rift/Embree ratios.

    python3 tools/rays_vs_embree.py --rift target/release/rift --threads 1 --rounds 3

embreex traces from one thread; for --threads N the rays are split across N processes, each
with its own copy of the scene, started together, and the slowest one's time counts.
"""
import argparse
import multiprocessing as mp
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import host


def rift_round(rift, dump_dir, args):
    """One `rift bench rays` run: {'closest': Mrays/s, 'occlusion': Mrays/s, 'hit': fraction}."""
    cmd = [rift, "bench", "rays", "--cells", str(args.cells), "--rays", str(args.rays),
           "--repeats", str(args.repeats), "--threads", str(args.threads)]
    if dump_dir is not None:
        cmd += ["--dump", str(dump_dir)]
    out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    rates = {name: float(m) for name, m in
             re.findall(r"^(closest hit|occlusion)\s+\S+\s+(\S+)$", out, re.M)}
    hit = float(re.search(r"\(([\d.]+)% hit\)", out).group(1)) / 100
    return {"closest": rates["closest hit"], "occlusion": rates["occlusion"], "hit": hit}


def embree_worker(dump_dir, part, parts, repeats, barrier, results):
    """Builds the scene, then times this process's share of the rays (after a shared start)."""
    from embreex import rtcore_scene as rtcs
    from embreex.mesh_construction import TriangleMesh

    tris = np.load(dump_dir / "triangles.npy")
    origins = np.array_split(np.load(dump_dir / "origins.npy"), parts)[part]
    directions = np.array_split(np.load(dump_dir / "directions.npy"), parts)[part]
    distance = float((dump_dir / "occlusion_distance.txt").read_text())
    dists = np.full(len(origins), distance, dtype=np.float32)
    scene = rtcs.EmbreeScene()
    TriangleMesh(scene, tris)
    scene.run(origins[:1000], directions[:1000])  # commit the scene (builds its BVH)
    times = {"closest": [], "occlusion": []}
    hits = 0
    for _ in range(repeats):
        barrier.wait()
        t = time.perf_counter()
        hits = int((scene.run(origins, directions) >= 0).sum())
        times["closest"].append(time.perf_counter() - t)
        barrier.wait()
        t = time.perf_counter()
        blocked = int((scene.run(origins, directions, dists=dists, query="OCCLUDED") >= 0).sum())
        times["occlusion"].append(time.perf_counter() - t)
        if blocked != hits:
            raise SystemExit(f"embree: occlusion ({blocked}) and closest hit ({hits}) disagree")
    results.put((part, times, hits))


def embree_round(dump_dir, args):
    """Embree on the dumped rays: {'closest': Mrays/s, 'occlusion': Mrays/s, 'hit': fraction}."""
    ctx = mp.get_context("spawn")
    barrier = ctx.Barrier(args.threads)
    results = ctx.Queue()
    procs = [ctx.Process(target=embree_worker,
                         args=(dump_dir, k, args.threads, args.repeats, barrier, results))
             for k in range(args.threads)]
    for p in procs:
        p.start()
    got = [results.get() for _ in procs]
    for p in procs:
        p.join()
        if p.exitcode != 0:
            raise SystemExit("embree worker failed")
    rates = {}
    for query in ("closest", "occlusion"):
        # Per repeat, the slowest process decides; then the median over repeats.
        slowest = [max(t[query][r] for _, t, _ in got) for r in range(args.repeats)]
        rates[query] = args.rays / statistics.median(slowest) / 1e6
    rates["hit"] = sum(h for _, _, h in got) / args.rays
    return rates


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rift", default="target/release/rift", help="the rift binary")
    ap.add_argument("--cells", type=int, default=1024)
    ap.add_argument("--rays", type=int, default=4_000_000)
    ap.add_argument("--repeats", type=int, default=3, help="timed repeats within a round")
    ap.add_argument("--rounds", type=int, default=3, help="alternating rift/Embree rounds")
    ap.add_argument("--threads", type=int, default=1)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        dump_dir = Path(tmp)
        rounds = []
        for r in range(args.rounds):
            # Alternate which goes first, so drift in the machine's speed falls on both (rift
            # goes first in the first round, which writes the rays).
            order = ["rift", "embree"] if r % 2 == 0 else ["embree", "rift"]
            got = {}
            for who in order:
                if who == "rift":
                    got["rift"] = rift_round(args.rift, dump_dir if r == 0 else None, args)
                else:
                    got["embree"] = embree_round(dump_dir, args)
            if abs(got["rift"]["hit"] - got["embree"]["hit"]) > 1e-3:
                raise SystemExit(f"hit fractions differ: rift {got['rift']['hit']:.4f}, "
                                 f"embree {got['embree']['hit']:.4f}")
            rounds.append(got)
            print(f"round {r + 1}: " + ", ".join(
                f"{q} rift {got['rift'][q]:.2f} / embree {got['embree'][q]:.2f} Mrays/s"
                for q in ("closest", "occlusion")), flush=True)
    print(f"\n{2 * args.cells ** 2} triangles, {args.rays} rays "
          f"({100 * rounds[0]['rift']['hit']:.1f}% hit), {args.threads} thread(s), "
          f"medians of {args.rounds} rounds")
    print(f"host: {host.describe()}")
    print(f"{'query':<10} {'rift Mrays/s':>13} {'embree Mrays/s':>15} {'rift/embree':>12}")
    for q in ("closest", "occlusion"):
        a = statistics.median(g["rift"][q] for g in rounds)
        b = statistics.median(g["embree"][q] for g in rounds)
        print(f"{q:<10} {a:>13.2f} {b:>15.2f} {a / b:>12.2f}")


if __name__ == "__main__":
    sys.exit(main())
