#!/usr/bin/python3
"""What each model input path of `morse reduce` costs, and a check that all give one superelement.

Run from the repository root with Debian's interpreter (numpy and h5py are needed):

    /usr/bin/python3 bench/model_input_bench.py --mesh meshes/stator_coarse.msh --runs 1   # smoke test, ~1 min
    /usr/bin/python3 bench/model_input_bench.py                   # meshes/stator.msh, ranks 1,2, 3 runs
    /usr/bin/python3 bench/model_input_bench.py --paths msh,op4 --ranks 2 -- -cb_eps_purify 0   # extra morse options after --

morse reads a model in five ways; the same model (the stator, clamped at `mount`, interface
`interface`, see meshes/README.md) is given in each:

  msh    the Gmsh mesh:                 -mesh M.msh -clamp mount -boundary interface
  bdf    a Nastran bulk data deck:      -mesh M.bdf -clamp '*BOUNDARY' -boundary ASET
         written by `morse mesh stator [generator options] -out M.bdf -nastran_format free
         -nastran_spc mount -nastran_aset interface` (only if the generator reproduces M.msh byte
         for byte; otherwise the path is skipped with the reason)
  mtx    assembled free-DOF K, M as MatrixMarket:  -matrices_K M_K.mtx -matrices_M M_M.mtx
         -matrices_dofmap M_dofmap.txt -boundary interface
  petsc  the same as PETSc binary (.petsc)
  op4    the same as one Nastran OUTPUT4 ASCII file (KAA then MAA, real double, BIGMAT sparse or
         non-sparse column runs), written by this script from the .mtx files:
         -matrices_K M.op4:KAA -matrices_M M.op4:MAA -matrices_dofmap M_dofmap.txt

Preparation (once, not timed): `morse reduce -mesh M -clamp mount -boundary interface
-cb_num_fixed_modes 0 -matrices_write PREFIX [-matrices_write_format petsc]` on 1 rank, the deck,
the OP4 file. Everything goes to out/bench_input/ (the superelements of the timed runs to
out/bench_input/se_<path>_np<R>.h5).

Timed runs: for every path and rank count (interleaved, --runs times) `mpiexec --oversubscribe
--bind-to none -n R /usr/bin/time ... morse reduce <model options> -cb_num_fixed_modes 20 -out ...`.
From morse's stage table: the input stages (mesh: ReadDistribute, NumberDofs, Preallocate,
Assemble; matrices: ReadMatrices, which contains the two ReadMatrix stages of K and M), the
Craig-Bampton stages, Write, total (wall); the process wall time of mpiexec; peak memory (morse's
per-rank peak RSS, max over ranks, and the sum over ranks of /usr/bin/time's max RSS).

Check: /cb/fixed_interface/frequencies_hz and /rom/frequencies_hz of every run agree with the
first msh run to --rtol (1e-8) relative, and /rom/boundary_dofs are identical.

Writes bench/results/model_input_<UTC date-time>_<mesh stem>.json and prints a table.
Exit status: 0 all runs agree; 1 a superelement differs from the msh path; 2 morse or the
preparation failed.
"""

import argparse
import datetime
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

import numpy as np

from benchlib import (EXTRA_ENV, RESULTS, ROOT, blas_info, cpu_busy, git_info, med, mpi_env, run_mpi,
                      wait_idle)

PATHS = ["msh", "bdf", "mtx", "petsc", "op4"]
MESH_INPUT_STAGES = ["ReadDistribute", "NumberDofs", "Preallocate", "Assemble"]
MATRIX_INPUT_STAGES = ["ReadMatrices"]
# Stages that run inside another one (a stage's line is printed when it ends, so a nested stage
# comes before its parent in the table): ReadMatrix (K, then M) inside ReadMatrices, and
# EigenResiduals inside EigenVectors (src/eigen/eigen.cpp). They are reported but not added again.
NESTED_IN = {"ReadMatrix": "ReadMatrices", "EigenResiduals": "EigenVectors"}
PER_MATRIX_STAGES = ["ReadMatrix"]  # once per matrix: kept apart as ReadMatrix_1 (K), ReadMatrix_2 (M)
OUTPUT_STAGES = ["Write"]
# `morse mesh stator` options that made the committed meshes (meshes/README.md, "Regenerate").
GENERATORS = {"stator": ["stator"], "stator_coarse": ["stator", "-stator_size", "coarse"]}


# ------------------------------------------------------------------------------------ helpers
def log(msg):
    print(msg, flush=True)


def mpiexec(ranks):
    return ["mpiexec", "--oversubscribe", "--bind-to", "none", "-n", str(ranks)]


def run_plain(cmd, what):
    """Runs a preparation command; returns (seconds, stdout) or raises RuntimeError."""
    t0 = time.monotonic()
    p = subprocess.run(cmd, capture_output=True, text=True, env=mpi_env(1))
    dt = time.monotonic() - t0
    if p.returncode != 0:
        raise RuntimeError("%s failed (exit %d): %s\n--- stdout\n%s\n--- stderr\n%s"
                           % (what, p.returncode, " ".join(cmd), p.stdout[-4000:], p.stderr[-4000:]))
    return dt, p.stdout


