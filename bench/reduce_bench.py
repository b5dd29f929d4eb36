#!/usr/bin/python3
"""Benchmark of `morse reduce` (Craig-Bampton) on a ~60k-DOF quadratic box mesh.

Run with Debian's interpreter (standard library only):

    /usr/bin/python3 bench/reduce_bench.py                 # hex20, 1 and 2 ranks, 3 runs each
    /usr/bin/python3 bench/reduce_bench.py --type wedge15  # the blade's element type
    /usr/bin/python3 bench/reduce_bench.py --runs 5 --ranks 1,2 --target-dofs 60000
    /usr/bin/python3 bench/reduce_bench.py --table bench/results/reduce_*.json   # Markdown table

The model: a steel bar, 10 mm cubic cells, ny x nz = 12 x 8 cells in the cross-section, nx
chosen so that the mesh has about --target-dofs DOFs (3 x nodes). The face x0 is clamped. The
interface ("iface", added by this script) is 8 nodes of the x1 face: its 4 corners and the
midpoints of its 4 edges, i.e. 24 boundary DOFs. 100 fixed-interface modes.

`morse mesh box` writes only face sets, so the script appends a dimension-0 physical group
"iface" (8 point elements, Gmsh type 15, on a new point entity) to the generated Gmsh 4.1 file.

Each run is `mpirun -n R /usr/bin/time -f ... morse reduce ... -log_view`; the script parses the
morse stage table ("stage / time [s] / peak [MB]"), the "K_ii factored once ... (X s)" line, the
sizes printed by morse, the MUMPS events of -log_view (symbolic / numeric Cholesky) and the
per-rank max RSS reported by /usr/bin/time. It prints a summary and writes
bench/results/reduce_<UTC date-time>_<type>.json (see bench/README.md for the fields).
Exit status: 0 if every run succeeded and the targets are met, 1 if a target is missed, 2 if
morse failed.
"""

import argparse
import datetime
import glob
import json
import os
import platform
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time

from benchlib import (EXTRA_ENV, RESULTS, ROOT, blas_info, cpu_busy, fmt, git_info, med, mpi_env,
                      parse_log_view,
                      parse_stage_table, run_mpi, wait_idle)


STAGES = ["ReadDistribute", "NumberDofs", "Preallocate", "Assemble", "Factor", "EigenSolve",
          "ConstraintModes", "Project", "ReducedEigen", "Write"]
TARGET_SECONDS_2RANKS = 30.0
TARGET_MEMORY_MB = 4096.0
STEEL = {"E": 210e9, "nu": 0.3, "rho": 7850.0}
CELL = 0.01  # m
NY, NZ = 12, 8
# PETSc -log_view events worth keeping (MUMPS analysis/factorization, solves, SLEPc).
LOG_EVENTS = ["MatCholFctrSym", "MatCholFctrNum", "MatLUFactorSym", "MatLUFactorNum", "MatSolve",
              "MatMatSolve", "MatMult", "MatMatMult", "EPSSetUp", "EPSSolve", "STSetUp", "STApply",
              "MatAssemblyBegin", "MatAssemblyEnd", "MatSetValues", "MatCreateSubMat", "BVOrthogonalize"]


# ------------------------------------------------------------------------------------- mesh
def box_nodes(kind, nx, ny, nz):
    """Node count of `morse mesh box` (grid vertices + one node per mesh edge)."""
    v = (nx + 1) * (ny + 1) * (nz + 1)
    e = nx * (ny + 1) * (nz + 1) + (nx + 1) * ny * (nz + 1) + (nx + 1) * (ny + 1) * nz
    if kind == "wedge15":
        e += nx * ny * (nz + 1)  # the diagonal of every x-y cell face (cells are cut into 2 wedges)
    return v + e


def choose_nx(kind, target_dofs):
    return min(range(1, 2000), key=lambda nx: abs(3 * box_nodes(kind, nx, NY, NZ) - target_dofs))


