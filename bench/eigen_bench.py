#!/usr/bin/python3
"""Many-mode eigen solves: morse's block solver against its Krylov-Schur solver and CalculiX.

Run from the repository root with Debian's interpreter (h5py and numpy are needed):

    /usr/bin/python3 bench/eigen_bench.py                      # rotor 37 (50 modes) and the stator (1000 modes)
    /usr/bin/python3 bench/eigen_bench.py --cases rotor37 --runs 3
    /usr/bin/python3 bench/eigen_bench.py --cases stator --solvers block --runs 1
    /usr/bin/python3 bench/eigen_bench.py --no-ccx             # without CalculiX

Cases (each `morse modes`, 2 ranks by default, one thread per rank):

  rotor37  ../shared/meshes/rotor37-nlstep/blade.inp, clamped by its *BOUNDARY, 61,098 free DOFs,
           the 50 lowest modes (-modes_nev 50). The peer is CalculiX 2.20 (Debian's calculix-ccx,
           installed by this script with apt-get if missing) on the same deck with its step
           replaced by `*FREQUENCY` / 50 (its default Lanczos/ARPACK shift-invert solver, SPOOLES
           factorization, 2 threads: OMP_NUM_THREADS=2, CCX_NPROC_EQUATION_SOLVER=2), run in the
           same invocation, interleaved with morse's runs. The first 10 frequencies must agree with
           CalculiX's to --ccx-rtol (0.3 %).
  stator   meshes/stator.msh clamped at `mount`, 146,202 free DOFs, the 1000 lowest modes
           (-modes_nev 1000). The reference for the old solver is Krylov-Schur with count slicing
           (the default before the block solver).
  stator500k  the generated stator at h = 8.9 mm (`morse mesh stator -stator_h 0.0089`, made in
           out/bench_eigen/ if missing): 478,002 free DOFs, the 1000 lowest modes (the basis
           capped by the memory available)

Every run of a case must give the same frequencies as the first morse run of that case to
--rtol (1e-8); the block solver's max relative residual and its Sylvester check are recorded.

Writes bench/results/eigen_<UTC date-time>.json (per case and solver: stage seconds, medians,
min, max, samples; process wall; peak memory per rank and over all ranks; the frequencies; the
ratios block / krylovschur and ccx / block) and prints a summary.
Exit status: 0 done and consistent; 1 frequencies disagree; 2 a run failed.
"""

import argparse
import datetime
import glob
import json
import os
import re
import subprocess
import sys
import time

import h5py
import numpy as np

from benchlib import (RESULTS, ROOT, blas_info, ensure_ccx, git_info, med, mpi_env, parse_stage_table, run_mpi,
                      wait_idle)

SHARED_R37 = os.path.normpath(os.path.join(ROOT, "..", "shared", "meshes", "rotor37-nlstep"))
MORSE = os.path.join(ROOT, "build", "morse")
WORK = os.path.join(ROOT, "out", "bench_eigen")

CASES = {
    "rotor37": {"mesh": os.path.join(SHARED_R37, "blade.inp"), "clamp": "*BOUNDARY", "nev": 50},
    "stator": {"mesh": os.path.join(ROOT, "meshes", "stator.msh"), "clamp": "mount", "nev": 1000},
    # The generated stator at h = 8.9 mm: 169,316 nodes, 478,002 free DOFs (made here if missing).
    # The default basis (2,208 vectors: Q and M Q alone 16.9 GB) is capped by the solver to 70 % of
    # the memory available after the factorization (about 1,730 vectors on a 24 GB machine).
    "stator500k": {"mesh": os.path.join(WORK, "stator500k.msh"), "clamp": "mount", "nev": 1000,
                   "generate": ["mesh", "stator", "-stator_h", "0.0089"]},
}


# Solver variants: the name in --solvers -> morse's options. "slices<P>": the block solver by
# spectrum slicing on P subcommunicators side by side (-modes_block_partitions P, one slice each).
SOLVER_ARGS = {"block": ["-modes_eigen_solver", "block"],
               "krylovschur": ["-modes_eigen_solver", "krylovschur"],
               "slices1": ["-modes_eigen_solver", "block", "-modes_block_slices", "2"],
               "slices2": ["-modes_eigen_solver", "block", "-modes_block_partitions", "2"]}


