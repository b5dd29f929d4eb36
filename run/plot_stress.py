#!/usr/bin/python3
"""Von Mises stress snapshot of a solid mesh (seed paper Fig. 25 style: compressor blade at the time of
the maximal tip displacement, linear vs nonlinear).

usage: /usr/bin/python3 run/plot_stress.py STRESS.h5 [STRESS2.h5] [--out PNG] [--title T] [--labels A,B]
                                           [--view ELEV,AZIM] [--field nodal|element] [--scale S]

Reads /mesh (coordinates, node_ids, topology: XDMF "Mixed" list of type code + 0-based node indices in
VTK order; tet4/10, wedge6/15, hex8/20) and /stress (displacement [1][n][3] m, von_mises [1][n] Pa,
von_mises_element [1][n_elements] Pa, attributes time [s], measure, max_von_mises [Pa]) of one to four
stress files. Needs numpy, h5py, matplotlib (Agg).
Writes PNG (default: the first file with .h5 replaced by .png): one 3-D panel per file showing the
boundary faces (faces of exactly one element, straight-sided through the corner nodes) of the mesh
deformed by displacement x scale (default: the largest displacement of all files drawn at 5% of the
bounding-box diagonal; the factor is written in each panel), coloured by the mean nodal von Mises
stress of the face corners (--field nodal, default) or by the owning element's value (--field
element), on one colour scale 0..max of all panels [MPa]. Panels are titled with --labels (default
"<measure>, t = <time> ms") and the maximal nodal value and its node id, marked by a black star.
Prints per file the maximal nodal von Mises stress, its node id and coordinates and the attribute
max_von_mises (quadrature-point maximum). Exits non-zero if a file or a dataset is missing.
"""
import argparse
import os
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.cm import ScalarMappable  # noqa: E402
from matplotlib.colors import Normalize  # noqa: E402
from matplotlib.ticker import MaxNLocator  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402

CMAP = "turbo"
MAX_EDGED_FACES = 5000  # finer meshes are drawn without black element edges
DEFORM_FRACTION = 0.05  # default: largest displacement drawn at this fraction of the bbox diagonal
# XDMF type code -> (nodes per element, corner-index faces in VTK order)
TRI = [(0, 1, 2), (0, 1, 3), (1, 2, 3), (0, 2, 3)]
HEX = [(0, 1, 2, 3), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]
WEDGE = [(0, 1, 2), (3, 4, 5), (0, 1, 4, 3), (1, 2, 5, 4), (2, 0, 3, 5)]
CELLS = {6: (4, TRI), 38: (10, TRI), 8: (6, WEDGE), 40: (15, WEDGE), 9: (8, HEX), 48: (20, HEX)}


def fail(msg):
    sys.exit(f"plot_stress: {msg}")


def attr(attrs, key, default=None):
    if key not in attrs:
        return default
    v = np.ravel(attrs[key])[0]
    return v.decode() if isinstance(v, bytes) else v


def load(path, field):
    """Mesh, displacement, nodal and element von Mises and /stress attributes of PATH as a dict."""
    if not os.path.isfile(path):
        fail(f"{path}: no such file")
    names = ["mesh/coordinates", "mesh/node_ids", "mesh/topology", "stress/displacement", "stress/von_mises"]
    if field == "element":
        names.append("stress/von_mises_element")
    try:
        with h5py.File(path, "r") as f:
            missing = [n for n in names if n not in f]
            if missing:
                fail(f"{path}: missing dataset /{', /'.join(missing)}")
            d = {n.split("/")[1]: f[n][()] for n in names}
            a = f["stress"].attrs
            d["measure"] = str(attr(a, "measure", os.path.basename(path)))
            d["time"] = attr(a, "time")
            d["max_von_mises"] = attr(a, "max_von_mises")
    except OSError as e:
        fail(f"{path} is not an HDF5 file ({e})")
    n = len(d["coordinates"])
    try:
        d["displacement"] = np.asarray(d["displacement"], float).reshape(-1, n, 3)[0]
        d["von_mises"] = np.asarray(d["von_mises"], float).reshape(-1, n)[0]
    except ValueError:
        fail(f"{path}: /stress/displacement or /stress/von_mises does not match {n} mesh nodes")
    d["faces"], d["owner"], n_elements = boundary_faces(np.asarray(d["topology"], np.int64), path)
    if field == "element":
        ve = np.asarray(d["von_mises_element"], float).ravel()
        if len(ve) < n_elements:
            fail(f"{path}: /stress/von_mises_element has {len(ve)} values for {n_elements} elements")
        d["von_mises_element"] = ve[:n_elements]
    d["path"] = path
    return d


