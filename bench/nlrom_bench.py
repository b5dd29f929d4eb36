#!/usr/bin/python3
"""Benchmark of the nonlinear reduced models (`morse nlrom`, `morse simulate`) on the 60k-DOF blade.

    /usr/bin/python3 bench/nlrom_bench.py               # meshes/blade.msh, r = 20 (3 + 4 + 13 MD), 3 runs
    /usr/bin/python3 bench/nlrom_bench.py --runs 1 --derivatives 13
    /usr/bin/python3 bench/nlrom_bench.py --r79         # r = 20, then r = 79 (24 + 15 + 40 MD, exact tensors)
    /usr/bin/python3 bench/nlrom_bench.py --r79 --skip-r20 --runs 1   # the r = 79 part alone

Seed 003's case (§4): clamped root, boundary LE (3 DOFs), CB + modal derivatives selected with the
training load 300 N at LE in e_y at 2000 rad/s over 10 periods. For STEP and for the exact tensors
on 1 and 2 ranks it reads morse's offline times (t1 basis, t2 forces, t3 projection) and the
parallel efficiency of t2 from 1 to 2 ranks (the issue's targets: STEP r = 20 under 20 s on 2
cores at >= 90 % efficiency). Then `morse simulate` (rank 0) integrates the STEP model for 0.0314 s
at the largest stable step below h = 1e-7 s and reports steps/s (target 2e5 at r = 20), and the
agreement of the STEP and exact tensors. Writes bench/results/nlrom_<UTC>_<mesh>_r<r>.json with medians.

--r79 adds the contact basis of seed 003 (boundary `tip`: 8 nodes x 3 = 24 DOFs, 15 fixed-interface
modes, 40 modal derivatives: r = 79) with exact tensors, the same training load:
  - `morse nlrom` on 2 ranks, --runs times: t1/t2/t3 and morse's line "exact tensors: r = 79, 3160
    pairs, N quadrature points, X GFLOP in BLAS-3 (Y GFLOP/s)"; target t2 < 120 s (median);
  - `morse simulate` on one core, --runs times, 2e-4 s at dt = 1e-8 s (the critical step of this
    model is about 6.8e-8 s): median steps/s; per step 2 (n2 + n3) r + 4 r^2 flops and 8 (n2 + n3) r
    bytes (the folded cubic tensor, streamed once per step; n2 = r(r+1)/2, n3 = r(r+1)(r+2)/6), hence
    the achieved GFLOP/s and GB/s against this machine's one-core limits: bench/machine_limits.cpp
    (STREAM copy/scale/add/triad, read-only sum, AVX2 FMA peak), compiled with g++ into a temporary
    directory and run once at the start of the part (null in the JSON, with the reason, without g++);
  - the speed-up against the full model for 0.0314 s of simulated time: seconds per step of the
    newest bench/results/fom_<UTC>_<mesh>_<N>steps.json (h = 1e-4 s) against the ROM at dt 1e-8 s, at
    the r = 20 part's 1e-7 s (above this model's critical step: hypothetical) and at the critical step.
  Writes bench/results/nlrom_<UTC>_<mesh>_r79.json (summary, runs, git, blas).
Exit status 0 on success, 2 if morse failed.
"""

import argparse
import datetime
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile

from benchlib import HERE, RESULTS, ROOT, blas_info, cpu_busy, git_info, med, run_mpi


