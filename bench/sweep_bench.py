#!/usr/bin/python3
"""Benchmark of contact runs and speed sweeps (issue 10, seed 003 §5).

usage:
    /usr/bin/python3 bench/sweep_bench.py                 # meshes/blade_coarse.msh, tip basis, 3 runs
    /usr/bin/python3 bench/sweep_bench.py --runs 1 --derivatives 20 --mesh meshes/blade.msh
    /usr/bin/python3 bench/sweep_bench.py --fixed 15 --derivatives 40 --dt 5e-8 --limits   # r = 79, the seed's

The model: `morse nlrom` with boundary `tip` (8 contact nodes, 24 physical DOFs), --fixed
fixed-interface modes and --derivatives modal derivatives, exact tensors (r = 24 + fixed + derivatives).
Parts, each --runs times (medians):
  - single: `morse simulate` on one core with casing contact at 1,450 rad/s (the unbatched
    kernel that `auto` picks: potential above r = 56): steps/s, and with --limits its GFLOP/s and
    coefficient GB/s against the FMA peak and read bandwidth measured by bench/machine_limits.cpp;
  - batch: `morse sweep` on one core with L speeds and -sweep_batch L, L in --lanes, for each kernel
    of --kernels (-sweep_kernel lane, potential, folded; float = potential with -sweep_float;
    potential-avx2, potential-avx512, potential-baseline: potential with -sweep_isa avx2, ...):
    lane-steps/s and the gain over the lane kernel with as many lanes;
  - map: a sweep of --map-speeds speeds (16; -sweep_batch --map-batch, 8) on 2 ranks with each kernel of --kernels, and on 1
    rank with the default kernel: lane-steps/s per core, the gain of each kernel over `lane` (the
    sweep's kernel before the batched potential kernel, issue 29: target x3 at r = 79), and the
    2-rank efficiency t1 / (2 t2).
Every run has -sim_tangent_checks 0 (the checks, a fixed count per speed, would dominate runs this
short). Writes bench/results/sweep_<UTC>_<mesh>_r<r>.json (summary, runs, git, blas).
Exit status 0 on success, 2 if morse failed.
"""

import argparse
import datetime
import json
import os
import re
import shutil
import sys
import tempfile

from benchlib import RESULTS, ROOT, blas_info, git_info, med, run_mpi
from nlrom_bench import machine_limits