def morse_args(case, solver, out, extra):
    c = CASES[case]
    return [MORSE, "modes", "-mesh", c["mesh"], "-clamp", c["clamp"], "-modes_nev", str(c["nev"])] + \
        SOLVER_ARGS[solver] + ["-modes_xdmf", "false", "-out", out] + c.get("extra", []) + extra


def read_freqs(path):
    with h5py.File(path, "r") as f:
        return np.array(f["/fom/frequencies_hz"][()])


# The stages of the eigen solve: the factorization, the solve, the vectors, the residual check of
# every pair and the Sylvester check of a count solve (each its own stage, none nested).
EIGEN_STAGES = ("Factor", "SliceCutoff", "InertiaCount", "EigenSolve", "EigenVectors", "EigenResiduals", "InertiaCheck", "SliceCounts")


def eigen_seconds(sec):
    return sum(sec.get(k, 0.0) for k in EIGEN_STAGES)


def summary_lines(stdout):
    keep = []
    for line in stdout.splitlines():
        if re.search(r"residual|Sylvester|block Krylov|restart|slicing|slices|inertia", line):
            keep.append(line.strip())
    return keep


def ccx_deck(nev):
    """The rotor 37 deck with its steps replaced by one *FREQUENCY step of nev modes."""
    d = os.path.join(WORK, "ccx")
    os.makedirs(d, exist_ok=True)
    link = os.path.join(d, "blade.msh")
    if not os.path.exists(link):
        os.symlink(os.path.join(SHARED_R37, "blade.msh"), link)
    with open(os.path.join(SHARED_R37, "blade.inp")) as f:
        lines = f.read().splitlines()
    head = []
    for line in lines:
        if line.upper().startswith("*STEP"):
            break
        head.append(line)
    head += ["*STEP", "*FREQUENCY", str(nev), "*END STEP"]
    with open(os.path.join(d, "r37.inp"), "w") as f:
        f.write("\n".join(head) + "\n")
    return d