def run_morse(morse_args, ranks, work, omp_threads):
    """benchlib.run_mpi with mpiexec --oversubscribe --bind-to none. Returns (result dict or None,
    cmd, failure text)."""
    failure = []
    r, cmd = run_mpi("morse", morse_args, ranks, work, omp_threads, launcher=mpiexec, failure=failure)
    return r, cmd, failure[0] if failure else ""


def parse_stages(stdout):
    """morse's stage table in order: [(name, seconds, peak_mb)]; "total (wall)" is "total"."""
    rows, inside = [], False
    for line in stdout.splitlines():
        if re.match(r"^\s+stage\s+time \[s\]\s+peak \[MB\]", line):
            rows, inside = [], True
            continue
        m = re.match(r"^\s+(\w+|total \(wall\))\s+([0-9.]+)\s+([0-9.]+)\s*$", line)
        if inside and m:
            rows.append(("total" if m.group(1).startswith("total") else m.group(1),
                         float(m.group(2)), float(m.group(3))))
    return rows


def parse_run(stdout, path):
    rows = parse_stages(stdout)
    sec, peak = {}, {}
    for name, s, p in rows:
        if name in PER_MATRIX_STAGES:  # one per matrix: keep them apart
            k = 0
            while "%s_%d" % (name, k + 1) in sec:
                k += 1
            name = "%s_%d" % (name, k + 1)
        sec[name] = sec.get(name, 0.0) + s
        peak[name] = max(peak.get(name, 0.0), p)
    input_stages = MESH_INPUT_STAGES if path in ("msh", "bdf") else MATRIX_INPUT_STAGES
    top = [n for n in sec if n != "total" and n not in NESTED_IN and
           not any(n.startswith(x + "_") for x in PER_MATRIX_STAGES)]
    cb = [n for n in top if n not in input_stages and n not in OUTPUT_STAGES]
    g = {"input": sum(sec.get(n, 0.0) for n in input_stages),
         "cb": sum(sec[n] for n in cb),
         "write": sum(sec.get(n, 0.0) for n in OUTPUT_STAGES),
         "total": sec.get("total")}
    g["outside_stages"] = g["total"] - sum(sec[n] for n in top) if g["total"] is not None else None
    r = {"stages": sec, "stage_peak_mb": peak, "stage_order": [n for n, _, _ in rows], "cb_stages": cb,
         "groups": g, "peak_mb_per_rank": peak.get("total")}
    m = re.search(r"(\d+) free DOFs, (\d+) clamped", stdout)
    if m:
        r["free_dofs"], r["clamped_dofs"] = int(m.group(1)), int(m.group(2))
    m = re.search(r"matrices K \S+ \((\d+) entries\), M \S+ \((\d+) entries\): (\d+) rows, (\d+) clamped, "
                  r"(\d+) free", stdout)
    if m:
        r["matrix_entries_K"], r["matrix_entries_M"] = int(m.group(1)), int(m.group(2))
        r["free_dofs"], r["clamped_dofs"] = int(m.group(5)), int(m.group(4))
    m = re.search(r"(\d+) boundary DOFs \((\d+) nodes\) \+ (\d+) fixed-interface modes = (\d+)", stdout)
    if m:
        r["boundary_dofs"], r["boundary_nodes"], r["fixed_modes"], r["reduced_size"] = map(int, m.groups())
    m = re.search(r"K_ii factored once.*\(([0-9.]+) s\)", stdout)
    r["factor_seconds"] = float(m.group(1)) if m else None
    return r


# ------------------------------------------------------------------------------------ OP4 writer
# Written from the format description in include/morse/io/op4.hpp (Nastran OUTPUT4, ASCII),
# independently of morse's own writer (src/io/op4.cpp):
#   header   4I8 (NCOL, NROW, NF, NTYPE) + name (A8) + "1P,3E23.16"; NROW < 0 flags BIGMAT
#   column   3I8 ICOL, IROW, NW
#              IROW = 0 (sparse): NW words of strings; BIGMAT string header "L+1 IROW" (2I8), then
#                                 the L words (L/2 doubles) of consecutive rows; NW and L count
#                                 words (2 per double), string headers 2 words each
#              IROW > 0 (non-sparse run): NW = number of values printed (the ASCII irregularity);
#                                 a column may be split into several records, rows increasing
#   values   3 per line, Fortran 1P,E23.16 (exponent letter dropped when |exponent| > 99); every
#            run / string starts on a new line
#   end      NCOL+1, 1, 1 then the value 1.0
W = 23  # field width of 1P,3E23.16