def read_msh_nodes(path):
    """Node tag -> (x, y, z) of a Gmsh 4.1 ASCII file."""
    with open(path) as f:
        lines = f.read().split("\n")
    i = lines.index("$Nodes")
    n_blocks, _, _, _ = map(int, lines[i + 1].split())
    i += 2
    coords = {}
    for _ in range(n_blocks):
        _, _, parametric, n = map(int, lines[i].split())
        assert parametric == 0
        tags = [int(t) for t in lines[i + 1:i + 1 + n]]
        for k, t in enumerate(tags):
            coords[t] = tuple(float(c) for c in lines[i + 1 + n + k].split()[:3])
        i += 1 + 2 * n
    return coords, lines


def add_node_group(path, name, node_tags):
    """Appends a dimension-0 physical group `name` holding node_tags to a Gmsh 4.1 file written
    by `morse mesh box` (in place): a $PhysicalNames entry, a point entity carrying the group and
    one point element (type 15) per node."""
    coords, lines = read_msh_nodes(path)
    # $PhysicalNames: new dimension-0 tag.
    i = lines.index("$PhysicalNames")
    n = int(lines[i + 1])
    groups = [lines[i + 2 + k].split() for k in range(n)]
    phys = 1 + max([int(g[1]) for g in groups if g[0] == "0"] + [0])
    lines[i + 1] = str(n + 1)
    lines.insert(i + 2 + n, '0 %d "%s"' % (phys, name))
    # $Entities: new point entity.
    i = lines.index("$Entities")
    counts = list(map(int, lines[i + 1].split()))
    points = [lines[i + 2 + k].split() for k in range(counts[0])]
    ptag = 1 + max([int(p[0]) for p in points] + [0])
    x, y, z = coords[node_tags[0]]
    lines.insert(i + 2 + counts[0], "%d %r %r %r 1 %d" % (ptag, x, y, z, phys))
    counts[0] += 1
    lines[i + 1] = " ".join(map(str, counts))
    # $Elements: a block of point elements on the new entity.
    i = lines.index("$Elements")
    nb, ne, emin, emax = map(int, lines[i + 1].split())
    lines[i + 1] = "%d %d %d %d" % (nb + 1, ne + len(node_tags), emin, emax + len(node_tags))
    j = lines.index("$EndElements")
    block = ["0 %d 15 %d" % (ptag, len(node_tags))]
    block += ["%d %d" % (emax + 1 + k, t) for k, t in enumerate(node_tags)]
    lines[j:j] = block
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        f.write("\n".join(lines))
    os.replace(tmp, path)


def interface_nodes(coords, lx, ly, lz):
    """The 4 corners and the 4 edge midpoints of the face x = lx."""
    want = [(lx, y, z) for y, z in [(0, 0), (ly, 0), (0, lz), (ly, lz),
                                    (ly / 2, 0), (ly / 2, lz), (0, lz / 2), (ly, lz / 2)]]
    tol = 1e-9 * max(lx, ly, lz)
    out = []
    for w in want:
        hit = [t for t, c in coords.items() if all(abs(c[d] - w[d]) < tol for d in range(3))]
        if len(hit) != 1:
            raise SystemExit("reduce_bench: no unique node at %s (found %s)" % (w, hit))
        out.append(hit[0])
    return out


def make_mesh(morse, kind, nx, path):
    lx, ly, lz = nx * CELL, NY * CELL, NZ * CELL
    cmd = [morse, "mesh", "box", "-box_type", kind, "-box_lx", repr(lx), "-box_ly", repr(ly),
           "-box_lz", repr(lz), "-box_nx", str(nx), "-box_ny", str(NY), "-box_nz", str(NZ),
           "-out", path]
    p = subprocess.run(cmd, capture_output=True, text=True, env=mpi_env(1))
    if p.returncode != 0:
        raise SystemExit("reduce_bench: %s failed:\n%s%s" % (" ".join(cmd), p.stdout, p.stderr))
    m = re.search(r"(\d+) nodes, (\d+) (?:\w+ )?elements", p.stdout)
    if not m:
        raise SystemExit("reduce_bench: cannot parse the output of %s:\n%s" % (" ".join(cmd), p.stdout))
    coords, _ = read_msh_nodes(path)
    iface = interface_nodes(coords, lx, ly, lz)
    add_node_group(path, "iface", iface)
    return {"type": kind, "cells": [nx, NY, NZ], "size_m": [lx, ly, lz], "cell_m": CELL,
            "nodes": int(m.group(1)), "elements": int(m.group(2)), "total_dofs": 3 * int(m.group(1)),
            "interface_node_ids": iface}