def r20_part(args, morse, work, load):
    """The r = 20 part (seed 003's STEP model): offline on 1 and 2 ranks, online, JSON."""
    base = ["-mesh", args.mesh, "-clamp", "root", "-boundary", "LE", "-nlrom_basis", "cbmd",
            "-nlrom_num_fixed_modes", str(args.fixed), "-nlrom_num_derivatives", str(args.derivatives),
            "-nlrom_training_tfinal", "0.0314", "-nlrom_damping_modal", "5e-4", "-nlrom_damping_modes", "10"] + load
    offline = {}
    for forces in ["step", "exact"]:
        for ranks in [1, 2]:
            rows = []
            for k in range(args.runs):
                out = os.path.join(work, "%s_%d.h5" % (forces, ranks))
                r, _ = run_mpi("nlrom %s np%d run %d" % (forces, ranks, k + 1),
                               [morse, "nlrom"] + base + ["-nlrom_forces", forces, "-out", out], ranks, work, 1)
                if r is None:
                    return 2
                m = re.search(r"t1 \(basis\) ([0-9.]+) s, t2 \(forces\) ([0-9.]+) s, t3 \(projection\) ([0-9.]+) s",
                              r["stdout"])
                rows.append({"t1": float(m.group(1)), "t2": float(m.group(2)), "t3": float(m.group(3)),
                             "process_wall": r["process_wall"],
                             "rank_max_rss_mb": r["rank_max_rss_mb"], "contention": r["contention"]})
            offline["%s_np%d" % (forces, ranks)] = {
                "t1_seconds": med([x["t1"] for x in rows]), "t2_seconds": med([x["t2"] for x in rows]),
                "t3_seconds": med([x["t3"] for x in rows]),
                "process_wall_seconds": med([x["process_wall"] for x in rows]), "runs": rows}
            print("%-5s %d rank(s): t1 %.2f s, t2 %.2f s, t3 %.2f s" % (
                forces, ranks, offline["%s_np%d" % (forces, ranks)]["t1_seconds"],
                offline["%s_np%d" % (forces, ranks)]["t2_seconds"], offline["%s_np%d" % (forces, ranks)]["t3_seconds"]))
    eff = {f: offline[f + "_np1"]["t2_seconds"] / (2 * offline[f + "_np2"]["t2_seconds"]) for f in ["step", "exact"]}
    # Agreement of STEP and exact tensors.
    agree = None
    try:
        import h5py
        a = h5py.File(os.path.join(work, "step_2.h5"), "r")
        b = h5py.File(os.path.join(work, "exact_2.h5"), "r")
        agree = max(float(abs(a["/nlrom/" + k][:] - b["/nlrom/" + k][:]).max() / abs(b["/nlrom/" + k][:]).max())
                    for k in ["A", "B"])
        r_size = int(a["/nlrom"].attrs["r"])
    except Exception as e:  # h5py missing: report without it
        sys.stderr.write("tensor comparison skipped: %s\n" % e)
        r_size = 3 + args.fixed + args.derivatives
    # Online: rank 0, STEP model, largest stable step <= 1e-7 s.
    rom = os.path.join(work, "step_2.h5")
    sims = []
    for k in range(args.runs):
        r, _ = run_mpi("simulate run %d" % (k + 1), [morse, "simulate", "-rom", rom] + load +
                       ["-sim_dt", "1e-7", "-sim_tfinal", "0.0314", "-sim_output_every", "1000000",
                        "-out", os.path.join(work, "sim.h5")], 1, work, 1)
        if r is None:
            return 2
        m = re.search(r"(\d+) steps in ([0-9.]+) s", r["stdout"])
        sims.append({"steps": int(m.group(1)), "seconds": float(m.group(2))})
    sps = med([s["steps"] / s["seconds"] for s in sims])
    # The implicit reduced scheme (-sim_scheme trapezoidal) at the full model's step, 1e-4 s.
    implicit = []
    for k in range(args.runs):
        r, _ = run_mpi("simulate trapezoidal run %d" % (k + 1), [morse, "simulate", "-rom", rom] + load +
                       ["-sim_scheme", "trapezoidal", "-sim_dt", "1e-4", "-sim_tfinal", "0.0314",
                        "-out", os.path.join(work, "sim_implicit.h5")], 1, work, 1)
        if r is None:
            return 2
        m = re.search(r"(\d+) steps in ([0-9.]+) s", r["stdout"])
        it = re.search(r"Newton: (\d+) iterations", r["stdout"])
        implicit.append({"steps": int(m.group(1)), "seconds": float(m.group(2)),
                         "newton_iterations": int(it.group(1)) if it else None})
    implicit_seconds = med([x["seconds"] for x in implicit])
    name = os.path.splitext(os.path.basename(args.mesh))[0]
    fom = newest_fom(name)
    fom_seconds = fom["seconds_per_step"] * 0.0314 / fom["dt"] if fom else None
    explicit_seconds = med([s["seconds"] for s in sims])
    summary = {
        "online_implicit_seconds_dt_1e-4": implicit_seconds,
        "online_explicit_seconds_dt_1e-7": explicit_seconds,
        "fom_seconds_same_problem": fom_seconds, "fom_results_file": fom["file"] if fom else None,
        "speedup_fom_over_rom_explicit": ratio(fom_seconds, explicit_seconds),
        "speedup_fom_over_rom_implicit": ratio(fom_seconds, implicit_seconds),
        "speedup_target": 1e5,
        "r": r_size, "step_evaluations": r_size ** 3 // 6 + r_size ** 2 + (5 * r_size) // 6,
        "step_t2_seconds_2_ranks": offline["step_np2"]["t2_seconds"], "step_t2_target_seconds": 20.0,
        # the whole `morse nlrom` command (mesh, basis, STEP, projection, file), process wall
        "step_command_wall_seconds_2_ranks": offline["step_np2"]["process_wall_seconds"],
        "step_command_wall_target_seconds": 20.0,
        "step_parallel_efficiency_1_to_2": eff["step"], "step_efficiency_target": 0.9,
        "exact_t2_seconds_2_ranks": offline["exact_np2"]["t2_seconds"],
        "exact_parallel_efficiency_1_to_2": eff["exact"],
        "step_vs_exact_max_relative_difference": agree,
        "online_steps_per_second": sps, "online_target_steps_per_second": 2e5,
        "seed_offline_minutes_r20": [1320, 1360], "seed_online_seconds": 5.0,
    }
    print("\nnlrom benchmark (%s, r = %d)" % (os.path.basename(args.mesh), r_size))
    print("  STEP t2 on 2 ranks %.2f s (target 20 s), efficiency 1->2 ranks %.1f %% (target 90 %%)" %
          (summary["step_t2_seconds_2_ranks"], 100 * eff["step"]))
    print("  the whole morse nlrom command (STEP, 2 ranks, process wall): %.2f s (target 20 s)" %
          summary["step_command_wall_seconds_2_ranks"])
    print("  exact t2 on 2 ranks %.2f s, efficiency %.1f %%; STEP vs exact %s" %
          (summary["exact_t2_seconds_2_ranks"], 100 * eff["exact"], agree))
    print("  online: %.3g steps/s on one core (target 2e5)" % sps)
    print("  vs morse fom (%s s for 0.0314 s): explicit ROM %.3g s (speed-up %s), implicit ROM at 1e-4 s %.3g s "
          "(speed-up %s; target 1e5)" % (fom_seconds, explicit_seconds, summary["speedup_fom_over_rom_explicit"],
                                          implicit_seconds, summary["speedup_fom_over_rom_implicit"]))
    os.makedirs(RESULTS, exist_ok=True)
    stamp = datetime.datetime.utcnow().strftime("%Y-%m-%dT%H%M%SZ")
    path = os.path.join(RESULTS, "nlrom_%s_%s_r%d.json" % (stamp, name, r_size))
    with open(path, "w") as fh:
        json.dump({"benchmark": "nlrom", "mesh": args.mesh, "summary": summary, "offline": offline,
                   "online_runs": sims, "online_implicit_runs": implicit, "git": git_info(),
                   "blas": blas_info(morse)}, fh, indent=1)
    print("wrote", path)
    return 0