def read_mtx(path):
    """(n, rows, cols, values) of a MatrixMarket coordinate real file, 0-based, both triangles."""
    with open(path, "rb") as f:
        banner = f.readline().decode().lower().split()
        if banner[:4] != ["%%matrixmarket", "matrix", "coordinate", "real"]:
            raise RuntimeError("%s: not a real coordinate MatrixMarket file: %s" % (path, " ".join(banner)))
        symmetric = banner[4] == "symmetric"
        line = f.readline()
        while line.startswith(b"%"):
            line = f.readline()
        nr, nc, nnz = map(int, line.split())
        data = np.fromstring(f.read().decode(), dtype=np.float64, sep=" ")
    if data.size != 3 * nnz or nr != nc:
        raise RuntimeError("%s: expected %d entries of a square matrix, read %d numbers (%d x %d)"
                           % (path, nnz, data.size, nr, nc))
    data = data.reshape(nnz, 3)
    i = data[:, 0].astype(np.int64) - 1
    j = data[:, 1].astype(np.int64) - 1
    v = data[:, 2].copy()
    if symmetric:
        off = i != j
        i, j, v = np.concatenate([i, j[off]]), np.concatenate([j, i[off]]), np.concatenate([v, v[off]])
    return nr, i, j, v


def fortran_e(values):
    """The values as one string of fixed 23-character fields in Fortran 1P,E23.16."""
    s = ("%23.16E" * len(values)) % tuple(values.tolist())
    if len(s) == W * len(values):
        return s
    # Some exponent has 3 digits: Fortran prints "-1.2345678901234567-100" (no letter).
    out = []
    for x in values.tolist():
        f = "%.16E" % x
        mant, ex = f.split("E")
        if len(ex) > 3:
            f = mant + ex
        out.append(f.rjust(W))
    return "".join(out)


def value_lines(block, start, count):
    """`count` values starting at field `start` of the formatted block, 3 per line."""
    seg = block[W * start:W * (start + count)]
    return "".join(seg[k:k + 3 * W] + "\n" for k in range(0, len(seg), 3 * W))


def write_op4_matrix(f, name, n, rows, cols, vals, layout):
    """Appends one n x n real double matrix (COO, any order) to the open text file f."""
    keep = vals != 0.0
    rows, cols, vals = rows[keep], cols[keep], vals[keep]
    order = np.lexsort((rows, cols))
    rows, cols, vals = rows[order], cols[order], vals[order]
    if rows.size > 1 and np.any((np.diff(cols) == 0) & (np.diff(rows) == 0)):
        raise RuntimeError("matrix %s has duplicate entries" % name)
    # exactly symmetric (both triangles stored, as OUTPUT4 does): form 6, else 1 (square)
    t = np.lexsort((cols, rows))
    symmetric = np.array_equal(rows, cols[t]) and np.array_equal(cols, rows[t]) and np.array_equal(vals, vals[t])
    form = 6 if symmetric else 1
    bigmat = layout == "bigmat"
    f.write("%8d%8d%8d%8d%-8s1P,3E23.16\n" % (n, -n if bigmat else n, form, 2, name))
    # runs of consecutive rows within a column
    nnz = rows.size
    new_run = np.ones(nnz, dtype=bool)
    new_run[1:] = (cols[1:] != cols[:-1]) | (rows[1:] != rows[:-1] + 1)
    run_start = np.flatnonzero(new_run)
    run_len = np.diff(np.append(run_start, nnz))
    run_col = cols[run_start]
    run_row = rows[run_start]
    col_first_run = np.flatnonzero(np.r_[True, run_col[1:] != run_col[:-1]])
    col_last_run = np.append(col_first_run[1:], run_start.size)
    chunk = 1 << 20  # values formatted per block
    pos = 0
    while pos < col_first_run.size:
        # a block of whole columns with about `chunk` values
        end = pos + 1
        base = run_start[col_first_run[pos]]
        while end < col_first_run.size and run_start[col_first_run[end]] - base < chunk:
            end += 1
        stop = run_start[col_first_run[end]] if end < col_first_run.size else nnz
        block = fortran_e(vals[base:stop])
        parts = []
        for c in range(pos, end):
            r0, r1 = col_first_run[c], col_last_run[c]
            icol = int(run_col[r0]) + 1
            if bigmat:
                nw = int(2 * (r1 - r0) + 2 * run_len[r0:r1].sum())
                parts.append("%8d%8d%8d\n" % (icol, 0, nw))
                for r in range(r0, r1):
                    L = int(run_len[r])
                    parts.append("%8d%8d\n" % (2 * L + 1, int(run_row[r]) + 1))
                    parts.append(value_lines(block, int(run_start[r] - base), L))
            else:
                for r in range(r0, r1):
                    L = int(run_len[r])
                    parts.append("%8d%8d%8d\n" % (icol, int(run_row[r]) + 1, L))
                    parts.append(value_lines(block, int(run_start[r] - base), L))
        f.write("".join(parts))
        pos = end
    f.write("%8d%8d%8d\n%23.16E\n" % (n + 1, 1, 1, 1.0))
    return {"name": name, "nrows": n, "ncols": n, "form": form, "type": 2, "entries": int(nnz),
            "strings_or_runs": int(run_start.size), "layout": "BIGMAT sparse" if bigmat else "non-sparse runs"}