# ------------------------------------------------------------------------------------- runs
def parse_run(stdout):
    sec, peak = parse_stage_table(stdout)
    keep = STAGES + ["total"]
    r = {"stages": {k: v for k, v in sec.items() if k in keep},
         "stage_peak_mb": {k: v for k, v in peak.items() if k in keep}}
    m = re.search(r"K_ii factored once.*\(([0-9.]+) s\)", stdout)
    r["factor_seconds"] = float(m.group(1)) if m else None
    r["factor_shared"] = bool(m and "shared" in m.group(0))
    m = re.search(r"mesh .*: (\d+) nodes, (\d+) elements on (\d+) rank", stdout)
    if m:
        r["nodes"], r["elements"], r["ranks"] = map(int, m.groups())
    m = re.search(r"(\d+) free DOFs, (\d+) clamped", stdout)
    if m:
        r["free_dofs"], r["clamped_dofs"] = map(int, m.groups())
    m = re.search(r"superelement: (\d+) boundary DOFs \((\d+) nodes\) \+ (\d+) fixed-interface modes = (\d+)",
                  stdout)
    if m:
        r["boundary_dofs"], r["boundary_nodes"], r["modes"], r["reduced_size"] = map(int, m.groups())
    freqs = re.findall(r"^\s+(\d+)\s+([0-9.eE+-]+)\s+([0-9.eE+-]+)\s*$", stdout, re.M)
    r["first_frequencies_hz"] = [[float(a), float(b)] for _, a, b in freqs[:6]]
    r["log_view"] = parse_log_view(stdout, LOG_EVENTS)
    return r


def run_reduce(morse, mesh, ranks, modes, out_h5, log_view, omp_threads, extra):
    args = [morse, "reduce", "-mesh", mesh, "-clamp", "x0", "-boundary", "iface",
            "-cb_num_fixed_modes", str(modes), "-material_E", repr(STEEL["E"]),
            "-material_nu", repr(STEEL["nu"]), "-material_rho", repr(STEEL["rho"]), "-out", out_h5]
    if log_view:
        args.append("-log_view")
    args += extra
    run, cmd = run_mpi("reduce_bench", args, ranks, os.path.dirname(out_h5), omp_threads)
    if run is None:
        return None, cmd
    r = parse_run(run.pop("stdout"))
    run.pop("stderr")
    r.update(run)
    missing = [s for s in STAGES + ["total"] if s not in r["stages"]]
    if missing:
        sys.stderr.write("reduce_bench: stage(s) %s missing from the output of %s\n"
                         % (missing, " ".join(cmd)))
        return None, cmd
    return r, cmd


