#!/usr/bin/python3
"""Mesh I/O benchmark: the generators and the readers on ~200k-node meshes.

Times (median of --runs):
  * `morse mesh box` (hex20, ~200k nodes): generate + write Gmsh 4.1
  * `morse mesh blade` refined to ~200k nodes: generate + write
  * `morse mesh info` on the box .msh (Gmsh reader + METIS + scatter) and on the same mesh as an
    Abaqus/CalculiX .inp deck (C3D20, written by this script), at 1 and 2 ranks
Writes bench/results/mesh_io_<date>.json and prints a table. Issue target: seconds, not minutes.
"""
import argparse, datetime, json, os, re, statistics, subprocess, sys, tempfile, time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MORSE = os.path.join(ROOT, "build", "morse")
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
           OMPI_MCA_rmaps_base_oversubscribe="1", OPENBLAS_NUM_THREADS="1")

# Abaqus C3D20 mid-edge order as vertex pairs; morse (Gmsh) hex20 order from docs/theory.
ABQ_EDGES = [(0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4), (0, 4), (1, 5), (2, 6), (3, 7)]
GMSH_EDGES = [(0, 1), (0, 3), (0, 4), (1, 2), (1, 5), (2, 3), (2, 6), (3, 7), (4, 5), (4, 7), (5, 6), (6, 7)]


def run(cmd):
    t0 = time.perf_counter()
    out = subprocess.run(cmd, env=ENV, capture_output=True, text=True)
    dt = time.perf_counter() - t0
    if out.returncode != 0:
        sys.exit(f"failed: {' '.join(cmd)}\n{out.stdout}\n{out.stderr}")
    return dt, out.stdout


def stage(stdout, name):
    m = re.search(rf"^\s+{name}\s+([0-9.]+)\s+([0-9.]+)", stdout, re.M)
    return (float(m.group(1)), float(m.group(2))) if m else (None, None)


def msh_to_inp(msh, inp):
    """Converts a morse-written hex20 Gmsh 4.1 file into a C3D20 deck with an NSET."""
    lines = open(msh).read().split("\n")
    i = lines.index("$Nodes")
    nblocks, nnodes = int(lines[i + 1].split()[0]), int(lines[i + 1].split()[1])
    k = i + 2
    nodes = []
    for _ in range(nblocks):
        _, _, _, n = map(int, lines[k].split())
        tags = lines[k + 1:k + 1 + n]
        xyz = lines[k + 1 + n:k + 1 + 2 * n]
        nodes += list(zip(tags, xyz))
        k += 1 + 2 * n
    i = lines.index("$Elements")
    nblocks = int(lines[i + 1].split()[0])
    k = i + 2
    elems = []
    for _ in range(nblocks):
        dim, _, etype, n = map(int, lines[k].split())
        if dim == 3 and etype == 17:
            elems += [lines[k + 1 + j].split() for j in range(n)]
        k += 1 + n
    perm = list(range(8)) + [8 + GMSH_EDGES.index(tuple(sorted(e))) for e in ABQ_EDGES]
    with open(inp, "w") as f:
        f.write("*HEADING\nmorse mesh_io_bench deck\n*NODE, NSET=NALL\n")
        for t, x in nodes:
            f.write(f"{t}, {', '.join(x.split())}\n")
        f.write("*ELEMENT, TYPE=C3D20, ELSET=EALL\n")
        for e in elems:
            c = [e[1 + p] for p in perm]
            f.write(f"{e[0]}, {', '.join(c[:15])},\n{', '.join(c[15:])}\n")
        f.write("*MATERIAL, NAME=STEEL\n*ELASTIC\n2.1e11, 0.3\n*DENSITY\n7800.\n*SOLID SECTION, ELSET=EALL, MATERIAL=STEEL\n")
    return len(nodes), len(elems)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=3)
    args = ap.parse_args()
    if not os.path.exists(MORSE):
        subprocess.run([os.path.join(ROOT, "run", "build")], check=True)
    tmp = tempfile.mkdtemp(prefix="morse_mesh_io_")
    res = {"benchmark": "mesh_io", "date_utc": datetime.datetime.utcnow().strftime("%Y-%m-%dT%H%M%SZ"), "runs": args.runs}
    box = os.path.join(tmp, "box.msh")
    box_cmd = [MORSE, "mesh", "box", "-box_type", "hex20", "-box_lx", "2", "-box_ly", "0.5", "-box_lz", "0.5",
               "-box_nx", "96", "-box_ny", "24", "-box_nz", "20", "-out", box]
    blade = os.path.join(tmp, "blade.msh")
    blade_cmd = [MORSE, "mesh", "blade", "-blade_n_chord", "80", "-blade_n_thick", "8", "-blade_n_span", "60", "-out", blade]
    gen = {}
    for name, cmd in (("box_hex20", box_cmd), ("blade_wedge15", blade_cmd)):
        times, last = [], ""
        for _ in range(args.runs):
            dt, last = run(cmd)
            times.append(dt)
        m = re.search(r"wrote \S+: (\d+) nodes, (\d+) elements", last)
        gen[name] = {"seconds_median": statistics.median(times), "samples": times,
                     "nodes": int(m.group(1)), "elements": int(m.group(2)),
                     "file_mb": os.path.getsize(cmd[-1]) / 2**20}
    res["generate_and_write"] = gen
    inp = os.path.join(tmp, "box.inp")
    t0 = time.perf_counter()
    nn, ne = msh_to_inp(box, inp)
    res["inp_conversion_python_seconds"] = time.perf_counter() - t0
    read = {}
    for fmt, path in (("gmsh", box), ("abaqus", inp)):
        for np_ in (1, 2):
            rd, wall = [], []
            for _ in range(args.runs):
                dt, out = run(["mpirun", "-n", str(np_), MORSE, "mesh", "info", "-mesh", path])
                rd.append(stage(out, "ReadDistribute")[0])
                wall.append(dt)
                assert "0 inverted elements" in out, out
            read[f"{fmt}_np{np_}"] = {"read_distribute_seconds_median": statistics.median(rd),
                                      "process_wall_median": statistics.median(wall), "samples": rd,
                                      "nodes": nn, "elements": ne, "file_mb": os.path.getsize(path) / 2**20}
    res["read_distribute"] = read
    worst = max([v["seconds_median"] for v in gen.values()] + [v["read_distribute_seconds_median"] for v in read.values()])
    res["target"] = {"limit_seconds": 10.0, "worst_seconds": worst, "pass": worst < 10.0}
    os.makedirs(os.path.join(ROOT, "bench", "results"), exist_ok=True)
    out = os.path.join(ROOT, "bench", "results", f"mesh_io_{res['date_utc']}.json")
    json.dump(res, open(out, "w"), indent=1)
    print(f"{'case':28s} {'nodes':>9s} {'elements':>9s} {'MB':>7s} {'median [s]':>11s}")
    for k, v in gen.items():
        print(f"generate+write {k:13s} {v['nodes']:9d} {v['elements']:9d} {v['file_mb']:7.1f} {v['seconds_median']:11.3f}")
    for k, v in read.items():
        print(f"read+distribute {k:12s} {v['nodes']:9d} {v['elements']:9d} {v['file_mb']:7.1f} {v['read_distribute_seconds_median']:11.3f}")
    print(f"worst {worst:.2f} s (target < 10 s): {'PASS' if worst < 10 else 'FAIL'}; wrote {out}")


if __name__ == "__main__":
    main()
