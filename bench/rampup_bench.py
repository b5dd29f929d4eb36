#!/usr/bin/python3
"""Benchmark of `morse rampup`: cost per step against the number of stator modes (issue 11,
Performance; seed 000 Fig. 7 observed time ~ N^2 in its multibody code).

Run with Debian's interpreter (h5py) from the repository root, after run/build:

    /usr/bin/python3 bench/rampup_bench.py                  # N = 50..2000, 5 runs each
    /usr/bin/python3 bench/rampup_bench.py --runs 3 --modes 50,200,1000

What it does:
  1. a stator superelement with 2,100 fixed-interface modes: morse reduce on the coarse stator
     (meshes/stator_coarse.msh, 13k DOFs; the mesh size does not matter for the ramp-up, only the
     number of modes) -> out/bench_rampup/se2100.h5 (made once, 2 ranks);
  2. the engine of run/engine.opts on it, with the stator's modal basis truncated between modes N
     and N + 1 (-rampup_stator_casing_cut_hz), for every N: the condensed step (morse's, cost
     linear in N: docs/rampup-theory.md §5.2) over 2,000 steps, and the dense step
     (-rampup_dense: LU of the whole effective matrix every step, what a general multibody
     solver does, O(n^3)) over fewer steps for N <= 1000;
  3. the time per step of each (the file's /rampup@seconds / steps), median/min/max of --runs runs,
     the fitted exponents of t(N) (log-log, over the largest N), and the ratio dense / condensed.

It prints a summary and writes bench/results/rampup_<UTC>.json (times, exponents, peak memory of
each run from morse's stage table, sizes, the machine load).
"""

import argparse
import datetime
import json
import os
import statistics
import subprocess
import sys

import h5py
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import benchlib  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run(cmd):
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", OMPI_ALLOW_RUN_AS_ROOT="1",
               OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OMPI_MCA_rmaps_base_oversubscribe="1")
    r = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit("rampup_bench: morse failed: %s\n%s%s" % (" ".join(cmd), r.stdout[-2000:], r.stderr[-2000:]))
    return r.stdout


def morse(n, *args):
    return run(["mpiexec", "--bind-to", "none", "-n", str(n), "build/morse"] + list(args))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--modes", default="50,100,250,500,1000,2000")
    ap.add_argument("--dense-max", type=int, default=1000, help="largest N run with the dense step")
    a = ap.parse_args()
    Ns = [int(x) for x in a.modes.split(",")]
    out = "out/bench_rampup"
    os.makedirs(os.path.join(ROOT, out), exist_ok=True)
    se = out + "/se2100.h5"
    if not os.path.exists(os.path.join(ROOT, se)):
        print("rampup_bench: superelement with 2100 fixed-interface modes (coarse stator, 2 ranks)", flush=True)
        morse(2, "reduce", "-mesh", "meshes/stator_coarse.msh", "-clamp", "mount", "-boundary", "interface",
              "-cb_num_fixed_modes", "2100", "-out", se)
    base = ["rampup", "-options_file", "run/engine.opts", "-rampup_stator_casing_file", se,
            "-rampup_write_matrices", "0", "-rampup_output_every", "100"]
    # Every stator mode of the assembly's basis (no truncation), to place the cuts.
    morse(1, *base, "-rampup_stator_casing_cut_hz", "1e9", "-rampup_t_final", "1e-3", "-out", out + "/all.h5")
    with h5py.File(os.path.join(ROOT, out, "all.h5"), "r") as f:
        freq = f["/rampup/stators/casing/frequencies_hz"][:]
    print("rampup_bench: the assembly's stator basis has %d modes (%.1f .. %.1f Hz)" % (len(freq), freq[0], freq[-1]))
    Ns = [N for N in Ns if N <= len(freq)]
    rows = []
    for N in Ns:
        cut = freq[N - 1] if N == len(freq) else 0.5 * (freq[N - 1] + freq[N])
        row = {"N": N, "cut_hz": float(cut)}
        for kind, steps in [("condensed", 2000), ("dense", 200 if N <= 250 else 20)]:
            if kind == "dense" and N > a.dense_max:
                continue
            t, peak, load = [], [], []
            for _ in range(a.runs):
                extra = ["-rampup_dense"] if kind == "dense" else []
                load.append(benchlib.cpu_busy(0.3))
                o = morse(1, *base, "-rampup_stator_casing_cut_hz", repr(float(cut)), "-rampup_t_final",
                          repr(steps * 1e-4), "-out", out + "/n.h5", *extra)
                with h5py.File(os.path.join(ROOT, out, "n.h5"), "r") as f:
                    r = f["/rampup"]
                    assert int(r.attrs["n_stator_modes"]) == N, (N, int(r.attrs["n_stator_modes"]))
                    t.append(float(r.attrs["seconds"]) / int(r.attrs["steps"]))
                    row["n_dofs"] = int(r.attrs["n_dofs"])
                peak.append(benchlib.parse_stage_table(o)[1].get("total", 0.0))
            row[kind] = {"us_per_step_median": 1e6 * statistics.median(t), "us_per_step_min": 1e6 * min(t),
                         "us_per_step_max": 1e6 * max(t), "samples_us": [1e6 * x for x in t], "steps": steps,
                         "peak_mb_max": max(peak), "machine_busy_before": load}
        rows.append(row)
        print("  N = %5d (n = %5d): condensed %9.2f us/step%s" % (
            N, row["n_dofs"], row["condensed"]["us_per_step_median"],
            "   dense %10.1f us/step (x%.0f)" % (row["dense"]["us_per_step_median"], row["dense"]["us_per_step_median"]
                                                 / row["condensed"]["us_per_step_median"]) if "dense" in row else ""),
              flush=True)

    def slope(kind, nmin):
        pts = [(r["N"], r[kind]["us_per_step_median"]) for r in rows if kind in r and r["N"] >= nmin]
        if len(pts) < 2:
            return None
        x, y = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
        return float(np.polyfit(x, y, 1)[0])

    res = {"date": datetime.datetime.utcnow().strftime("%Y-%m-%dT%H:%M:%SZ"), "runs": a.runs,
           "superelement": se, "engine": "run/engine.opts", "rows": rows,
           "exponent_condensed_N_ge_250": slope("condensed", 250),
           "exponent_dense_N_ge_250": slope("dense", 250),
           "rotor_dofs": rows[0]["n_dofs"] - rows[0]["N"] if rows else None,
           "git": benchlib.git_info(), "cpus": os.cpu_count()}
    print("rampup_bench: t(N) ~ N^%.2f condensed, N^%s dense (N >= 250)" % (
        res["exponent_condensed_N_ge_250"] or float("nan"),
        "%.2f" % res["exponent_dense_N_ge_250"] if res["exponent_dense_N_ge_250"] else "?"))
    stamp = res["date"].replace("-", "").replace(":", "")
    path = os.path.join(ROOT, "bench/results/rampup_%s.json" % stamp)
    with open(path, "w") as f:
        json.dump(res, f, indent=1)
    print("rampup_bench: wrote %s" % os.path.relpath(path, ROOT))


if __name__ == "__main__":
    main()