# ------------------------------------------------------------------------------------- stats
def summarize(samples):
    s = {"runs": len(samples)}
    keys = STAGES + ["total"]
    s["stage_seconds_median"] = {k: med([r["stages"][k] for r in samples]) for k in keys}
    s["stage_seconds_samples"] = {k: [r["stages"][k] for r in samples] for k in keys}
    s["stage_seconds_min"] = {k: min(r["stages"][k] for r in samples) for k in keys}
    s["stage_seconds_max"] = {k: max(r["stages"][k] for r in samples) for k in keys}
    s["process_wall_median"] = med([r["process_wall"] for r in samples])
    s["process_wall_samples"] = [r["process_wall"] for r in samples]
    s["cpu_busy_before_samples"] = [r.get("cpu_busy_before") for r in samples]
    s["foreign_cpu_fraction_samples"] = [r.get("foreign_cpu_fraction") for r in samples]
    s["foreign_cpu_fraction_max"] = max([x for x in s["foreign_cpu_fraction_samples"] if x is not None] or [0])
    s["contention_samples"] = [r.get("contention") for r in samples]
    s["contention_max"] = max([x for x in s["contention_samples"] if x is not None] or [0])
    s["cpu_seconds_all_ranks_median"] = med([sum(r["rank_cpu_seconds"]) or None for r in samples])
    s["factor_seconds_median"] = med([r["factor_seconds"] for r in samples])
    s["factor_seconds_samples"] = [r["factor_seconds"] for r in samples]
    s["factor_shared_with_constraint_modes"] = all(r["factor_shared"] for r in samples)
    s["peak_mb_per_rank_max"] = max(r["stage_peak_mb"]["total"] for r in samples)
    s["peak_mb_per_stage_max"] = {k: max(r["stage_peak_mb"][k] for r in samples) for k in keys}
    sums = [r["sum_max_rss_mb"] for r in samples if r["sum_max_rss_mb"] is not None]
    s["peak_mb_all_ranks_max"] = max(sums) if sums else None
    events = sorted({e for r in samples for e in r["log_view"]})
    s["log_view_seconds_median"] = {e: med([r["log_view"].get(e, {}).get("seconds") for r in samples])
                                    for e in events}
    t = s["stage_seconds_median"]["total"]
    st = s["stage_seconds_median"]
    s["fractions_of_total"] = {k: st[k] / t for k in STAGES}
    s["fraction_factor_plus_eigensolve"] = (st["Factor"] + st["EigenSolve"]) / t
    s["fraction_assemble_plus_write"] = (st["Assemble"] + st["Write"]) / t
    s["fraction_setup_read_number_prealloc_assemble"] = (
        st["ReadDistribute"] + st["NumberDofs"] + st["Preallocate"] + st["Assemble"]) / t
    s["fraction_unaccounted"] = 1.0 - sum(st[k] for k in STAGES) / t
    s["outside_stages_seconds_median"] = med([r["stages"]["total"] - sum(r["stages"][k] for k in STAGES)
                                              for r in samples])
    return s


def find_reference(path_arg, kind, mesh, current_path):
    if path_arg == "none":
        return None, None
    if path_arg:
        with open(path_arg) as f:
            return path_arg, json.load(f)
    for p in sorted(glob.glob(os.path.join(RESULTS, "reduce_*_%s.json" % kind)), reverse=True):
        if os.path.abspath(p) == os.path.abspath(current_path):
            continue
        try:
            with open(p) as f:
                ref = json.load(f)
        except (OSError, ValueError):
            continue
        if ref.get("mesh", {}).get("cells") == mesh["cells"] and ref.get("modes") == mesh.get("modes"):
            return p, ref
    return None, None


def ratios_against(ref, per_ranks):
    out = {}
    for nr, s in per_ranks.items():
        rs = ref.get("per_ranks", {}).get(nr)
        if not rs:
            continue
        a, b = s["stage_seconds_median"], rs["stage_seconds_median"]
        out[nr] = {k: (a[k] / b[k] if b.get(k) else None) for k in a}
        if rs.get("peak_mb_per_rank_max"):
            out[nr]["peak_mb_per_rank"] = s["peak_mb_per_rank_max"] / rs["peak_mb_per_rank_max"]
    return out