def run_ccx(exe, d, threads):
    for ext in (".dat", ".frd", ".sta", ".cvg", ".12d", ".eig"):
        p = os.path.join(d, "r37" + ext)
        if os.path.exists(p):
            os.remove(p)
    env = dict(os.environ, OMP_NUM_THREADS=str(threads), CCX_NPROC_EQUATION_SOLVER=str(threads),
               OPENBLAS_NUM_THREADS="1")
    cmd = ["/usr/bin/time", "-f", "BENCH_MAXRSS_KB %M", exe, "-i", "r37"]
    t0 = time.monotonic()
    p = subprocess.run(cmd, cwd=d, capture_output=True, text=True, env=env)
    wall = time.monotonic() - t0
    if p.returncode != 0 or not os.path.exists(os.path.join(d, "r37.dat")):
        sys.stderr.write("ccx failed (exit %d)\n%s\n%s\n" % (p.returncode, p.stdout[-3000:], p.stderr[-3000:]))
        return None
    rss = re.findall(r"BENCH_MAXRSS_KB (\d+)", p.stderr)
    # .dat: "E I G E N V A L U E   O U T P U T" then rows "mode eigenvalue real(rad/time) cycles/time imag"
    freqs = []
    with open(os.path.join(d, "r37.dat")) as f:
        text = f.read()
    m = re.search(r"E I G E N V A L U E\s+O U T P U T(.*?)(?:P A R T I C I P|E F F E C T I V E|\Z)", text, re.S)
    if m:
        for line in m.group(1).splitlines():
            fl = line.split()
            if len(fl) >= 4 and fl[0].isdigit():
                freqs.append(float(fl[3]))
    return {"process_wall": wall, "max_rss_mb": int(rss[-1]) / 1024.0 if rss else None,
            "frequencies_hz": freqs, "stdout_tail": p.stdout[-1500:]}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", default="rotor37,stator")
    ap.add_argument("--solvers", default="block,krylovschur")
    ap.add_argument("--runs", type=int, default=3, help="runs per case and solver (medians)")
    ap.add_argument("--stator-runs", type=int, default=None, help="runs for the stator (default --runs)")
    ap.add_argument("--ranks", type=int, default=2)
    ap.add_argument("--no-ccx", action="store_true")
    ap.add_argument("--ccx-threads", type=int, default=2)
    ap.add_argument("--rtol", type=float, default=1e-8)
    ap.add_argument("--ccx-rtol", type=float, default=3e-3)
    ap.add_argument("--idle", type=float, default=0.15, help="wait until at most this fraction of CPUs is busy")
    ap.add_argument("extra", nargs="*", help="extra morse options (after --)")
    a = ap.parse_args()
    if not os.path.exists(MORSE):
        sys.exit("build morse first (run/build): %s missing" % MORSE)
    os.makedirs(WORK, exist_ok=True)
    os.makedirs(RESULTS, exist_ok=True)
    cases = [c for c in a.cases.split(",") if c]
    solvers = [s for s in a.solvers.split(",") if s]
    for c in cases:
        if c not in CASES:
            sys.exit("unknown case %s" % c)
        if not os.path.exists(CASES[c]["mesh"]) and "generate" in CASES[c]:
            print("%s: generating %s" % (c, CASES[c]["mesh"]), flush=True)
            subprocess.run([MORSE] + CASES[c]["generate"] + ["-out", CASES[c]["mesh"]], check=True,
                           env=dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1"))
        if not os.path.exists(CASES[c]["mesh"]):
            sys.exit("%s: mesh %s not found" % (c, CASES[c]["mesh"]))
    ccx = None
    if "rotor37" in cases and not a.no_ccx:
        ccx = ensure_ccx()
        if not ccx:
            print("CalculiX could not be installed: no peer comparison", flush=True)
    stamp = datetime.datetime.utcnow().strftime("%Y-%m-%dT%H%M%SZ")
    res = {"benchmark": "eigen", "date_utc": stamp, "ranks": a.ranks, "runs": a.runs,
           "extra_options": a.extra, "environment": {"git": git_info(), "blas": blas_info(MORSE),
                                                      "morse_mtime": os.path.getmtime(MORSE)},
           "cases": {}}
    status = 0
    for case in cases:
        runs = a.stator_runs if (case.startswith("stator") and a.stator_runs) else a.runs
        c = CASES[case]
        cr = {"mesh": c["mesh"], "clamp": c["clamp"], "nev": c["nev"], "runs": runs, "solvers": {}}
        ref = None
        samples = {s: [] for s in solvers}
        ccx_samples = []
        for k in range(runs):
            order = solvers + (["ccx"] if ccx and case == "rotor37" else [])
            for s in order:
                busy = wait_idle(a.idle, 600)
                if s == "ccx":
                    d = ccx_deck(c["nev"])
                    r = run_ccx(ccx, d, a.ccx_threads)
                    if r is None:
                        status = 2
                        continue
                    r["busy_before"] = busy
                    ccx_samples.append(r)
                    print("  %-8s ccx        run %d: %8.2f s  (%.0f MB)" % (case, k + 1, r["process_wall"],
                                                                        r["max_rss_mb"] or 0), flush=True)
                    continue
                out = os.path.join(WORK, "%s_%s.h5" % (case, s))
                r, cmd = run_mpi("%s %s" % (case, s), morse_args(case, s, out, a.extra), a.ranks, WORK, 1)
                if r is None:
                    status = 2
                    continue
                sec, peak = parse_stage_table(r["stdout"])
                # the frequency table's rows ("  12   1234.5   ...") parse as stages too: drop them
                sec = {k: v for k, v in sec.items() if not k.isdigit()}
                peak = {k: v for k, v in peak.items() if not k.isdigit()}
                f = read_freqs(out)
                if ref is None:
                    ref = f
                dev = float(np.max(np.abs(f - ref) / ref)) if len(f) == len(ref) else float("inf")
                if dev > a.rtol:
                    print("  %s %s: frequencies differ from the first run by %.2e" % (case, s, dev))
                    status = max(status, 1)
                samples[s].append({"stage_seconds": sec, "peak_mb": peak, "process_wall": r["process_wall"],
                                   "rank_max_rss_mb": r["rank_max_rss_mb"], "sum_max_rss_mb": r["sum_max_rss_mb"],
                                   "foreign_cpu_fraction": r["foreign_cpu_fraction"], "busy_before": busy,
                                   "max_rel_freq_dev": dev, "summary": summary_lines(r["stdout"]),
                                   "frequencies_hz": f.tolist()})
                eig = eigen_seconds(sec)
                print("  %-8s %-11s run %d: eigen %8.2f s, total %8.2f s, wall %8.2f s, peak %.0f MB/rank"
                      % (case, s, k + 1, eig, sec.get("total", 0), r["process_wall"],
                         max(peak.values()) if peak else 0), flush=True)
        for s in solvers:
            ss = samples[s]
            if not ss:
                continue
            stages = sorted({k for x in ss for k in x["stage_seconds"]})
            st = {k: {"median": med([x["stage_seconds"].get(k) for x in ss]),
                      "min": min(x["stage_seconds"].get(k, 0) for x in ss),
                      "max": max(x["stage_seconds"].get(k, 0) for x in ss)} for k in stages}
            eig = [eigen_seconds(x["stage_seconds"]) for x in ss]
            cr["solvers"][s] = {"stage_seconds": st, "eigen_seconds_median": med(eig),
                                "eigen_seconds_samples": eig,
                                "total_median": med([x["stage_seconds"].get("total") for x in ss]),
                                "process_wall_median": med([x["process_wall"] for x in ss]),
                                "peak_mb_per_rank_max": max(max(x["peak_mb"].values()) for x in ss),
                                "peak_mb_all_ranks_max": max((x["sum_max_rss_mb"] or 0) for x in ss),
                                "summary": ss[0]["summary"], "samples": ss}
        if ccx_samples:
            fr = ccx_samples[0]["frequencies_hz"]
            cr["ccx"] = {"process_wall_median": med([x["process_wall"] for x in ccx_samples]),
                         "process_wall_samples": [x["process_wall"] for x in ccx_samples],
                         "max_rss_mb": max((x["max_rss_mb"] or 0) for x in ccx_samples),
                         "threads": a.ccx_threads, "frequencies_hz": fr, "version": ccx,
                         "stdout_tail": ccx_samples[0]["stdout_tail"]}
            if ref is not None and len(fr) >= 10:
                d10 = [abs(fr[i] - ref[i]) / ref[i] for i in range(10)]
                cr["ccx"]["first10_rel_diff"] = d10
                cr["ccx"]["first10_max_rel_diff"] = max(d10)
                if max(d10) > a.ccx_rtol:
                    print("  %s: CalculiX's first 10 frequencies differ by %.2e > %.1e" % (case, max(d10), a.ccx_rtol))
                    status = max(status, 1)
        ratios = {}
        sv = cr["solvers"]
        if "block" in sv and "krylovschur" in sv:
            ratios["krylovschur_over_block_eigen"] = sv["krylovschur"]["eigen_seconds_median"] / sv["block"]["eigen_seconds_median"]
            ratios["krylovschur_over_block_wall"] = sv["krylovschur"]["process_wall_median"] / sv["block"]["process_wall_median"]
        if "ccx" in cr:
            for s in sv:
                ratios["ccx_over_%s_wall" % s] = cr["ccx"]["process_wall_median"] / sv[s]["process_wall_median"]
        cr["ratios"] = ratios
        res["cases"][case] = cr
    path = os.path.join(RESULTS, "eigen_%s.json" % stamp)
    with open(path + ".tmp", "w") as f:
        json.dump(res, f, indent=1)
    os.replace(path + ".tmp", path)
    print("\nsummary (medians, %d ranks)" % a.ranks)
    for case, cr in res["cases"].items():
        for s, v in cr["solvers"].items():
            print("  %-8s %-11s eigen %8.2f s  wall %8.2f s  peak %6.0f MB/rank %6.0f MB all" %
                  (case, s, v["eigen_seconds_median"], v["process_wall_median"], v["peak_mb_per_rank_max"],
                   v["peak_mb_all_ranks_max"]))
        if "ccx" in cr:
            print("  %-8s %-11s wall %8.2f s  (%d threads), first 10 within %.2e" %
                  (case, "calculix", cr["ccx"]["process_wall_median"], cr["ccx"]["threads"],
                   cr["ccx"].get("first10_max_rel_diff", float("nan"))))
        for k, v in cr["ratios"].items():
            print("  %-8s %s = %.2f" % (case, k, v))
    print("wrote", os.path.relpath(path, ROOT))
    sys.exit(status)


if __name__ == "__main__":
    main()