# ---- r = 79: seed 003's contact basis (boundary `tip`: 8 nodes x 3 = 24 DOFs, 15 fixed-interface
# modes, 40 modal derivatives), exact tensors ----

R79_BOUNDARY, R79_FIXED, R79_DERIVATIVES = "tip", 15, 40
R79_T2_TARGET = 120.0     # s, exact tensors (t2) on 2 ranks
R79_DT = 1e-8             # s, below the critical step of this model (~6.8e-8 s)
R79_SIM_TFINAL = 2e-4     # s of simulated time per online run (20,000 steps at 1e-8 s)
R20_DT = 1e-7             # s, the r = 20 part's online step
T_SPEEDUP = 0.0314        # s, simulated time of the speed-up comparison (10 periods at 2000 rad/s)
FOM_DT = 1e-4             # s, the step of `morse fom` (bench/fom_bench.py) if its JSON does not say


def machine_limits(n):
    """Compiles bench/machine_limits.cpp into a temporary directory and runs it once (one core).
    Returns (dict or None, reason or None)."""
    src = os.path.join(HERE, "machine_limits.cpp")
    gxx = shutil.which("g++")
    if gxx is None:
        return None, "g++ not found on PATH"
    if not os.path.exists(src):
        return None, "%s missing" % src
    tmp = tempfile.mkdtemp(prefix="machine_limits_")
    exe = os.path.join(tmp, "machine_limits")
    # Baseline x86-64 build; the FMA and read kernels carry their own target("avx2,fma").
    cmd = [gxx, "-O3", "-march=x86-64", "-std=c++17", src, "-o", exe]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        return None, "compilation failed (%s): %s" % (" ".join(cmd), p.stderr[-2000:])
    busy = cpu_busy(1.0)
    try:
        p = subprocess.run([exe, "--n", str(n)], capture_output=True, text=True, timeout=900)
    except subprocess.TimeoutExpired:
        return None, "machine_limits timed out (900 s)"
    if p.returncode != 0:
        return None, "machine_limits failed (exit %d): %s" % (p.returncode, p.stderr[-2000:])
    try:
        lim = json.loads(p.stdout)
    except ValueError as e:
        return None, "machine_limits printed no JSON (%s): %s" % (e, p.stdout[-2000:])
    lim["compile_command"] = " ".join(cmd)
    lim["cpu_busy_fraction_before"] = busy  # all CPUs, over 1 s just before the run
    return lim, None