def write_op4(path, matrices, layout):
    """matrices: [(name, mtx path)]; one ASCII OP4 file holding them in this order."""
    info = []
    with open(path, "w") as f:
        for name, mtx in matrices:
            n, i, j, v = read_mtx(mtx)
            info.append(write_op4_matrix(f, name, n, i, j, v, layout))
    return info


# ------------------------------------------------------------------------------------ preparation
def msh_material(path):
    """[(name, E, nu, rho)] of the $MorseMaterials section of a morse-written Gmsh file (src/mesh/gmsh.cpp:
    version 1, the number of materials, one line "name" E nu rho each, then per-element indices)."""
    mats, lines, inside = [], [], False
    with open(path) as f:
        for line in f:
            if line.startswith("$MorseMaterials"):
                inside = True
                continue
            if line.startswith("$EndMorseMaterials"):
                break
            if inside:
                lines.append(line.strip())
    if len(lines) >= 2 and lines[0] == "1":  # version 1, number of materials, name E nu rho per line
        nmat = int(lines[1])
        for ln in lines[2:2 + nmat]:
            m = re.match(r'^"([^"]*)"\s+(\S+)\s+(\S+)\s+(\S+)', ln)
            if m:
                mats.append((m.group(1), float(m.group(2)), float(m.group(3)), float(m.group(4))))
    return mats


def prepare(a, morse, work, stem):
    """Writes the input files of every path; returns (model options per path, prep record)."""
    prep = {"work_dir": os.path.relpath(work, ROOT), "seconds": {}, "files": {}, "skipped": {}}
    prefix = os.path.join(work, stem)
    mesh = os.path.abspath(a.mesh)
    model = {"msh": ["-mesh", mesh, "-clamp", a.clamp, "-boundary", a.boundary]}

    def fsize(*ps):
        for p in ps:
            prep["files"][os.path.relpath(p, ROOT)] = os.path.getsize(p)

    need_matrices = any(p in a.paths for p in ("mtx", "petsc", "op4"))
    if need_matrices:
        base = ["reduce", "-mesh", mesh, "-clamp", a.clamp, "-boundary", a.boundary, "-cb_num_fixed_modes", "0",
                "-matrices_write", prefix]
        dofmap = prefix + "_dofmap.txt"
        log("  writing %s_K.mtx, _M.mtx, _dofmap.txt (morse reduce -matrices_write, 1 rank)" % prefix)
        dt, _ = run_plain(mpiexec(1) + [morse] + base + ["-out", os.path.join(work, "prep_mtx.h5")], "matrices_write mtx")
        prep["seconds"]["matrices_write_mtx"] = dt
        with open(dofmap, "rb") as f:
            map_mtx = f.read()
        fsize(prefix + "_K.mtx", prefix + "_M.mtx", dofmap)
        if "petsc" in a.paths:
            log("  writing %s_K.petsc, _M.petsc (-matrices_write_format petsc)" % prefix)
            dt, _ = run_plain(mpiexec(1) + [morse] + base + ["-matrices_write_format", "petsc", "-out",
                                                             os.path.join(work, "prep_petsc.h5")],
                              "matrices_write petsc")
            prep["seconds"]["matrices_write_petsc"] = dt
            with open(dofmap, "rb") as f:
                prep["dofmap_identical_mtx_petsc"] = f.read() == map_mtx
            if not prep["dofmap_identical_mtx_petsc"]:
                raise RuntimeError("the DOF map written with the PETSc matrices differs from the one written "
                                   "with the MatrixMarket matrices")
            fsize(prefix + "_K.petsc", prefix + "_M.petsc")
        mopts = ["-matrices_dofmap", dofmap, "-boundary", a.boundary]
        model["mtx"] = ["-matrices_K", prefix + "_K.mtx", "-matrices_M", prefix + "_M.mtx"] + mopts
        model["petsc"] = ["-matrices_K", prefix + "_K.petsc", "-matrices_M", prefix + "_M.petsc"] + mopts
        if "op4" in a.paths:
            op4 = prefix + ".op4"
            log("  writing %s (KAA, MAA; ASCII, real double, %s) from the .mtx files (Python)" % (op4, a.op4_layout))
            t0 = time.monotonic()
            prep["op4"] = write_op4(op4, [("KAA", prefix + "_K.mtx"), ("MAA", prefix + "_M.mtx")], a.op4_layout)
            prep["seconds"]["op4_write_python"] = time.monotonic() - t0
            fsize(op4)
            model["op4"] = ["-matrices_K", op4 + ":KAA", "-matrices_M", op4 + ":MAA"] + mopts

    if "bdf" in a.paths:
        gen = GENERATORS.get(stem)
        reason = None
        if gen is None:
            reason = ("no known `morse mesh` command for %s (known: %s, see meshes/README.md)"
                      % (os.path.basename(a.mesh), ", ".join(sorted(GENERATORS))))
        else:
            regen = os.path.join(work, stem + "_regenerated.msh")
            dt, _ = run_plain([morse, "mesh"] + gen + ["-out", regen], "mesh regeneration")
            with open(regen, "rb") as f1, open(a.mesh, "rb") as f2:
                same = f1.read() == f2.read()
            os.remove(regen)
            mats = msh_material(a.mesh)
            if not same:
                reason = "`morse mesh %s` does not reproduce %s byte for byte" % (" ".join(gen), a.mesh)
            elif len(mats) != 1:
                reason = "the mesh has %d materials (the deck writer takes one)" % len(mats)
            else:
                bdf = prefix + ".bdf"
                _, E, nu, rho = mats[0]
                log("  writing %s (morse mesh %s -nastran_format free -nastran_spc %s -nastran_aset %s)"
                    % (bdf, " ".join(gen), a.clamp, a.boundary))
                dt, _ = run_plain([morse, "mesh"] + gen + ["-out", bdf, "-material_E", repr(E), "-material_nu",
                                                           repr(nu), "-material_rho", repr(rho), "-nastran_format",
                                                           "free", "-nastran_spc", a.clamp, "-nastran_aset",
                                                           a.boundary], "bdf write")
                prep["seconds"]["bdf_write"] = dt
                prep["bdf_generator"] = ["morse", "mesh"] + gen
                fsize(bdf)
                model["bdf"] = ["-mesh", bdf, "-clamp", "*BOUNDARY", "-boundary", "ASET"]
        if reason:
            log("  bdf path SKIPPED: " + reason)
            prep["skipped"]["bdf"] = reason
    return model, prep


