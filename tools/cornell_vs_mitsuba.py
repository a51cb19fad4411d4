#!/usr/bin/env python3
"""Cornell box efficiency, rift against Mitsuba 3, in one run: rounds alternate the two
renderers on the reference pack (../shared/reference/cornell: Mitsuba's own `cornell_box()`),
each at the same samples per pixel and thread count, and the medians are compared.

Efficiency is 1 / (relMSE x seconds), relMSE = mean((v - ref)^2 / (ref^2 + 0.01)) against a
converged reference, as `rift bench convergence` measures it; rift's figures are that
command's. Each round renders every renderer with two seeds (different in every round), and
seconds and relMSE are the two renders' means. The pack's reference has noise of its own
(16,384 samples: relMSE about 1.7e-5), which adds to every relMSE measured against it, a sixth
of rift's at 256 samples; so the reference is `examples/cornell_reference.exr` where it is
there (the same scene rendered the same way with many times the samples by
`tools/cornell_reference.py`; `--reference` picks another), and efficiency is also given from
the variance the two seeds show (half their mean squared difference, regularised alike), which
no reference's noise enters, and the comparison is made both ways. Bias does not enter the
variance either: each renderer's image mean against the reference is printed beside it.
Mitsuba's seconds are those of `mi.render` and its evaluation, after a warm-up render that
compiles its kernels (Dr.Jit caches them), until the image is in host memory, with the scene as
`cornell_box()` builds it but the reference's box filter and unlimited path depth.
Every one of Mitsuba's samplers is tried (independent, stratified, multijitter, orthogonal,
ldsampler; each rounds the samples per pixel to what it can stratify: a square, a prime's
square, a power of two), in the same rounds, and rift is compared with the most efficient.

    python3 tools/cornell_vs_mitsuba.py --rift target/release/rift --spp 256 --rounds 3

`--avx2-only` compiles Mitsuba's kernels for AVX2 in eight lanes (Dr.Jit's LLVM target set
to Haswell through its C library), as on a processor without AVX-512, where it takes longer:
on a host with AVX-512 this shows in one run how the comparison stands on such processors
(Embree, which traces Mitsuba's rays, still picks its own kernels). It is not Mitsuba at its
best on such a host, which the default is.

Needs `pip install mitsuba` and, for the LLVM variants, LLVM 16 or newer as a shared library
(Debian: `apt-get install libllvm19`): LLVM 15.0 aborts compiling Mitsuba's kernels on
processors with AVX-512 and on some without (an AMD EPYC with AVX2 only: "Cannot select ...
fminimum"), so the newest libLLVM found is used, with a warning when it is older than 16.
"""
import argparse
import glob
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import host
from images import read_rgb, rel_mse, rel_variance

ROOT = Path(__file__).resolve().parent.parent
PACK = ROOT.parent / "shared" / "reference" / "cornell"


def newest_libllvm():
    """The newest libLLVM shared library on the system as (major version, path), or None."""
    found = []
    for path in glob.glob("/usr/lib/*/libLLVM*.so*") + glob.glob("/usr/lib/libLLVM*.so*"):
        m = re.search(r"libLLVM(?:-|\.so\.)(\d+)", path)
        if m:
            found.append((int(m.group(1)), path))
    return max(found) if found else None


def rift_round(rift, spp, threads, seed, tmp, reference):
    """rift's (seconds, relMSE, variance, mean RGB against the reference's, %) from
    `rift bench convergence --variance` at `spp` with seeds `seed` and `seed` + 1, against the
    EXR at `reference`."""
    out = subprocess.run(
        [rift, "bench", "convergence", str(ROOT / "examples" / "cornell.toml"),
         "--reference", str(reference), "--spp", str(spp), "--variance",
         "--seed", str(seed), "--csv", str(tmp / "c.csv"), "--plot", str(tmp / "c.png"),
         "--threads", str(threads)],
        check=True, capture_output=True, text=True).stdout
    lines = [line.split() for line in out.splitlines()]
    row = next(r for r in lines if r and r[0] == str(spp))
    mean = next(line for line in out.splitlines() if line.startswith("image mean"))
    off = np.array([float(v) for v in mean.split(":")[1].split()])
    return float(row[1]), float(row[2]), float(row[5]), off