def boundary_faces(topo, path):
    """(faces [m][4] corner indices, triangles with the last corner repeated; owner element [m]; n_elements)."""
    starts = {}  # type code -> element indices, start positions in topo
    i = e = 0
    while i < len(topo):
        code = int(topo[i])
        if code not in CELLS:
            fail(f"{path}: unsupported XDMF element type {code} in /mesh/topology")
        starts.setdefault(code, ([], []))
        starts[code][0].append(e)
        starts[code][1].append(i + 1)
        i += 1 + CELLS[code][0]
        e += 1
    if i != len(topo):
        fail(f"{path}: /mesh/topology is truncated")
    faces, keys, owner = [], [], []
    for code, (elems, pos) in starts.items():
        nodes = topo[np.asarray(pos)[:, None] + np.arange(CELLS[code][0])]
        for face in CELLS[code][1]:
            c = nodes[:, list(face) + [face[-1]] * (4 - len(face))]
            faces.append(c)
            k = np.sort(nodes[:, list(face)], axis=1)
            keys.append(k if len(face) == 4 else np.hstack([np.full((len(k), 1), -1), k]))
            owner.append(np.asarray(elems))
    faces, keys, owner = np.concatenate(faces), np.concatenate(keys), np.concatenate(owner)
    _, first, count = np.unique(keys, axis=0, return_index=True, return_counts=True)
    b = np.sort(first[count == 1])
    return faces[b], owner[b], e


def face_values(r, field):
    if field == "element":
        return r["von_mises_element"][r["owner"]]
    f, v = r["faces"], r["von_mises"]
    tri = f[:, 2] == f[:, 3]
    return np.where(tri, v[f[:, :3]].mean(axis=1), v[f].mean(axis=1))


def summary(r, label):
    i = r["imax"]
    x = r["coordinates"][i]
    q = r["max_von_mises"]
    q = "n/a" if q is None else f"{q / 1e6:.6g} MPa"
    print(f"{label} ({r['path']}): max nodal von Mises {r['von_mises'][i] / 1e6:.6g} MPa at node {r['node_ids'][i]} "
          f"({x[0]:.6g}, {x[1]:.6g}, {x[2]:.6g}) m; max_von_mises (quadrature points) {q}")


