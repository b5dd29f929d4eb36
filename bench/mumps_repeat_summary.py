"""Summary step of bench/mumps_repeat.sh (standard library only, Debian's /usr/bin/python3).

    mumps_repeat_summary.py config CFG N MESH VARIANT RANKS OPTIONS   # one JSON line on stdout
    mumps_repeat_summary.py report CONFIGS.jsonl N COMPILE_COMMAND     # table + results JSON

`config` reads the N runs CFG.1 .. CFG.N (run.json: the hashes printed by mumps_repeat; vecs.bin:
K x, M x, then per sigma the solve and the MatMatSolve columns, PETSc binary) and CFG.diag (MUMPS's
ICNTL(4) = 2 output): distinct bit patterns per quantity, the number of runs in which repeating
the solve (MatMatSolve) with the same factor in the same run changed its bits, the largest difference from run 1 (max |a - a_1| / max |a_1|), MUMPS's number
of level 2 nodes, split nodes and ordering used. `report` prints the table and writes
bench/results/mumps_repeat_<UTC>.json.
"""

import json
import os
import re
import struct
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import benchlib  # noqa: E402


def read_vecs(path):
    out, data = [], open(path, "rb").read()
    pos = 0
    while pos < len(data):
        cid, n = struct.unpack(">ii", data[pos:pos + 8])
        assert cid == 1211214, "not a PETSc Vec"
        out.append(struct.unpack(">%dd" % n, data[pos + 8:pos + 8 + 8 * n]))
        pos += 8 + 8 * n
    return out


def groups(run, vecs):
    """Quantity name -> list of vectors, in the order mumps_repeat wrote them."""
    g, k = {"Kx": [vecs[0]], "Mx": [vecs[1]]}, 2
    nrhs = (len(vecs) - 2) // len(run["per_sigma"]) - 1
    for s in run["per_sigma"]:
        g["sigma=%g solve" % s["sigma"]] = [vecs[k]]
        g["sigma=%g matmatsolve" % s["sigma"]] = vecs[k + 1:k + 1 + nrhs]
        k += 1 + nrhs
    return g


def config(cfg, n, mesh, variant, ranks, options):
    runs, vecs = [], []
    for i in range(1, int(n) + 1):
        runs.append(json.loads(open("%s.%d/run.json" % (cfg, i)).read()))
        vecs.append(groups(runs[-1], read_vecs("%s.%d/vecs.bin" % (cfg, i))))
    hashes = {"Kx": [r["Kx"] for r in runs], "Mx": [r["Mx"] for r in runs]}
    in_run = {}  # per sigma: runs whose repeated solves (MatMatSolves) in the same run differed
    for j, s in enumerate(runs[0]["per_sigma"]):
        for q in ("solve", "solve_again", "matmatsolve"):
            hashes["sigma=%g %s" % (s["sigma"], q)] = [r["per_sigma"][j][q] for r in runs]
        for q in ("solve", "matmatsolve"):
            in_run["sigma=%g %s" % (s["sigma"], q)] = sum(r["per_sigma"][j][q + "_in_run_distinct"] > 1 for r in runs)
    diff = {}
    for q, ref in vecs[0].items():
        scale = max(abs(x) for v in ref for x in v) or 1.0
        diff[q] = max(abs(a - b) for run in vecs[1:] for va, vb in zip(run[q], ref) for a, b in zip(va, vb)) / scale \
            if len(vecs) > 1 else 0.0
    diag = open(cfg + ".diag").read()

    def grab(pat):
        m = re.search(pat + r"\s*=\s*(\d+)", diag)
        return int(m.group(1)) if m else None
    print(json.dumps({"mesh": mesh, "variant": variant, "ranks": int(ranks), "options": options, "runs": int(n),
                      "n_dofs": runs[0]["n"], "distinct": {q: len(set(h)) for q, h in hashes.items()},
                      "runs_with_differing_repeats_in_run": in_run, "max_rel_diff_vs_run1": diff,
                      "level2_nodes": grab(r"Number of level 2 nodes"), "split_nodes": grab(r"Number of split nodes"),
                      "ordering_used": grab(r"\(7\) Ordering option effectively used"),
                      "infog_run1": {str(s["sigma"]): s["infog"] for s in runs[0]["per_sigma"]}, "hashes": hashes}))


def report(path, n, compile_cmd):
    cfgs = [json.loads(line) for line in open(path)]
    print("distinct bit patterns over %s runs (1 = repeatable); in-run: runs whose repeated solve / MatMatSolve "
          "changed bits (per sigma); max rel. diff from run 1 over all quantities" % n)
    for c in cfgs:
        d = c["distinct"]
        print("%-17s %-12s %d rk L2 %-3s ord %-2s | %s | in-run %s | %.1e" % (
            os.path.basename(c["mesh"]), c["variant"], c["ranks"], c["level2_nodes"], c["ordering_used"],
            " ".join("%s %d" % (q.replace("sigma=", "s=").replace("matmatsolve", "mms"), k) for q, k in d.items()),
            " ".join(str(k) for k in c["runs_with_differing_repeats_in_run"].values()),
            max(c["max_rel_diff_vs_run1"].values())))
    utc = time.strftime("%Y-%m-%dT%H%M%SZ", time.gmtime())
    out = {"benchmark": "mumps_repeat", "utc": utc, "runs_per_config": int(n), "compile_command": compile_cmd,
           "quantities": "K x, M x; per sigma (A = K - sigma M, MUMPS Cholesky): MatSolve, the same MatSolve "
                         "again in the same run, a 16-column MatMatSolve; distinct = bit patterns over the runs",
           "configs": cfgs, "environment": {"git": benchlib.git_info(), "OMP_NUM_THREADS": "1",
                                            "OPENBLAS_NUM_THREADS": "1", "cpus": os.cpu_count()}}
    file = os.path.join(benchlib.RESULTS, "mumps_repeat_%s.json" % utc)
    with open(file, "w") as f:
        json.dump(out, f, indent=1)
    print("wrote", file)


if __name__ == "__main__":
    {"config": config, "report": report}[sys.argv[1]](*sys.argv[2:])