def two_seed_figures(images, seconds, reference):
    """(seconds, relMSE, variance, mean RGB against the reference's, %) of two renders."""
    a, b = images
    rel = (rel_mse(a, reference) + rel_mse(b, reference)) / 2
    mean = (a.mean((0, 1)) + b.mean((0, 1))) / 2 / reference.mean((0, 1)) * 100 - 100
    return statistics.mean(seconds), rel, rel_variance(a, b, reference), mean


def load_mitsuba(variant):
    """Mitsuba with `variant` set, its LLVM variants pointed at the newest libLLVM here."""
    if variant.startswith("llvm") and "DRJIT_LIBLLVM_PATH" not in os.environ:
        newest = newest_libllvm()
        if newest:
            version, lib = newest
            os.environ["DRJIT_LIBLLVM_PATH"] = lib
            if version < 16:
                print(f"warning: the newest libLLVM here is {lib}; LLVM 15 and older can abort "
                      "compiling Mitsuba's kernels (Debian: apt-get install libllvm19)",
                      file=sys.stderr)
    import mitsuba as mi

    mi.set_variant(variant)
    return mi


# Dr.Jit's C library entry points (C++ names) for its LLVM backend's target.
SET_TARGET = "_Z19jit_llvm_set_targetPKcS0_j"
TARGET_CPU = "_Z19jit_llvm_target_cpuv"
VECTOR_WIDTH = "_Z21jit_llvm_vector_widthv"
AVX2_FEATURES = ("+avx,+avx2,+fma,+f16c,+bmi,+bmi2,+lzcnt,+popcnt,+sse4.2,"
                 "-avx512f,-avx512vl,-avx512dq,-avx512bw,-avx512cd")


def restrict_to_avx2():
    """Compiles Dr.Jit's LLVM kernels from here on for AVX2 (Haswell) in eight lanes; returns
    the target and lane count it reports, to be printed."""
    import ctypes
    import drjit as dr
    library = Path(dr.__file__).parent / "libdrjit-core.so"
    try:
        core = ctypes.CDLL(str(library))
        set_target, cpu, width = (getattr(core, n) for n in (SET_TARGET, TARGET_CPU, VECTOR_WIDTH))
    except (OSError, AttributeError) as e:
        sys.exit(f"--avx2-only: this Dr.Jit's {library} has no LLVM target to set ({e})")
    set_target(b"haswell", AVX2_FEATURES.encode(), ctypes.c_uint32(8))
    cpu.restype, width.restype = ctypes.c_char_p, ctypes.c_uint32
    return cpu().decode(), width()


def default_reference():
    """The reference of many samples where `tools/cornell_reference.py` has made it, else the
    pack's."""
    many = ROOT / "examples" / "cornell_reference.exr"
    return many if many.exists() else PACK / "reference.exr"


SAMPLERS = ["independent", "stratified", "multijitter", "orthogonal", "ldsampler"]


def mitsuba_scenes(mi, samplers, spp):
    """The Cornell box with each sampler, warmed up (kernels compiled): {name: (scene, spp)},
    spp the samples per pixel the sampler takes."""
    scenes = {}
    for name in samplers:
        scene = mi.cornell_box()
        scene["sensor"]["film"]["rfilter"] = {"type": "box"}
        scene["sensor"]["sampler"] = {"type": name, "sample_count": spp}
        scene["integrator"] = {"type": "path", "max_depth": -1}
        built = mi.load_dict(scene)
        taken = built.sensors()[0].sampler().sample_count()
        mitsuba_render(mi, built, taken, 0)
        scenes[name] = (built, taken)
    return scenes


def mitsuba_render(mi, scene, spp, seed):
    """Mitsuba's image and seconds, until the image is in host memory."""
    import drjit as dr
    start = time.perf_counter()
    img = mi.render(scene, spp=spp, seed=seed)
    dr.eval(img)
    dr.sync_thread()
    img = np.asarray(img, dtype=np.float64)[..., :3]
    return img, time.perf_counter() - start