# ------------------------------------------------------------------------------------ check
def read_se(path):
    import h5py
    with h5py.File(path, "r") as h:
        return {"fixed_hz": np.array(h["cb/fixed_interface/frequencies_hz"]),
                "rom_hz": np.array(h["rom/frequencies_hz"]),
                "boundary_dofs": np.array(h["rom/boundary_dofs"])}


def compare(ref, se, rtol):
    out = {}
    ok = True
    for key in ("fixed_hz", "rom_hz"):
        a, b = ref[key], se[key]
        if a.shape != b.shape:
            out[key] = {"shape": [list(a.shape), list(b.shape)], "pass": False}
            ok = False
            continue
        d = float(np.max(np.abs(a - b) / np.maximum(np.abs(a), 1e-300))) if a.size else 0.0
        out[key] = {"max_rel_diff": d, "pass": d <= rtol}
        ok = ok and d <= rtol
    same = ref["boundary_dofs"].shape == se["boundary_dofs"].shape and \
        bool(np.array_equal(ref["boundary_dofs"], se["boundary_dofs"]))
    out["boundary_dofs_identical"] = same
    out["pass"] = ok and same
    return out


# ------------------------------------------------------------------------------------ summary
def summarize(ss):
    stages = []
    for r in ss:
        for n in r["stages"]:
            if n not in stages:
                stages.append(n)
    groups = list(ss[0]["groups"])
    return {
        "runs": len(ss),
        "stage_seconds_median": {s: med([r["stages"].get(s) for r in ss]) for s in stages},
        "stage_seconds_min": {s: min(r["stages"].get(s, 0.0) for r in ss) for s in stages},
        "stage_seconds_max": {s: max(r["stages"].get(s, 0.0) for r in ss) for s in stages},
        "stage_seconds_samples": {s: [r["stages"].get(s) for r in ss] for s in stages},
        "group_seconds_median": {g: med([r["groups"][g] for r in ss]) for g in groups},
        "group_seconds_samples": {g: [r["groups"][g] for r in ss] for g in groups},
        "process_wall_median": med([r["process_wall"] for r in ss]),
        "process_wall_samples": [r["process_wall"] for r in ss],
        "peak_mb_per_rank_max": max(r["peak_mb_per_rank"] or 0.0 for r in ss),
        "peak_mb_input_stages_max": max(max([r["stage_peak_mb"].get(s, 0.0) for s in
                                             MESH_INPUT_STAGES + MATRIX_INPUT_STAGES] or [0.0]) for r in ss),
        "peak_mb_all_ranks_max": max([r["sum_max_rss_mb"] for r in ss if r["sum_max_rss_mb"]] or [0]) or None,
        "cpu_seconds_all_ranks_median": med([sum(r["rank_cpu_seconds"]) or None for r in ss]),
        "foreign_cpu_fraction_samples": [r["foreign_cpu_fraction"] for r in ss],
    }