def rate(stdout, pattern):
    m = re.search(pattern, stdout)
    return float(m.group(1)) if m else None


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mesh", default=os.path.join(ROOT, "meshes", "blade_coarse.msh"))
    ap.add_argument("--fixed", type=int, default=10)
    ap.add_argument("--derivatives", type=int, default=20)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--dt", type=float, default=1e-7)
    ap.add_argument("--revolutions", type=float, default=0.1, help="per speed in the batch part")
    ap.add_argument("--lanes", default="1,4,8,16")
    ap.add_argument("--kernels", default="lane,potential,float,folded",
                    help="sweep kernels to time (lane, potential, float, folded)")
    ap.add_argument("--map-batch", type=int, default=8, help="-sweep_batch of the map part")
    ap.add_argument("--map-speeds", type=int, default=16,
                    help="speeds of the map part (1 rad/s apart from 1,000 rad/s); its keys keep the name map16")
    ap.add_argument("--limits", action="store_true",
                    help="measure the machine's FMA peak and read bandwidth (bench/machine_limits.cpp) and give the "
                         "single run's ratio to them")
    ap.add_argument("--rom", help="reuse this morse nlrom file (the tip boundary) instead of building one")
    args = ap.parse_args()
    morse = os.path.join(ROOT, "build", "morse")
    if not os.path.exists(morse):
        sys.exit("sweep_bench: build morse first (run/test or cmake --build build)")
    work = tempfile.mkdtemp(prefix="sweep_bench_")
    rom = args.rom or os.path.join(work, "rom.h5")
    res, _ = ({}, None) if args.rom else run_mpi("nlrom", [morse, "nlrom", "-mesh", args.mesh, "-clamp", "root", "-boundary", "tip",
                               "-nlrom_basis", "cbmd", "-nlrom_num_fixed_modes", str(args.fixed),
                               "-nlrom_num_derivatives", str(args.derivatives), "-nlrom_training_tfinal", "0.0314",
                               "-nlrom_damping_modal", "5e-4", "-nlrom_damping_modes", "10", "-nlrom_forces", "exact",
                               "-load_sets", "LE", "-load_LE_dir", "y", "-load_LE_amplitude", "300",
                               "-load_LE_omega", "2000", "-out", rom], 2, work, 1)
    if res is None:
        return 2
    # No tangent checks (-sim_tangent_checks 0): 200 per speed at about 8 ms each (r = 79) would be
    # most of these short runs' time (a 200-revolution speed spends under 1 % in them).
    casing = ["-contact_set", "tip", "-sim_dt", str(args.dt), "-sim_tangent_checks", "0"]
    runs = {"single": [], "batch": {}, "scaling": {"1": [], "2": []}}
    r_size = None
    # Single runs (unbatched kernel) at 1,450 rad/s.
    for _ in range(args.runs):
        res, _ = run_mpi("simulate", [morse, "simulate", "-rom", rom, "-sim_omega", "1450", "-sim_revolutions",
                                      str(args.revolutions), "-sim_output_every", "1000",
                                      "-out", os.path.join(work, "sim.h5")] + casing, 1, work, 1)
        if res is None:
            return 2
        r_size = int(rate(res["stdout"], r"r = (\d+)"))
        k = re.search(r"nonlinear force kernel: (\w+), ([0-9.eE+-]+) flop and ([0-9.eE+-]+) MB per step", res["stdout"])
        runs["single"].append({"steps_per_s": rate(res["stdout"], r"steps in [\d.]+ s \(([\d.e+]+) steps/s"),
                               "kernel": k.group(1) if k else "linear",
                               "kernel_flops_per_step": float(k.group(2)) if k else None,
                               "kernel_mb_per_step": float(k.group(3)) if k else None})
    lanes = [int(x) for x in args.lanes.split(",")]

    kernels = args.kernels.split(",")
    for k in kernels:
        if k not in ("lane", "potential", "float", "folded", "potential-avx2", "potential-avx512",
                     "potential-baseline"):
            sys.exit("sweep_bench: unknown kernel %s" % k)

    def kernel_options(kernel):
        if kernel.startswith("potential-"):
            return ["-sweep_kernel", "potential", "-sweep_isa", kernel.split("-", 1)[1]]
        return ["-sweep_kernel", "potential", "-sweep_float"] if kernel == "float" else ["-sweep_kernel", kernel]

    def sweep(n_speeds, batch, ranks, revolutions, kernel):
        res, _ = run_mpi("sweep", [morse, "sweep", "-rom", rom, "-sweep_omega_min", "1000", "-sweep_omega_max",
                                   str(1000 + n_speeds - 1), "-sweep_omega_step", "1", "-sim_revolutions",
                                   str(revolutions), "-sweep_batch", str(batch), "-sweep_monitor", "LE",
                                   "-sweep_spectrum_bins", "50", "-sweep_restart",
                                   "-out", os.path.join(work, "sweep.h5")] + casing + kernel_options(kernel),
                         ranks, work, 1)
        if res is None:
            return None
        return {"lane_steps_per_s": rate(res["stdout"], r"([\d.e+]+) steps/s over all ranks"),
                "seconds": rate(res["stdout"], r"speeds in ([\d.]+) s"),
                "kernel_percent": rate(res["stdout"], r"([\d.]+)% in the force kernels"),
                "idle_percent": rate(res["stdout"], r"([\d.]+)% idle"),
                "isa": (re.search(r"in the force kernels \(potential, ([^)]*\))\)", res["stdout"]) or [None, None])[1],
                "max_rss_mb": res.get("rank_max_rss_mb")}

    runs["batch"] = {k: {} for k in kernels}
    runs["map"] = {k: [] for k in kernels}
    for L in lanes:
        for k in kernels:
            runs["batch"][k][str(L)] = []
        for _ in range(args.runs):
            for k in kernels:  # interleaved: the machine's drift hits every kernel alike
                x = sweep(L, L, 1, args.revolutions, k)
                if x is None:
                    return 2
                runs["batch"][k][str(L)].append(x)
    for _ in range(args.runs):
        for k in kernels:
            x = sweep(args.map_speeds, args.map_batch, 2, args.revolutions, k)
            if x is None:
                return 2
            runs["map"][k].append(x)
        x = sweep(args.map_speeds, args.map_batch, 1, args.revolutions, "potential")
        if x is None:
            return 2
        runs["scaling"]["1"].append(x)
    runs["scaling"]["2"] = runs["map"].get("potential", [])
    n2 = r_size * (r_size + 1) // 2
    n3 = r_size * (r_size + 1) * (r_size + 2) // 6
    n4 = r_size * (r_size + 1) * (r_size + 2) * (r_size + 3) // 24
    flops_potential = 4.0 * (n3 + n4) + 2.0 * r_size * r_size  # per lane-step, useful
    single = med([x["steps_per_s"] for x in runs["single"]])
    batch = {k: {L: med([x["lane_steps_per_s"] for x in runs["batch"][k][str(L)]]) for L in lanes} for k in kernels}
    mapr = {k: med([x["lane_steps_per_s"] for x in runs["map"][k]]) for k in kernels}
    isa = None  # the build of the batched potential kernel that `potential` ran (from the summary line)
    for x in runs["map"].get("potential", []):
        isa = isa or x.get("isa")
    summary = {
        "r": r_size, "potential_isa": isa, "map_batch": args.map_batch, "map_speeds": args.map_speeds, "dt": args.dt, "flops_per_lane_step_potential": flops_potential,
        "single_steps_per_s": single, "single_kernel": runs["single"][0]["kernel"],
        "batch_lane_steps_per_s": {k: {str(L): batch[k][L] for L in lanes} for k in kernels},
        "map16_2ranks_lane_steps_per_s_per_core": {k: mapr[k] / 2 for k in kernels},
        "map16_2ranks_idle_percent": {k: med([x["idle_percent"] for x in runs["map"][k]]) for k in kernels},
    }
    if "lane" in kernels:
        summary["batch_gain_over_lane_kernel"] = {k: {str(L): batch[k][L] / batch["lane"][L] for L in lanes}
                                                  for k in kernels}
        summary["map16_gain_over_lane_kernel"] = {k: mapr[k] / mapr["lane"] for k in kernels}
    if "potential" in kernels:
        summary["batch_potential_gflops"] = {str(L): batch["potential"][L] * flops_potential * 1e-9 for L in lanes}
        t1 = med([x["seconds"] for x in runs["scaling"]["1"]])
        t2 = med([x["seconds"] for x in runs["scaling"]["2"]])
        summary.update({"sweep16_seconds_1_rank": t1, "sweep16_seconds_2_ranks": t2,
                        "scaling_efficiency_2_ranks": t1 / (2 * t2)})
    # The single run against the machine: the kernel streams its coefficients once per step.
    k0 = runs["single"][0]
    if k0["kernel_flops_per_step"]:
        gflops = single * (k0["kernel_flops_per_step"] + 4.0 * r_size * r_size) * 1e-9
        gbs = single * k0["kernel_mb_per_step"] * 1e6 * 1e-9
        summary.update({"single_gflops": gflops, "single_gbs": gbs})
        if args.limits:
            lim, why = machine_limits(40_000_000)
            summary["machine_limits"] = lim if lim else {"missing_reason": why}
            if lim:
                summary["single_ratio_over_fma_peak"] = gflops / lim["fma_peak_gflops"]
                summary["single_ratio_over_read_bandwidth"] = gbs / lim["read_gbs"]
    print("sweep_bench: r = %d, dt = %g s, %d run(s) per point (medians)" % (r_size, args.dt, args.runs))
    if "single_gflops" in summary:
        print("  single run: %.1f GFLOP/s, %.1f GB/s of coefficients%s" % (
            summary["single_gflops"], summary["single_gbs"],
            ", %.0f %% of the FMA peak, %.0f %% of the read bandwidth" % (
                100 * summary["single_ratio_over_fma_peak"], 100 * summary["single_ratio_over_read_bandwidth"])
            if "single_ratio_over_fma_peak" in summary else ""))
    print("  single run (unbatched %s kernel, contact): %.0f steps/s" % (summary["single_kernel"], single))
    for L in lanes:
        print("  one core, %2d lanes: %s" % (L, ", ".join(
            "%s %.0f%s" % (k, batch[k][L], " (x%.2f)" % summary["batch_gain_over_lane_kernel"][k][str(L)]
                           if "lane" in kernels else "") for k in kernels)) + " lane-steps/s")
    print("  %d-speed map on 2 ranks, lane-steps/s per core: %s" % (args.map_speeds, ", ".join(
        "%s %.0f%s" % (k, mapr[k] / 2, " (x%.2f)" % summary["map16_gain_over_lane_kernel"][k] if "lane" in kernels
                       else "") for k in kernels)))
    if "sweep16_seconds_1_rank" in summary:
        print("  %d-speed sweep (potential): %.2f s on 1 rank, %.2f s on 2 ranks: efficiency %.1f %%" % (
            args.map_speeds, summary["sweep16_seconds_1_rank"], summary["sweep16_seconds_2_ranks"],
            100 * summary["scaling_efficiency_2_ranks"]))
    stamp = datetime.datetime.utcnow().strftime("%Y-%m-%dT%H%M%SZ")
    name = os.path.splitext(os.path.basename(args.mesh))[0]
    os.makedirs(RESULTS, exist_ok=True)
    path = os.path.join(RESULTS, "sweep_%s_%s_r%d.json" % (stamp, name, r_size))
    with open(path, "w") as f:
        json.dump({"summary": summary, "runs": runs, "args": vars(args), "git": git_info(), "blas": blas_info(morse)},
                  f, indent=1)
    print("sweep_bench: wrote %s" % path)
    shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