def comparison_arguments(doc):
    """The options every Cornell comparison takes: rift's binary, samples per pixel, rounds,
    threads and the reference; the script's `doc` describes it."""
    ap = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    ap.add_argument("--rift", default=str(ROOT / "target/release/rift"))
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--threads", type=int, default=os.cpu_count())
    ap.add_argument("--reference", default=str(default_reference()))
    return ap


def print_efficiencies(runs, peer, spp_of=None):
    """The table of `runs` ({who: [(seconds, relMSE, variance, mean %)] a round}, rift's
    first): medians, efficiency against the reference and from the variance, each run's mean
    against the reference, and rift's ratio to the most efficient of `peer`'s runs both ways.
    `spp_of(who)` adds a column of samples per pixel."""
    width = max(len(who) for who in runs)
    spp_head = f" {'spp':>5}" if spp_of else ""
    print(f"{'':{width}}{spp_head} {'seconds':>9} {'relMSE':>11} {'efficiency':>11} "
          f"{'variance':>11} {'efficiency':>11}  mean against the reference (%)")
    eff, eff_var = {}, {}
    for who, rows in runs.items():
        seconds = statistics.median(r[0] for r in rows)
        rel = statistics.median(r[1] for r in rows)
        var = statistics.median(r[2] for r in rows)
        eff[who], eff_var[who] = 1.0 / (seconds * rel), 1.0 / (seconds * var)
        spp = f" {spp_of(who):5d}" if spp_of else ""
        mean = np.round(np.mean([r[3] for r in rows], axis=0), 3)
        print(f"{who:{width}}{spp} {seconds:9.3f} {rel:11.4e} {eff[who]:11.1f} {var:11.4e} "
              f"{eff_var[who]:11.1f}  {mean}")
    for name, table in (("against the reference", eff), ("from the two seeds' variance", eff_var)):
        best = max((who for who in runs if who != "rift"), key=table.get)
        print(f"efficiency {name}, rift / {peer} at its best ({best}): "
              f"{table['rift'] / table[best]:.2f}")


def main():
    ap = comparison_arguments(__doc__)
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--samplers", default=",".join(SAMPLERS))
    ap.add_argument("--avx2-only", action="store_true",
                    help="Mitsuba's kernels for AVX2 in eight lanes, as without AVX-512")
    args = ap.parse_args()
    if args.avx2_only and not args.variant.startswith("llvm"):
        sys.exit("--avx2-only: only for Mitsuba's LLVM variants")

    mi = load_mitsuba(args.variant)
    import drjit as dr
    if args.variant.startswith("llvm"):
        dr.set_thread_count(args.threads)
    kernels = ""
    if args.avx2_only:
        cpu, width = restrict_to_avx2()
        kernels = f", kernels for {cpu} in {width} lanes"
    reference = read_rgb(args.reference)
    print(f"reference: {args.reference}", flush=True)
    scenes = mitsuba_scenes(mi, args.samplers.split(","), args.spp)

    runs = {"rift": []} | {name: [] for name in scenes}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for k in range(args.rounds):
            seeds = (2 * k + 1, 2 * k + 2)
            runs["rift"].append(
                rift_round(args.rift, args.spp, args.threads, seeds[0], tmp, args.reference))
            seconds, rel = runs["rift"][-1][:2]
            line = f"round {k + 1}: rift {seconds:.2f} s relMSE {rel:.4e}"
            for name, (scene, spp) in scenes.items():
                renders = [mitsuba_render(mi, scene, spp, seed) for seed in seeds]
                runs[name].append(two_seed_figures([r[0] for r in renders],
                                                   [r[1] for r in renders], reference))
                line += f" | {name} {runs[name][-1][0]:.2f} s {runs[name][-1][1]:.4e}"
            print(line, flush=True)

    print(f"\nCornell box, {args.threads} threads, Mitsuba {mi.__version__} {args.variant}"
          f"{kernels}, medians of {args.rounds} rounds, two seeds each")
    print(f"host: {host.describe()}")
    print_efficiencies(runs, "mitsuba", lambda who: args.spp if who == "rift" else scenes[who][1])


if __name__ == "__main__":
    main()