def print_table(res):
    per = res["per_path"]
    ranks = res["ranks"]
    log("\nmodel_input_bench: %s, %s free DOFs, %s boundary DOFs, %d fixed-interface modes; medians of %d run(s)"
        % (res["mesh"], res["sizes"].get("free_dofs"), res["sizes"].get("boundary_dofs"), res["modes"], res["runs"]))
    hdr = "  %-6s %3s %10s %10s %9s %10s %10s %9s %9s %9s %9s" % (
        "path", "np", "input [s]", "CB [s]", "write", "total [s]", "mpiexec", "peak MB", "all rk MB", "input/msh",
        "check")
    log(hdr)
    for p in res["paths"]:
        for nr in ranks:
            d = per.get(p, {}).get(str(nr))
            if not d:
                log("  %-6s %3d %s" % (p, nr, "(skipped: %s)" % res["skipped"][p] if p in res["skipped"] else "(failed)"))
                continue
            g = d["group_seconds_median"]
            ratio = d.get("input_ratio_to_msh")
            log("  %-6s %3d %10.3f %10.3f %9.3f %10.3f %10.3f %9.0f %9.0f %9s %9s" % (
                p, nr, g["input"], g["cb"], g["write"], g["total"], d["process_wall_median"], d["peak_mb_per_rank_max"],
                d["peak_mb_all_ranks_max"] or 0, "%.2f" % ratio if ratio is not None else "-",
                "%.0e" % max(d["check_max_rel_diff_fixed_hz"], d["check_max_rel_diff_rom_hz"])
                if d["check_pass"] else "DIFF"))
    log("  (check: largest relative frequency difference to %s; runs in the medians: %s)" % (
        res["check"]["reference"], ", ".join("%s np%s %d%s" % (p, nr, d["runs"], " (%d disturbed left out)" %
                                                                 d["disturbed_runs"] if d["disturbed_runs"] else "")
                                             for p in res["paths"] for nr, d in per.get(p, {}).items())))
    log("  input stages, medians [s]:")
    for p in res["paths"]:
        for nr in ranks:
            d = per.get(p, {}).get(str(nr))
            if d:
                sm = d["stage_seconds_median"]
                names = MESH_INPUT_STAGES if p in ("msh", "bdf") else ["ReadMatrix_1", "ReadMatrix_2", "ReadMatrices"]
                log("    %-6s %d  %s" % (p, nr, "  ".join("%s %.3f" % (n.replace("ReadMatrix_1", "ReadMatrix(K)")
                                                                      .replace("ReadMatrix_2", "ReadMatrix(M)"),
                                                                      sm.get(n, 0.0)) for n in names)))
    for p in res["paths"]:
        s = res["input_speedup_1_to_2"].get(p)
        if s:
            log("  input speed-up 1 -> 2 ranks, %-6s %.2f" % (p, s))