# ------------------------------------------------------------------------------------- main
def print_summary(res):
    pr = res["per_ranks"]
    ranks = sorted(pr, key=int)
    m = res["mesh"]
    print("\nmorse reduce benchmark (%s): %d nodes, %d elements, %d free DOFs, %d boundary DOFs, "
          "%d modes; medians of %s runs" % (m["type"], m["nodes"], m["elements"], m["free_dofs"],
                                            m["boundary_dofs"], res["modes"],
                                            "/".join(str(pr[r]["runs"]) for r in ranks)))
    head = "  %-18s" % "stage" + "".join("%10s %6s" % ("%s rk [s]" % r, "%") for r in ranks)
    if len(ranks) >= 2:
        head += "%9s" % "speedup"
    print(head)
    for k in STAGES + ["(outside stages)", "total"]:
        line = "  %-18s" % k
        for r in ranks:
            t = (pr[r]["outside_stages_seconds_median"] if k == "(outside stages)"
                 else pr[r]["stage_seconds_median"][k])
            line += "%10s %6s" % (fmt(t, 10), "%5.1f" % (100 * t / pr[r]["stage_seconds_median"]["total"]))
        if len(ranks) >= 2:
            key = "outside_stages_seconds_median"
            a, b = ((pr[ranks[0]][key], pr[ranks[-1]][key]) if k == "(outside stages)" else
                    (pr[ranks[0]]["stage_seconds_median"][k], pr[ranks[-1]]["stage_seconds_median"][k]))
            line += "%9s" % ("%.2f" % (a / b) if b > 0 else "-")
        print(line)
    rows = [("process wall (mpirun) [s]", "process_wall_median", 3),
            ("MUMPS factorization [s]", "factor_seconds_median", 3),
            ("peak RSS per rank [MB]", "peak_mb_per_rank_max", 1),
            ("peak RSS all ranks [MB]", "peak_mb_all_ranks_max", 1),
            ("CPU s, all ranks", "cpu_seconds_all_ranks_median", 2),
            ("max other load (medians)", "foreign_cpu_fraction_max", 2),
            ("max contention (medians)", "contention_max", 2),
            ("disturbed runs (excluded)", "disturbed_runs", 0),
            ("Factor+EigenSolve frac", "fraction_factor_plus_eigensolve", 3),
            ("Assemble+Write frac", "fraction_assemble_plus_write", 3),
            ("Read..Assemble frac", "fraction_setup_read_number_prealloc_assemble", 3)]
    for label, key, p in rows:
        print("  %-26s" % label + "".join("%12s" % fmt(pr[r][key], 12, p) for r in ranks))
    for ev in ("MatCholFctrSym", "MatCholFctrNum", "MatMatSolve", "MatSolve"):
        if any(ev in pr[r]["log_view_seconds_median"] for r in ranks):
            print("  %-26s" % ("-log_view " + ev + " [s]") +
                  "".join("%12s" % fmt(pr[r]["log_view_seconds_median"].get(ev), 12) for r in ranks))
    for r in ranks:
        if pr[r]["medians_include_disturbed_runs"]:
            print("  WARNING: every %s-rank run was disturbed by other processes; its medians are not "
                  "trustworthy" % r)
    if "speedup_total" in res:
        print("  speed-up %s -> %s ranks (total wall): %.2f" % (ranks[0], ranks[-1], res["speedup_total"]))
    for name, t in res["targets"].items():
        print("  target %-40s %s (%s)" % (name, "PASS" if t["pass"] else "FAIL", t["value"]))
    if res.get("reference"):
        print("  ratios vs reference %s (total): %s" % (
            os.path.basename(res["reference"]),
            ", ".join("%s rk %.2f" % (r, v["total"]) for r, v in res["ratios_vs_reference"].items())))


def markdown_table(paths):
    """A Markdown table of the medians of result files (for bench/README.md)."""
    res = []
    for p in paths:
        with open(p) as f:
            res.append((os.path.basename(p), json.load(f)))
    cols = []
    for name, d in res:
        for nr in sorted(d["per_ranks"], key=int):
            cols.append((name, d, nr))
    out = ["| | " + " | ".join("%s %s rk" % (d["mesh"]["type"], nr) for _, d, nr in cols) + " |",
           "|---|" + "---:|" * len(cols)]

    def row(label, f):
        out.append("| %s | " % label + " | ".join(f(d, d["per_ranks"][nr]) for _, d, nr in cols) + " |")

    row("runs in the median (disturbed, excluded)", lambda d, s: "%d (%d)" % (s["runs"], s.get("disturbed_runs", 0)))
    for k in STAGES:
        row(k + " [s]", lambda d, s, k=k: "%.3f" % s["stage_seconds_median"][k])
    row("(outside stages) [s]", lambda d, s: "%.2f" % s["outside_stages_seconds_median"])
    row("**total (wall)** [s]", lambda d, s: "**%.2f**" % s["stage_seconds_median"]["total"])
    row("mpirun wall [s] (min-max)", lambda d, s: "%.2f (%.1f-%.1f)" % (
        s["process_wall_median"], min(s["process_wall_samples"]), max(s["process_wall_samples"])))
    row("MUMPS factorization [s] (symbolic + numeric)", lambda d, s: "%.2f (%.2f + %.2f)" % (
        s["factor_seconds_median"], s["log_view_seconds_median"].get("MatCholFctrSym", float("nan")),
        s["log_view_seconds_median"].get("MatCholFctrNum", float("nan"))))
    row("triangular solves: count, time [s]", lambda d, s: "%d, %.1f" % (
        s["samples"][0]["log_view"].get("MatSolve", {}).get("count", 0),
        s["log_view_seconds_median"].get("MatSolve", float("nan"))))
    row("Factor+EigenSolve / total", lambda d, s: "%.0f %%" % (100 * s["fraction_factor_plus_eigensolve"]))
    row("Preallocate+Assemble / total", lambda d, s: "%.1f %%" % (
        100 * (s["fractions_of_total"]["Preallocate"] + s["fractions_of_total"]["Assemble"])))
    row("Assemble+Write / total", lambda d, s: "%.1f %%" % (100 * s["fraction_assemble_plus_write"]))
    row("peak RSS per rank [MB]", lambda d, s: "%.0f" % s["peak_mb_per_rank_max"])
    row("peak RSS all ranks [MB]", lambda d, s: "%.0f" % (s["peak_mb_all_ranks_max"] or float("nan")))
    row("speed-up 1 -> 2 ranks (total)", lambda d, s: "%.2f" % d["speedup_total"] if "speedup_total" in d else "-")
    return "\n".join(out)