def newest_fom(mesh_name):
    """The newest bench/results/fom_<UTC>_<mesh>_<N>steps.json of this mesh (by the UTC stamp in the
    name): a dict (file, seconds_per_step, dt, ranks, steps, newton, git_commit), or None. Seconds per
    step: the summary's median `seconds_per_step`, else `seconds_integration` / `steps`."""
    pat = re.compile(r"^fom_(\d{4}-\d\d-\d\dT\d{6}Z)_%s_(\d+)steps\.json$" % re.escape(mesh_name))
    try:
        found = sorted((m.group(1), f) for f in os.listdir(RESULTS) for m in [pat.match(f)] if m)
    except OSError:
        return None
    if not found:
        return None
    path = os.path.join(RESULTS, found[-1][1])
    try:
        with open(path) as fh:
            d = json.load(fh)
    except (OSError, ValueError) as e:
        sys.stderr.write("%s unreadable: %s\n" % (path, e))
        return None
    s = d.get("summary", {})
    sps = s.get("seconds_per_step")  # median over the runs
    if sps is None and s.get("seconds_integration") is not None and d.get("steps"):
        sps = s["seconds_integration"] / d["steps"]
    if sps is None:
        return None
    return {"file": os.path.relpath(path, ROOT), "seconds_per_step": sps, "dt": d.get("dt") or FOM_DT,
            "ranks": d.get("ranks"), "steps": d.get("steps"), "newton": d.get("newton"),
            "git_commit": d.get("git", {}).get("commit")}


def ratio(a, b):
    return a / b if a is not None and b else None