# ------------------------------------------------------------------------------------ main
def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mesh", default="meshes/stator.msh", help="the model (default meshes/stator.msh; "
                    "meshes/stator_coarse.msh for a quick run)")
    ap.add_argument("--clamp", default="mount", help="clamped node set (default mount)")
    ap.add_argument("--boundary", default="interface", help="interface node set (default interface)")
    ap.add_argument("--modes", type=int, default=20, help="-cb_num_fixed_modes of the timed runs (default 20)")
    ap.add_argument("--runs", type=int, default=3, help="runs per path and rank count (default 3)")
    ap.add_argument("--ranks", default="1,2", help="comma-separated rank counts (default 1,2)")
    ap.add_argument("--paths", default=",".join(PATHS), help="comma-separated subset of %s" % ",".join(PATHS))
    ap.add_argument("--op4-layout", default="bigmat", choices=["bigmat", "runs"],
                    help="OP4 columns as BIGMAT sparse strings (default) or non-sparse records, one per run of "
                         "consecutive rows")
    ap.add_argument("--rtol", type=float, default=1e-8, help="relative tolerance of the frequency check")
    ap.add_argument("--omp-threads", type=int, default=1)
    ap.add_argument("--idle-limit", type=float, default=0.15,
                    help="before each run wait until at most this fraction of the CPUs is busy (default 0.15)")
    ap.add_argument("--idle-timeout", type=float, default=300, help="longest wait for an idle machine [s] (0: none)")
    ap.add_argument("--max-load", type=float, default=0.10,
                    help="a run during which other processes used more than this fraction of the CPUs is marked "
                         "disturbed and left out of the medians (default 0.10)")
    ap.add_argument("--retries", type=int, default=1,
                    help="extra runs per path and rank count allowed to replace disturbed ones (default 1)")
    ap.add_argument("--work", default=os.path.join(ROOT, "out", "bench_input"), help="generated files")
    ap.add_argument("--morse", default=os.path.join(ROOT, "build", "morse"))
    ap.add_argument("--out", default="", help="results file (default bench/results/model_input_<UTC>_<stem>.json)")
    ap.add_argument("extra", nargs="*", help="extra options for every timed morse reduce (after --)")
    a = ap.parse_args()
    a.paths = [p for p in a.paths.split(",") if p]
    bad = [p for p in a.paths if p not in PATHS]
    if bad:
        ap.error("unknown path(s) %s" % ",".join(bad))
    ranks = [int(r) for r in a.ranks.split(",")]
    a.mesh = os.path.relpath(os.path.abspath(a.mesh), ROOT) if os.path.exists(a.mesh) else a.mesh
    if not os.path.exists(os.path.join(ROOT, a.mesh)):
        ap.error("mesh %s not found" % a.mesh)
    a.mesh = os.path.join(ROOT, a.mesh)
    stem = os.path.splitext(os.path.basename(a.mesh))[0]
    if not os.path.exists(a.morse):
        log("model_input_bench: %s missing, running run/build" % a.morse)
        subprocess.run([os.path.join(ROOT, "run", "build")], check=True)
    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H%M%SZ")
    out_path = a.out or os.path.join(RESULTS, "model_input_%s_%s.json" % (stamp, stem))
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    os.makedirs(a.work, exist_ok=True)
    tmp = tempfile.mkdtemp(prefix="morse_model_input_bench_")
    try:
        morse = os.path.join(tmp, "morse")  # a snapshot: build/morse may be rebuilt meanwhile
        shutil.copy2(a.morse, morse)
        binary_mtime = datetime.datetime.fromtimestamp(os.path.getmtime(a.morse), datetime.timezone.utc) \
            .strftime("%Y-%m-%dT%H:%M:%SZ")
        log("model_input_bench: %s, paths %s, ranks %s, %d run(s); preparing inputs in %s"
            % (os.path.relpath(a.mesh, ROOT), ",".join(a.paths), a.ranks, a.runs, os.path.relpath(a.work, ROOT)))
        try:
            model, prep = prepare(a, morse, a.work, stem)
        except RuntimeError as e:
            sys.stderr.write("model_input_bench: preparation failed: %s\n" % e)
            return 2
        for k, v in prep["seconds"].items():
            log("  prep %-22s %8.1f s" % (k, v))
        paths = [p for p in a.paths if p in model]

        samples = {p: {nr: [] for nr in ranks} for p in paths}
        failed, checks = [], []
        ref = {"se": None, "file": None}
        attempts = {(p, nr): 0 for p in paths for nr in ranks}

        def one_run(p, nr, k):
            se = os.path.join(a.work, "se_%s_np%d.h5" % (p, nr))
            if os.path.exists(se):
                os.remove(se)
            args = [morse, "reduce"] + model[p] + ["-cb_num_fixed_modes", str(a.modes), "-out", se] + a.extra
            busy = wait_idle(a.idle_limit, a.idle_timeout) if a.idle_timeout > 0 else cpu_busy()
            attempts[(p, nr)] += 1
            r, cmd, err = run_morse(args, nr, tmp, a.omp_threads)
            if r is None:
                failed.append({"path": p, "ranks": nr, "run": k, "command": " ".join(cmd), "error": err})
                sys.stderr.write("model_input_bench: %s np%d run %d FAILED: %s\n%s\n" % (p, nr, k, " ".join(cmd), err))
                return
            stdout, stderr = r.pop("stdout"), r.pop("stderr")
            s = parse_run(stdout, p)
            s.update(r)
            s["run"] = k
            s["cpu_busy_before"] = busy
            s["disturbed"] = r["foreign_cpu_fraction"] is not None and r["foreign_cpu_fraction"] > a.max_load
            s["stderr_tail"] = stderr[-2000:] if stderr.strip() else ""
            se_data = read_se(se)
            if ref["se"] is None and p == "msh":
                ref["se"], ref["file"] = se_data, "msh np%d run %d" % (nr, k)
            if ref["se"] is None:  # msh not run: the first run is the reference
                ref["se"], ref["file"] = se_data, "%s np%d run %d" % (p, nr, k)
            c = compare(ref["se"], se_data, a.rtol)
            c.update({"path": p, "ranks": nr, "run": k})
            checks.append(c)
            s["check"] = c
            samples[p][nr].append(s)
            g = s["groups"]
            log("  %-5s np%d run %d: input %7.3f s, CB %7.3f s, total %7.3f s, mpiexec %7.3f s, peak %6.0f MB/rank, "
                "other load %s, check %s%s" % (
                    p, nr, k, g["input"], g["cb"], g["total"], s["process_wall"], s["peak_mb_per_rank"] or 0,
                    "%.0f%%" % (100 * s["foreign_cpu_fraction"]) if s["foreign_cpu_fraction"] is not None else "?",
                    "ok (%.1e, %.1e)" % (c["fixed_hz"].get("max_rel_diff", -1), c["rom_hz"].get("max_rel_diff", -1))
                    if c["pass"] else "MISMATCH %s" % json.dumps(c),
                    " -> DISTURBED, not in the medians" if s["disturbed"] else ""))
            with open(out_path + ".partial", "w") as f:
                json.dump({"samples": {q: {str(n): v for n, v in d.items()} for q, d in samples.items()}}, f)

        # The msh path first in every round (it is the reference of the check), then the others;
        # rank counts interleaved so that a disturbance hits every path alike.
        order = (["msh"] if "msh" in paths else []) + [p for p in paths if p != "msh"]
        for k in range(1, a.runs + 1):
            for p in order:
                for nr in ranks:
                    one_run(p, nr, k)

        def clean(p, nr):
            return [s for s in samples[p][nr] if not s["disturbed"]]

        while True:
            todo = [(p, nr) for p in order for nr in ranks
                    if len(clean(p, nr)) < a.runs and samples[p][nr] and attempts[(p, nr)] < a.runs + a.retries]
            if not todo:
                break
            for p, nr in todo:
                one_run(p, nr, attempts[(p, nr)] + 1)

        per_path, speedup = {}, {}
        for p in paths:
            per_path[p] = {}
            for nr in ranks:
                ss = samples[p][nr]
                if not ss:
                    continue
                use = clean(p, nr) or ss
                d = summarize(use)
                d["disturbed_runs"] = len(ss) - len(clean(p, nr))
                d["medians_include_disturbed_runs"] = not clean(p, nr)
                d["check_pass"] = all(s["check"]["pass"] for s in ss)
                d["check_max_rel_diff_fixed_hz"] = max(s["check"]["fixed_hz"].get("max_rel_diff", float("inf"))
                                                       for s in ss)
                d["check_max_rel_diff_rom_hz"] = max(s["check"]["rom_hz"].get("max_rel_diff", float("inf"))
                                                     for s in ss)
                d["samples"] = ss
                per_path[p][str(nr)] = d
            for nr in ranks:
                d, m = per_path[p].get(str(nr)), per_path.get("msh", {}).get(str(nr))
                if d and m:
                    d["input_ratio_to_msh"] = d["group_seconds_median"]["input"] / m["group_seconds_median"]["input"]
                    d["total_ratio_to_msh"] = d["group_seconds_median"]["total"] / m["group_seconds_median"]["total"]
            if per_path[p].get("1") and per_path[p].get("2"):
                i1 = per_path[p]["1"]["group_seconds_median"]["input"]
                i2 = per_path[p]["2"]["group_seconds_median"]["input"]
                speedup[p] = i1 / i2 if i2 else None
        first = next((s for p in order for nr in ranks for s in samples[p][nr]), {})
        sizes = {k: first.get(k) for k in ("free_dofs", "clamped_dofs", "boundary_dofs", "boundary_nodes",
                                           "fixed_modes", "reduced_size")}
        mtx_run = next((s for p in ("mtx", "petsc", "op4") if p in samples for nr in ranks for s in samples[p][nr]),
                       None)
        if mtx_run:
            sizes["matrix_entries_K"] = mtx_run.get("matrix_entries_K")
            sizes["matrix_entries_M"] = mtx_run.get("matrix_entries_M")
        all_pass = bool(checks) and all(c["pass"] for c in checks)
        res = {"benchmark": "model_input", "date_utc": stamp, "mesh": os.path.relpath(a.mesh, ROOT),
               "clamp": a.clamp, "boundary": a.boundary, "modes": a.modes, "runs": a.runs, "ranks": ranks,
               "paths": a.paths, "skipped": prep["skipped"], "extra_options": a.extra,
               "command": "mpiexec --oversubscribe --bind-to none -n R morse reduce <model options> "
                          "-cb_num_fixed_modes %d -out out/bench_input/se_<path>_npR.h5 %s"
                          % (a.modes, " ".join(a.extra)),
               "model_options": {p: [os.path.relpath(x, ROOT) if x.startswith(ROOT) else x for x in v]
                                 for p, v in model.items()},
               "input_stages": {"mesh": MESH_INPUT_STAGES, "matrices": MATRIX_INPUT_STAGES,
                                "ReadMatrix_1, ReadMatrix_2": "K, M; inside ReadMatrices"},
               "nested_stages": NESTED_IN,
               "groups": {"input": "the input stages", "cb": "every other stage but Write (nested ones not "
                          "added again)", "write": "Write", "outside_stages": "total (wall) minus the top-level "
                          "stages"},
               "sizes": sizes, "preparation": prep,
               "check": {"reference": ref["file"], "rtol": a.rtol, "all_pass": all_pass, "runs": checks},
               "per_path": per_path, "input_speedup_1_to_2": speedup, "failed_runs": failed,
               "environment": {"host": platform.node(), "cpus": os.cpu_count(), "omp_threads": a.omp_threads,
                               "mpiexec": "--oversubscribe --bind-to none", "extra_env": EXTRA_ENV,
                               "binary_mtime_utc": binary_mtime, "blas": blas_info(morse), "git": git_info(),
                               "idle_limit": a.idle_limit, "max_load": a.max_load}}
        os.makedirs(os.path.dirname(os.path.abspath(out_path)), exist_ok=True)
        with open(out_path, "w") as f:
            json.dump(res, f, indent=1)
        if os.path.exists(out_path + ".partial"):
            os.remove(out_path + ".partial")
        print_table(res)
        if not all_pass:
            log("model_input_bench: CHECK FAILED: a superelement differs from the %s one (rtol %g); see "
                "check.runs in the JSON" % (ref["file"], a.rtol))
        else:
            log("model_input_bench: all %d superelements agree with %s (frequencies to %g relative, boundary "
                "DOFs identical)" % (len(checks), ref["file"], a.rtol))
        log("model_input_bench: wrote %s" % os.path.relpath(out_path, os.getcwd()))
        if failed:
            return 2
        return 0 if all_pass else 1
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
