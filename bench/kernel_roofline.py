#!/usr/bin/python3
"""Roofline of the online force kernels on one core (issue 29).

usage:
    /usr/bin/python3 bench/kernel_roofline.py                       # r = 54, 79, 89; B = 1, 4, 8, 16
    /usr/bin/python3 bench/kernel_roofline.py --r 79 --lanes 1,8 --reps 7

Runs bench/machine_limits.cpp (this core's FMA peak and read bandwidth, compiled on the spot),
then build/kernel_roofline (built with morse) for every r and number of lanes B, then the machine
limits again (the machine's speed drifts: both are reported and the mean is the reference). For
each kernel - `lane` (CubicKernel, the potential form that `morse simulate` and the per-lane sweep
use above r = 56, one lane per pass), `batch` (CubicKernelBatch, B lanes per pass over the
potential coefficients, the sweep's default, in the widest build the processor has) and `float`
(the same with float coefficients), and on an AVX-512 processor `batch-avx2` and `float-avx2`
(the AVX2 build of the same kernels) - it
prints lane-steps/s, GFLOP/s (useful: 4 per coefficient and lane, plus 2 r^2 for P3), GB/s of
coefficients, their fractions of the core's FMA peak (AVX-512 where the processor has it) and of
the read bandwidth, the fraction of the AVX2 FMA peak, and the gain over the lane kernel. The figures are medians of --reps timings, the kernels of one r timed in turn.
Writes bench/results/roofline_<UTC>.json (summary, raw, limits, git). Exit 0, or 2 if a program
failed.
"""

import argparse
import datetime
import json
import os
import subprocess
import sys

from benchlib import RESULTS, ROOT, git_info
from nlrom_bench import machine_limits


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--r", default="54,79,89")
    ap.add_argument("--lanes", default="1,4,8,16")
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--seconds", type=float, default=0.3, help="per timing")
    ap.add_argument("--limits-n", type=int, default=40_000_000, help="doubles per array of machine_limits")
    args = ap.parse_args()
    exe = os.path.join(ROOT, "build", "kernel_roofline")
    if not os.path.exists(exe):
        sys.exit("kernel_roofline: build morse first (run/test or cmake --build build)")
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    lim0, why0 = machine_limits(args.limits_n)
    p = subprocess.run([exe, "--r", args.r, "--lanes", args.lanes, "--reps", str(args.reps), "--seconds",
                        str(args.seconds)], capture_output=True, text=True, env=env, timeout=3600)
    sys.stderr.write(p.stderr)
    if p.returncode != 0:
        print("kernel_roofline failed (exit %d)" % p.returncode)
        return 2
    raw = json.loads(p.stdout)
    rss_mb = raw.get("max_rss_mb")  # kernel_roofline's own peak (VmHWM)
    lim1, why1 = machine_limits(args.limits_n)
    lims = [x for x in (lim0, lim1) if x]
    peak = sum(x["fma_peak_gflops"] for x in lims) / len(lims) if lims else None
    bw = sum(x["read_gbs"] for x in lims) / len(lims) if lims else None
    peak2 = sum(x.get("fma_avx2_gflops", x["fma_peak_gflops"]) for x in lims) / len(lims) if lims else None
    print("kernel_roofline: one core, FMA peak %s GFLOP/s (%s; AVX2 %s), read bandwidth %s GB/s "
          "(machine_limits before/after: %s)" % (
              "%.1f" % peak if peak else "?", lims[0]["isa"] if lims else "?", "%.1f" % peak2 if peak2 else "?",
              "%.1f" % bw if bw else "?",
              ", ".join("%.1f/%.1f" % (x["fma_peak_gflops"], x["read_gbs"]) for x in lims) or (why0 or why1)))
    summary = []
    for block in raw["r"]:
        r = block["r"]
        lane = next((x for x in block["runs"] if x["kernel"] == "lane"), None)
        print("  r = %d: %.0f coefficients, %.1f MB in double, %.3g MFLOP per lane-step; batch build: %s" % (
            r, block["coefficients"], block["bytes_double"] / 1e6, block["flops_per_lane"] / 1e6,
            block.get("isa", "?")))
        print("    %-10s %3s %12s %9s %8s %7s %7s %7s %8s" % ("kernel", "B", "lane-steps/s", "GFLOP/s", "GB/s", "%peak",
                                                            "%avx2", "%bw", "x lane"))
        for x in block["runs"]:
            row = {"r": r, "kernel": x["kernel"], "lanes": x["lanes"], "lane_steps_per_s": x["lane_steps_per_s"],
                   "gflops": x["gflops"], "gbs": x["gbs"],
                   "fraction_of_fma_peak": x["gflops"] / peak if peak else None,
                   "fraction_of_avx2_fma_peak": x["gflops"] / peak2 if peak2 else None,
                   "fraction_of_read_bandwidth": x["gbs"] / bw if bw else None,
                   "gain_over_lane": x["lane_steps_per_s"] / lane["lane_steps_per_s"] if lane else None}
            summary.append(row)
            print("    %-10s %3d %12.0f %9.2f %8.2f %6.0f%% %6.0f%% %6.0f%% %8s" % (
                x["kernel"], x["lanes"], x["lane_steps_per_s"], x["gflops"], x["gbs"],
                100 * row["fraction_of_fma_peak"] if peak else float("nan"),
                100 * row["fraction_of_avx2_fma_peak"] if peak2 else float("nan"),
                100 * row["fraction_of_read_bandwidth"] if bw else float("nan"),
                "%.2f" % row["gain_over_lane"] if lane else "-"))
    stamp = datetime.datetime.utcnow().strftime("%Y-%m-%dT%H%M%SZ")
    os.makedirs(RESULTS, exist_ok=True)
    path = os.path.join(RESULTS, "roofline_%s.json" % stamp)
    with open(path, "w") as f:
        json.dump({"benchmark": "kernel_roofline", "summary": summary, "fma_peak_gflops": peak,
                   "fma_avx2_gflops": peak2, "read_gbs": bw,
                   "machine_limits": [lim0, lim1], "max_rss_mb": rss_mb, "machine_limits_missing_reason": why0 or why1, "raw": raw,
                   "args": vars(args), "git": git_info()}, f, indent=1)
    print("kernel_roofline: wrote %s" % path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