def r79_part(args, morse, work, load):
    """The r = 79 part: exact tensors of the contact basis on 2 ranks (target t2 < 120 s), online
    steps/s against the machine's limits, and the speed-up against `morse fom`. Writes
    bench/results/nlrom_<UTC>_<mesh>_r79.json. Returns 0, or 2 if morse failed."""
    print("\nr = 79 part: machine limits (one core, g++ -O3 -march=x86-64, N = %d doubles)..." % args.limits_n,
          flush=True)
    limits, why = machine_limits(args.limits_n)
    if limits is None:
        sys.stderr.write("machine limits: %s\n" % why)
    else:
        print("  read %.1f GB/s, triad %.1f GB/s, FMA peak %.1f GFLOP/s (%s)" % (
            limits["read_gbs"], limits["stream_triad_gbs"], limits["fma_peak_gflops"], limits["isa"]))
    base = ["-mesh", args.mesh, "-clamp", "root", "-boundary", R79_BOUNDARY, "-nlrom_basis", "cbmd",
            "-nlrom_num_fixed_modes", str(R79_FIXED), "-nlrom_num_derivatives", str(R79_DERIVATIVES),
            "-nlrom_training_tfinal", "0.0314", "-nlrom_damping_modal", "5e-4", "-nlrom_damping_modes", "10",
            "-nlrom_forces", "exact"] + load
    rom = os.path.join(work, "r79_exact_2.h5")
    tre = re.compile(r"t1 \(basis\) ([0-9.]+) s, t2 \(forces\) ([0-9.]+) s, t3 \(projection\) ([0-9.]+) s")
    xre = re.compile(r"exact tensors: r = (\d+), (\d+) pairs, ([0-9.]+) quadrature points, ([0-9.eE+-]+) GFLOP in "
                     r"BLAS-3 \(([0-9.eE+-]+) GFLOP/s\)")
    offline = []
    for k in range(args.runs):
        r, _ = run_mpi("nlrom r79 exact np2 run %d" % (k + 1), [morse, "nlrom"] + base + ["-out", rom], 2, work, 1)
        if r is None:
            return 2
        m, x = tre.search(r["stdout"]), xre.search(r["stdout"])
        if m is None or x is None:
            sys.stderr.write("nlrom r79 run %d: times or exact-tensor line not found in morse's output:\n%s\n"
                             % (k + 1, r["stdout"][-4000:]))
            return 2
        row = {"t1": float(m.group(1)), "t2": float(m.group(2)), "t3": float(m.group(3)),
               "r": int(x.group(1)), "pairs": int(x.group(2)), "quadrature_points": float(x.group(3)),
               "tensor_gflop": float(x.group(4)), "tensor_gflops_per_second": float(x.group(5)),
               "process_wall": r["process_wall"], "rank_max_rss_mb": r["rank_max_rss_mb"],
               "contention": r["contention"]}
        offline.append(row)
        print("  nlrom run %d: r = %d, t1 %.2f s, t2 %.2f s, t3 %.2f s; tensors %.4g GFLOP at %.1f GFLOP/s"
              % (k + 1, row["r"], row["t1"], row["t2"], row["t3"], row["tensor_gflop"],
                 row["tensor_gflops_per_second"]), flush=True)
    r_size = offline[0]["r"]
    if r_size != 3 * 8 + R79_FIXED + R79_DERIVATIVES:
        sys.stderr.write("warning: r = %d, not 79 (24 boundary DOFs + 15 + 40 expected)\n" % r_size)
    t2 = med([x["t2"] for x in offline])
    # Online: rank 0, exact-tensor model, dt = 1e-8 s (below the critical step), with the kernel that
    # `-sim_kernel auto` picks (potential form at r = 79) --runs times, then once with the folded
    # kernel for the record of the gain.
    kre = re.compile(r"nonlinear force kernel: (\w+), ([0-9.eE+-]+) flop and ([0-9.eE+-]+) MB per step")
    online, folded = [], None
    for k in range(args.runs + 1):
        kernel = "auto" if k < args.runs else "folded"
        r, _ = run_mpi("simulate r79 run %d (%s kernel)" % (k + 1, kernel), [morse, "simulate", "-rom", rom] + load +
                       ["-sim_dt", repr(R79_DT), "-sim_tfinal", repr(R79_SIM_TFINAL), "-sim_output_every", "1000000",
                        "-sim_kernel", kernel, "-out", os.path.join(work, "sim_r79.h5")], 1, work, 1)
        if r is None:
            return 2
        m = re.search(r"(\d+) steps in ([0-9.]+) s", r["stdout"])
        c = re.search(r"critical step ([0-9.eE+-]+) s", r["stdout"])
        kl = kre.search(r["stdout"])
        if m is None or kl is None:
            sys.stderr.write("simulate r79 run %d: no step count or kernel line in morse's output:\n%s\n" %
                             (k + 1, r["stdout"][-4000:]))
            return 2
        row = {"kernel": kl.group(1), "kernel_flops_per_step": float(kl.group(2)),
               "kernel_bytes_per_step": float(kl.group(3)) * 1e6, "steps": int(m.group(1)),
               "seconds": float(m.group(2)), "critical_dt": float(c.group(1)) if c else None,
               "contention": r["contention"]}
        print("  simulate run %d (%s kernel): %d steps in %.3f s (%.4g steps/s)" % (
            k + 1, row["kernel"], row["steps"], row["seconds"], row["steps"] / row["seconds"]), flush=True)
        if k < args.runs:
            online.append(row)
        else:
            folded = row
    sps = med([x["steps"] / x["seconds"] for x in online])
    critical = med([x["critical_dt"] for x in online])
    # Per step (sim/central.cpp): the nonlinear force kernel's flops and coefficient bytes as morse
    # reports them, plus 4 r^2 flops of the linear part (P1 q + P2 q_prev); vectors and the r x r
    # matrices are cache-resident and not counted.
    n2 = r_size * (r_size + 1) // 2
    n3 = r_size * (r_size + 1) * (r_size + 2) // 6
    flops_step = online[0]["kernel_flops_per_step"] + 4.0 * r_size * r_size
    bytes_step = online[0]["kernel_bytes_per_step"]
    gflops = sps * flops_step * 1e-9
    gbs = sps * bytes_step * 1e-9
    lim = limits or {}
    roof = None
    if limits:
        roof = min(limits["fma_peak_gflops"] * 1e9 / flops_step, limits["read_gbs"] * 1e9 / bytes_step)
    # Speed-up against the full model for the same simulated time (T_SPEEDUP).
    name = os.path.splitext(os.path.basename(args.mesh))[0]
    fom = newest_fom(name)
    speedup = {"simulated_seconds": T_SPEEDUP, "fom": fom}
    fom_seconds = fom["seconds_per_step"] * T_SPEEDUP / fom["dt"] if fom else None
    speedup["fom_seconds"] = fom_seconds
    for label, dt, note in [
            ("rom_dt_1e-8", R79_DT, "the step of this benchmark's online runs (below the critical step)"),
            ("rom_dt_1e-7", R20_DT, "the r = 20 part's step; ABOVE this model's critical step, so morse "
                                    "simulate refuses it: hypothetical, as if steps cost the same"),
            ("rom_dt_critical", critical, "the largest stable step of this model (2 / omega_max), as if run at it")]:
        if dt is None:
            speedup[label] = None
            continue
        steps = math.ceil(T_SPEEDUP / dt - 1e-9)  # as sim::integrate counts them
        rom_seconds = steps / sps if sps else None
        speedup[label] = {"dt": dt, "steps": steps, "rom_seconds": rom_seconds,
                          "speedup_fom_over_rom": ratio(fom_seconds, rom_seconds), "note": note}
    speedup["note"] = ("speed-up = fom seconds for %.4g s of simulated time (fom seconds per step at its dt, from the "
                       "newest fom results file; %s ranks) / rom seconds for the same time (steps / median "
                       "steps/s of `morse simulate` on one core at dt 1e-8); ROM offline cost not included"
                       % (T_SPEEDUP, fom.get("ranks") if fom else "?"))
    if fom is None:
        speedup["note"] += "; no bench/results/fom_<UTC>_%s_<N>steps.json found" % name
    summary = {
        "r": r_size, "boundary": R79_BOUNDARY, "boundary_dofs": 24, "fixed_modes": R79_FIXED,
        "derivatives": R79_DERIVATIVES, "n2": n2, "n3": n3,
        "exact_t1_seconds_2_ranks": med([x["t1"] for x in offline]),
        "exact_t2_seconds_2_ranks": t2, "exact_t2_target_seconds": R79_T2_TARGET,
        "exact_t2_target_met": t2 < R79_T2_TARGET,
        "exact_t3_seconds_2_ranks": med([x["t3"] for x in offline]),
        "tensor_projection_gflop": med([x["tensor_gflop"] for x in offline]),
        "tensor_projection_gflops_per_second": med([x["tensor_gflops_per_second"] for x in offline]),
        "quadrature_points": offline[0]["quadrature_points"],
        "online_dt": R79_DT, "online_critical_dt": critical, "online_steps_per_run": online[0]["steps"],
        "online_steps_per_second": sps,
        "online_flops_per_step": flops_step, "online_bytes_per_step": bytes_step,
        "online_arithmetic_intensity_flops_per_byte": flops_step / bytes_step,
        "online_achieved_gflops": gflops, "online_achieved_gbs": gbs,
        "online_kernel": online[0]["kernel"],
        "online_model": "flops = the kernel's (morse's 'nonlinear force kernel' line) + 4 r^2, bytes = the kernel's "
                        "coefficients streamed once per step (potential: r(r+1)(r+2)/6 + r(r+1)(r+2)(r+3)/24 "
                        "doubles + P3; folded: (n2 + n3) r doubles)",
        "folded_kernel_run": folded,
        "folded_kernel_steps_per_second": folded["steps"] / folded["seconds"] if folded else None,
        "kernel_speedup_over_folded": ratio(sps, folded["steps"] / folded["seconds"]) if folded else None,
        "machine_limits": limits, "machine_limits_missing_reason": why,
        "ratio_achieved_over_fma_peak": ratio(gflops, lim.get("fma_peak_gflops")),
        "ratio_achieved_over_read_bandwidth": ratio(gbs, lim.get("read_gbs")),
        "ratio_achieved_over_triad_bandwidth": ratio(gbs, lim.get("stream_triad_gbs")),
        "roofline_steps_per_second": roof,
        "ratio_steps_per_second_over_roofline": ratio(sps, roof),
        "speedup_vs_fom": speedup,
    }
    print("\nnlrom benchmark r = %d (%s, boundary %s, %d + %d + %d, exact tensors), median of %d runs" % (
        r_size, os.path.basename(args.mesh), R79_BOUNDARY, 24, R79_FIXED, R79_DERIVATIVES, args.runs))
    print("  exact tensors t2 on 2 ranks %.2f s (target %.0f s: %s); projection %.4g GFLOP at %.1f GFLOP/s" % (
        t2, R79_T2_TARGET, "met" if summary["exact_t2_target_met"] else "MISSED", summary["tensor_projection_gflop"],
        summary["tensor_projection_gflops_per_second"]))
    print("  online: %.4g steps/s at dt %g s (critical %s s): %.2f GFLOP/s, %.2f GB/s (%.3g flop/byte)" % (
        sps, R79_DT, "%.3g" % critical if critical else "?", gflops, gbs, flops_step / bytes_step))
    if limits:
        print("  of the one-core limits: %.1f %% of FMA peak %.1f GFLOP/s, %.1f %% of read %.1f GB/s, %.1f %% of "
              "triad %.1f GB/s; roofline %.4g steps/s" % (
                  100 * summary["ratio_achieved_over_fma_peak"], limits["fma_peak_gflops"],
                  100 * summary["ratio_achieved_over_read_bandwidth"], limits["read_gbs"],
                  100 * summary["ratio_achieved_over_triad_bandwidth"], limits["stream_triad_gbs"], roof))
    else:
        print("  machine limits not measured: %s" % why)
    if fom:
        print("  vs morse fom (%s, %.3f s/step at %g s, %s ranks): %.4g s for %.4g s simulated" % (
            fom["file"], fom["seconds_per_step"], fom["dt"], fom["ranks"], fom_seconds, T_SPEEDUP))
        for label in ["rom_dt_1e-8", "rom_dt_1e-7", "rom_dt_critical"]:
            v = speedup[label]
            if v and v["rom_seconds"]:
                print("    ROM at dt %.3g s: %.4g s, speed-up %.3g" % (v["dt"], v["rom_seconds"],
                                                                      v["speedup_fom_over_rom"]))
    else:
        print("  no fom results file for %s: speed-up not computed" % name)
    os.makedirs(RESULTS, exist_ok=True)
    stamp = datetime.datetime.utcnow().strftime("%Y-%m-%dT%H%M%SZ")
    path = os.path.join(RESULTS, "nlrom_%s_%s_r%d.json" % (stamp, name, r_size))
    with open(path, "w") as fh:
        json.dump({"benchmark": "nlrom", "part": "r79", "mesh": args.mesh, "ranks_offline": 2, "ranks_online": 1,
                   "summary": summary, "runs": {"nlrom": offline, "simulate": online},
                   "git": git_info(), "blas": blas_info(morse)}, fh, indent=1)
    print("wrote", path)
    return 0


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mesh", default=os.path.join(ROOT, "meshes", "blade.msh"))
    ap.add_argument("--fixed", type=int, default=4, help="r = 20 part: fixed-interface modes (default 4)")
    ap.add_argument("--derivatives", type=int, default=13, help="r = 20 part: modal derivatives (default 13)")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--r79", action="store_true",
                    help="also run the r = 79 part (boundary tip, 15 modes, 40 derivatives, exact tensors)")
    ap.add_argument("--skip-r20", action="store_true", help="skip the r = 20 part (with --r79: the r = 79 part alone)")
    ap.add_argument("--limits-n", type=int, default=40000000,
                    help="r = 79 part: doubles per array of machine_limits (default 40,000,000: 960 MB)")
    args = ap.parse_args()
    if args.skip_r20 and not args.r79:
        ap.error("--skip-r20 leaves nothing to run without --r79")
    morse = os.path.join(ROOT, "build", "morse")
    work = tempfile.mkdtemp(prefix="nlrom_bench_")
    load = ["-load_sets", "LE", "-load_LE_dir", "y", "-load_LE_amplitude", "300", "-load_LE_omega", "2000"]
    if not args.skip_r20:
        status = r20_part(args, morse, work, load)
        if status != 0:
            return status
    if args.r79:
        return r79_part(args, morse, work, load)
    return 0


if __name__ == "__main__":
    sys.exit(main())