def plot(runs, labels, out, title, view, field, scale, vmax):
    fig = plt.figure(figsize=(6 * len(runs) + 1, 5.5))
    top = max(max(r["values"].max(), r["von_mises"].max()) for r in runs) / 1e6
    norm = Normalize(0, vmax if vmax else top)
    sm = ScalarMappable(norm, CMAP)
    axes = []
    for k, (r, label) in enumerate(zip(runs, labels)):
        ax = fig.add_subplot(1, len(runs), k + 1, projection="3d")
        ax.computed_zorder = False  # keep the max marker above the surface
        ax.set_facecolor("none")  # do not hide the axis labels of the panel on the left
        x = r["coordinates"] + scale * r["displacement"]
        colours = sm.to_rgba(r["values"] / 1e6)
        pc = Poly3DCollection(x[r["faces"]], facecolors=colours, linewidths=0.2,
                              edgecolors="k" if len(colours) <= MAX_EDGED_FACES else colours)
        ax.add_collection3d(pc)
        i = r["imax"]
        ax.scatter(*x[i], marker="*", s=120, c="k", depthshade=False, zorder=10)
        lo, hi = x.min(axis=0), x.max(axis=0)
        ax.set(xlim=(lo[0], hi[0]), ylim=(lo[1], hi[1]), zlim=(lo[2], hi[2]))
        span = np.maximum(hi - lo, 1e-3 * (hi - lo).max())
        ax.set_box_aspect(span)
        for axis, s, name in zip((ax.xaxis, ax.yaxis, ax.zaxis), span / span.max(), "xyz"):
            axis.set_major_locator(MaxNLocator(max(2, round(6 * s))))  # no crowded ticks on thin sides
            axis.set_label_text(f"{name} [m]")
        ax.view_init(*view)
        ax.set_title(f"{label}\nmax {r['von_mises'][i] / 1e6:.4g} MPa at node {r['node_ids'][i]} (\u2605)\n"
                     f"displacement \u00d7 {scale:.4g}, {field} values", fontsize=10)
        axes.append(ax)
    fig.colorbar(sm, ax=axes, shrink=0.6, pad=0.2 / len(runs), extend="max" if vmax and vmax < top else "neither",
                 label="von Mises stress [MPa]" + (f" (clipped at {vmax:g})" if vmax and vmax < top else ""))
    if title:
        fig.suptitle(title)
    fig.savefig(out, dpi=150, bbox_inches="tight")
    plt.close(fig)
    print(f"wrote {out}")


def main():
    p = argparse.ArgumentParser(usage="%(prog)s STRESS.h5 [STRESS2.h5] [options]",
                                description=__doc__.split("\n\n")[0])
    p.add_argument("files", nargs="+", metavar="STRESS.h5", help="one to four morse stress files (one panel each)")
    p.add_argument("--out", help="output PNG (default: first file with .h5 replaced by .png)")
    p.add_argument("--title", help="figure title")
    p.add_argument("--labels", help="comma-separated panel labels (default: measure and time of each file)")
    p.add_argument("--view", default="20,-60", help="ELEV,AZIM of the 3-D view in degrees (default 20,-60)")
    p.add_argument("--field", choices=("nodal", "element"), default="nodal",
                   help="colour faces by the mean of their corner nodes (default) or by their element")
    p.add_argument("--scale", type=float, help="displacement scale factor (default: max displacement at 5%% "
                                               "of the bounding-box diagonal)")
    p.add_argument("--vmax", type=float, help="top of the colour scale [MPa] (default: the largest value); "
                   "larger values are drawn in the top colour, e.g. to see past a singular node")
    a = p.parse_args()
    if len(a.files) > 4:
        p.error("at most four stress files")
    try:
        view = tuple(float(v) for v in a.view.split(","))
        assert len(view) == 2
    except (ValueError, AssertionError):
        p.error("--view takes ELEV,AZIM")
    runs = [load(f, a.field) for f in a.files]
    labels = a.labels.split(",") if a.labels else []
    if len(labels) not in (0, len(runs)):
        p.error(f"--labels needs {len(runs)} comma-separated label(s)")
    for k, r in enumerate(runs):
        r["imax"] = int(np.argmax(r["von_mises"]))
        r["values"] = face_values(r, a.field)
        if not a.labels:
            t = r["time"]
            labels.append(r["measure"] + ("" if t is None else f", t = {float(t) * 1e3:.3f} ms"))
    scale = a.scale
    if scale is None:
        diag = max(np.linalg.norm(np.ptp(r["coordinates"], axis=0)) for r in runs)
        umax = max(np.linalg.norm(r["displacement"], axis=1).max() for r in runs)
        scale = DEFORM_FRACTION * diag / umax if umax > 0 else 0.0
    out = a.out or (a.files[0][:-3] if a.files[0].endswith(".h5") else a.files[0]) + ".png"
    plot(runs, labels, out, a.title, view, a.field, scale, a.vmax)
    for r, label in zip(runs, labels):
        summary(r, label)


if __name__ == "__main__":
    main()