def main():
    if len(sys.argv) > 2 and sys.argv[1] == "--table":
        print(markdown_table(sys.argv[2:]))
        return 0
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--type", default="hex20", choices=["hex20", "wedge15", "tet10"])
    ap.add_argument("--runs", type=int, default=3, help="repetitions per rank count (default 3)")
    ap.add_argument("--ranks", default="1,2", help="comma-separated rank counts (default 1,2)")
    ap.add_argument("--target-dofs", type=int, default=60000, help="approximate 3 x nodes (default 60000)")
    ap.add_argument("--modes", type=int, default=100, help="fixed-interface modes (default 100)")
    ap.add_argument("--omp-threads", type=int, default=1,
                    help="OMP_NUM_THREADS/OPENBLAS_NUM_THREADS per rank (default 1: one core per rank)")
    ap.add_argument("--idle-limit", type=float, default=0.15,
                    help="before each run wait until at most this fraction of the CPUs is busy (default 0.15)")
    ap.add_argument("--idle-timeout", type=float, default=300,
                    help="longest wait for an idle machine per run [s]; 0: do not wait (default 300)")
    ap.add_argument("--max-load", type=float, default=0.10,
                    help="a run during which other processes used more than this fraction of all CPUs is "
                         "'disturbed' (even on a core morse leaves idle they slow the memory-bound "
                         "solves down): kept in the JSON, left out of the medians, repeated (default 0.10)")
    ap.add_argument("--retries", type=int, default=3,
                    help="extra runs per rank count allowed to replace disturbed ones (default 3)")
    ap.add_argument("--env", action="append", default=[], metavar="KEY=VALUE",
                    help="extra environment for morse, e.g. LD_LIBRARY_PATH=DIR to try another BLAS "
                         "(repeatable; recorded in the JSON)")
    ap.add_argument("--no-log-view", action="store_true", help="do not pass -log_view")
    ap.add_argument("--reference", default="",
                    help="results JSON to compare with ('none': no comparison; default: the newest "
                         "earlier result of the same type and mesh in bench/results)")
    ap.add_argument("--morse", default=os.path.join(ROOT, "build", "morse"))
    ap.add_argument("--keep", action="store_true", help="keep the work directory (mesh, HDF5)")
    ap.add_argument("--out", default="", help="results file (default bench/results/reduce_<date>_<type>.json)")
    ap.add_argument("extra", nargs="*", help="extra options for morse reduce (after --)")
    a = ap.parse_args()
    ranks = [int(r) for r in a.ranks.split(",")]
    for kv in a.env:
        k, _, v = kv.partition("=")
        EXTRA_ENV[k] = v

    if not os.path.exists(a.morse):
        print("reduce_bench: %s missing, running run/build" % a.morse)
        subprocess.run([os.path.join(ROOT, "run", "build")], check=True)

    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H%M%SZ")
    out_path = a.out or os.path.join(RESULTS, "reduce_%s_%s.json" % (stamp, a.type))
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))  # run the clean-up below
    os.makedirs(os.path.dirname(os.path.abspath(out_path)), exist_ok=True)
    work = tempfile.mkdtemp(prefix="morse_reduce_bench_")
    try:
        # Every run uses a snapshot of the binary: build/morse may be rebuilt while we run.
        morse_src = a.morse
        morse_mtime = datetime.datetime.fromtimestamp(os.path.getmtime(morse_src), datetime.timezone.utc)
        a.morse = os.path.join(work, "morse")
        shutil.copy2(morse_src, a.morse)
        nx = choose_nx(a.type, a.target_dofs)
        mesh_path = os.path.join(work, "bar_%s.msh" % a.type)
        t0 = time.monotonic()
        mesh = make_mesh(a.morse, a.type, nx, mesh_path)
        mesh["generate_seconds"] = time.monotonic() - t0
        mesh["file_mb"] = os.path.getsize(mesh_path) / 2**20
        print("reduce_bench: %s mesh %dx%dx%d cells, %d nodes, %d elements, %d DOFs (%.1f MB file)"
              % (a.type, nx, NY, NZ, mesh["nodes"], mesh["elements"], mesh["total_dofs"], mesh["file_mb"]))

        # Rank counts are interleaved (1,2,1,2,...) so that a disturbance of the machine hits
        # them alike. A run during which other processes used more than --max-load of the CPUs
        # is kept but marked disturbed, and repeated (at most --retries extra runs per rank
        # count); medians are over the undisturbed runs when there are any.
        failed, cmds = [], {}
        samples = {nr: [] for nr in ranks}
        attempts = {nr: 0 for nr in ranks}

        def clean(nr):
            return [r for r in samples[nr] if not r["disturbed"]]

        while True:
            todo = [nr for nr in ranks if len(clean(nr)) < a.runs and attempts[nr] < a.runs + a.retries]
            if not todo:
                break
            for nr in todo:
                attempts[nr] += 1
                busy = wait_idle(a.idle_limit, a.idle_timeout) if a.idle_timeout > 0 else cpu_busy()
                r, cmd = run_reduce(a.morse, mesh_path, nr, a.modes, os.path.join(work, "se.h5"),
                                    not a.no_log_view, a.omp_threads, a.extra)
                cmds[str(nr)] = " ".join(cmd)
                if r is None:
                    failed.append({"ranks": nr, "attempt": attempts[nr], "command": " ".join(cmd)})
                    attempts[nr] = a.runs + a.retries  # do not insist
                    continue
                r["cpu_busy_before"] = busy
                load = r["foreign_cpu_fraction"]
                r["disturbed"] = load is not None and load > a.max_load
                samples[nr].append(r)
                # Raw samples so far, in case the benchmark is stopped before the end.
                with open(out_path + ".partial", "w") as f:
                    json.dump({"mesh": mesh, "samples": samples}, f)
                print("  %d rank(s) attempt %d: total %.2f s (Factor %.2f, EigenSolve %.2f, Assemble %.2f, "
                      "Preallocate %.2f), CPU %.1f s, peak %.0f MB/rank, other load %s%s" % (
                          nr, attempts[nr], r["stages"]["total"], r["stages"]["Factor"],
                          r["stages"]["EigenSolve"], r["stages"]["Assemble"], r["stages"]["Preallocate"],
                          sum(r["rank_cpu_seconds"]), r["stage_peak_mb"]["total"], "%.0f%%" % (100 * load) if load is not None else "?",
                          " -> DISTURBED, not in the medians" if r["disturbed"] else ""), flush=True)
        per_ranks = {}
        for nr in ranks:
            if not samples[nr]:
                continue
            use = clean(nr) or samples[nr]
            per_ranks[str(nr)] = summarize(use)
            per_ranks[str(nr)]["medians_include_disturbed_runs"] = not clean(nr)
            per_ranks[str(nr)]["disturbed_runs"] = len(samples[nr]) - len(clean(nr))
            per_ranks[str(nr)]["samples"] = samples[nr]
        if not per_ranks:
            raise SystemExit(2)
        first = next(iter(per_ranks.values()))["samples"][0]
        for k in ("free_dofs", "clamped_dofs", "boundary_dofs", "boundary_nodes", "modes", "reduced_size"):
            mesh[k] = first.get(k)
        mesh["interior_dofs"] = mesh["free_dofs"] - mesh["boundary_dofs"]
        mesh["modes"] = a.modes
        res = {"benchmark": "reduce", "date_utc": stamp, "mesh": mesh, "modes": a.modes,
               "material": STEEL, "clamp": "x0", "boundary": "iface (4 corners + 4 edge midpoints of x1)",
               "commands": cmds, "per_ranks": per_ranks, "failed_runs": failed,
               "environment": {"host": platform.node(), "cpus": os.cpu_count(), "omp_threads": a.omp_threads,
                               "log_view": not a.no_log_view, "morse": morse_src,
                               "extra_env": EXTRA_ENV, "blas": blas_info(a.morse),
                               "morse_mtime": morse_mtime.isoformat(),
                               "git": git_info()}}
        rk = sorted(per_ranks, key=int)
        if len(rk) >= 2:
            a0, a1 = per_ranks[rk[0]], per_ranks[rk[-1]]
            res["speedup_total"] = a0["stage_seconds_median"]["total"] / a1["stage_seconds_median"]["total"]
            res["speedup_process_wall"] = a0["process_wall_median"] / a1["process_wall_median"]
            res["speedup_per_stage"] = {k: (a0["stage_seconds_median"][k] / a1["stage_seconds_median"][k]
                                            if a1["stage_seconds_median"][k] > 0 else None)
                                        for k in STAGES + ["total"]}
            res["speedup_ranks"] = [int(rk[0]), int(rk[-1])]
        # Targets: the whole reduce on 2 ranks (process wall, i.e. including MPI start-up and
        # PETSc initialization) under 30 s; memory of all ranks together under 4 GB; time
        # dominated by Factor + EigenSolve rather than by Assemble + Write.
        targets = {}
        tr = "2" if "2" in per_ranks else rk[-1]
        s = per_ranks[tr]
        wall = s["process_wall_median"]
        targets["wall_%s_ranks_lt_30s" % tr] = {"value": round(wall, 3), "limit": TARGET_SECONDS_2RANKS,
                                                "ratio": wall / TARGET_SECONDS_2RANKS,
                                                "pass": wall < TARGET_SECONDS_2RANKS}
        mem = max((p["peak_mb_all_ranks_max"] or p["peak_mb_per_rank_max"] * int(n)) for n, p in per_ranks.items())
        targets["memory_all_ranks_lt_4GB"] = {"value": round(mem, 1), "limit": TARGET_MEMORY_MB,
                                              "ratio": mem / TARGET_MEMORY_MB, "pass": mem < TARGET_MEMORY_MB}
        fe_, aw = s["fraction_factor_plus_eigensolve"], s["fraction_assemble_plus_write"]
        targets["factor_eigensolve_dominate"] = {"value": "%.3f vs %.3f" % (fe_, aw), "pass": fe_ > aw and fe_ > 0.5}
        res["targets"] = targets
        res["all_targets_pass"] = all(t["pass"] for t in targets.values())
        ref_path, ref = find_reference(a.reference, a.type, mesh, out_path)
        if ref:
            res["reference"] = ref_path
            res["ratios_vs_reference"] = ratios_against(ref, per_ranks)
        os.makedirs(os.path.dirname(out_path), exist_ok=True)
        with open(out_path, "w") as f:
            json.dump(res, f, indent=1)
        if os.path.exists(out_path + ".partial"):
            os.remove(out_path + ".partial")
        print_summary(res)
        print("reduce_bench: wrote %s" % os.path.relpath(out_path, os.getcwd()))
        if failed:
            return 2
        return 0 if res["all_targets_pass"] else 1
    finally:
        if a.keep:
            print("reduce_bench: kept %s" % work)
        else:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
