#!/usr/bin/env bash
# Case chain of the "bring your own model" inputs on the generated box (clamped at x0, boundary x1):
#  - reduce writes its free-DOF K, M and DOF map (-matrices_write, MatrixMarket and PETSc binary);
#    reduce and select from those matrices give the superelement of the mesh path: the same
#    fixed-interface and superelement frequencies, the same boundary DOFs and Guyan block;
#  - the unclamped matrices with -clamp of a DOF-map row set give it too;
#  - -matrices_C is projected like M (C = M gives /rom/C = /rom/M);
#  - a Nastran deck written by `morse mesh box -out box.bdf` gives the same frequencies;
#  - modes from the matrices give the frequencies and mode shapes (per row, labelled by /dofs) of
#    modes from the mesh;
#  - bad input (nonsymmetric K, size mismatch, a DOF map with a row too many, a basis request
#    without a mesh, matrices given to a command that needs a mesh) fails cleanly and leaves no
#    file.
# usage: case_matrices_chain.sh DIR MORSE NP BOX MPIEXEC [MPI FLAGS...] -- [MATERIAL OPTIONS...]
set -euo pipefail
. "$(dirname "$0")/case_common.sh" "$@"
cb=(-boundary x1 -cb_num_fixed_modes 6)
run reduce "${model[@]}" "${cb[@]}" -matrices_write "$d/box" -out "$d/se_mesh.h5"
run reduce "${model[@]}" "${cb[@]}" -matrices_write "$d/boxp" -matrices_write_format petsc -out "$d/se_mesh2.h5"
run reduce -matrices_K "$d/box_K.mtx" -matrices_M "$d/box_M.mtx" -matrices_dofmap "$d/box_dofmap.txt" "${cb[@]}" \
  -out "$d/se_mtx.h5"
run reduce -matrices_K "$d/boxp_K.petsc" -matrices_M "$d/boxp_M.petsc" -matrices_dofmap "$d/boxp_dofmap.txt" \
  "${cb[@]}" -out "$d/se_petsc.h5"
# Unclamped matrices (clamp x0 through the DOF map's row set), from a model with no clamp.
run reduce -mesh "$box" "${material[@]}" -boundary x0 -cb_num_fixed_modes 0 -matrices_write "$d/free" \
  -out "$d/se_free.h5"
run reduce -matrices_K "$d/free_K.mtx" -matrices_M "$d/free_M.mtx" -matrices_dofmap "$d/free_dofmap.txt" \
  -clamp x0 "${cb[@]}" -out "$d/se_clamp.h5"
# select from matrices against select from the mesh.
sel=(-boundary x1 -cb_num_fixed_modes 10 -select_method eim,lpf -select_num_modes 4)
run select "${model[@]}" "${sel[@]}" -out "$d/sel_mesh.h5"
run select -matrices_K "$d/box_K.mtx" -matrices_M "$d/box_M.mtx" -matrices_dofmap "$d/box_dofmap.txt" "${sel[@]}" \
  -out "$d/sel_mtx.h5"
# A damping matrix is projected like the others: with C = M, /rom/C is /rom/M (reduce and select).
run reduce -matrices_K "$d/box_K.mtx" -matrices_M "$d/box_M.mtx" -matrices_C "$d/box_M.mtx" \
  -matrices_dofmap "$d/box_dofmap.txt" "${cb[@]}" -out "$d/se_c.h5"
run select -matrices_K "$d/box_K.mtx" -matrices_M "$d/box_M.mtx" -matrices_C "$d/box_M.mtx" \
  -matrices_dofmap "$d/box_dofmap.txt" "${sel[@]}" -out "$d/sel_c.h5"
# Nastran bulk data written by morse.
run mesh box -box_type hex8 -box_lx 4 -box_ly 1 -box_lz 1 -box_nx 4 -box_ny 1 -box_nz 1 "${material[@]}" \
  -nastran_spc x0 -nastran_aset x1 -out "$d/box.bdf"
run reduce -mesh "$d/box.bdf" -clamp '*BOUNDARY' -boundary ASET -cb_num_fixed_modes 6 -out "$d/se_bdf.h5"
/usr/bin/python3 - "$d" <<'PY' || [ $? -eq 127 ]
import sys, h5py, numpy as np
d = sys.argv[1]
ref = h5py.File(f"{d}/se_mesh.h5", "r")
def close(a, b, tol, what):
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape, (what, a.shape, b.shape)
    err = np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300)
    assert err < tol, (what, err)
for name in ["se_mtx", "se_petsc", "se_clamp", "se_bdf"]:
    f = h5py.File(f"{d}/{name}.h5", "r")
    close(f["/cb/fixed_interface/frequencies_hz"][:], ref["/cb/fixed_interface/frequencies_hz"][:], 1e-10, name)
    close(f["/rom/frequencies_hz"][:], ref["/rom/frequencies_hz"][:], 1e-10, name)
    assert (f["/rom/boundary_dofs"][:] == ref["/rom/boundary_dofs"][:]).all(), name
    nb = ref["/rom"].attrs["n_boundary_dofs"]
    close(f["/rom/K"][:nb, :nb], ref["/rom/K"][:nb, :nb], 1e-9, name + " K_bb")
    close(f["/rom/M"][:nb, :nb], ref["/rom/M"][:nb, :nb], 1e-9, name + " M_bb")
    if name != "se_bdf":
        assert "/dofs/node" in f and "/mesh" not in f, name
bd = ref["/rom/boundary_dofs"][:]
assert bd.shape == (12, 2) and set(bd[:, 1]) == {1, 2, 3}
a, b = h5py.File(f"{d}/sel_mesh.h5", "r"), h5py.File(f"{d}/sel_mtx.h5", "r")
close(b["/select/fom/frequencies_hz"][:], a["/select/fom/frequencies_hz"][:], 1e-10, "select fom")
close(b["/rom/frequencies_hz"][:], a["/rom/frequencies_hz"][:], 1e-9, "select rom")
for name in ["se_c", "sel_c"]:
    f = h5py.File(f"{d}/{name}.h5", "r")
    close(f["/rom/C"][:], f["/rom/M"][:], 1e-12, name + " C = M")
PY
# Bad input.
/usr/bin/python3 - "$d" <<'PY'
import sys
d = sys.argv[1]
lines = open(f"{d}/box_K.mtx").read().splitlines()
hdr = [l for l in lines if l.startswith("%")]
size = [l for l in lines if not l.startswith("%")][0]
ents = [l for l in lines if not l.startswith("%")][1:]
n = int(size.split()[0])
# general storage, one off-diagonal pair made unequal
out = [hdr[0].replace("symmetric", "general"), f"{n} {n} {2 * len(ents) - sum(1 for e in ents if e.split()[0] == e.split()[1])}"]
# the largest off-diagonal entry loses its symmetry
big = max((e for e in ents if e.split()[0] != e.split()[1]), key=lambda e: abs(float(e.split()[2])))
for e in ents:
    i, j, v = e.split()
    out.append(e)
    if i != j:
        w = float(v) * (1.5 if e == big else 1.0)
        out.append(f"{j} {i} {w!r}")
open(f"{d}/nonsym_K.mtx", "w").write("\n".join(out) + "\n")
m = open(f"{d}/box_dofmap.txt").read()
open(f"{d}/long_dofmap.txt", "w").write(m + "999 1\n")
PY
mtx=(-matrices_K "$d/box_K.mtx" -matrices_M "$d/box_M.mtx" -matrices_dofmap "$d/box_dofmap.txt")
expect_error 'nonsym_K.mtx is not symmetric' "$d/bad1.h5" reduce -matrices_K "$d/nonsym_K.mtx" \
  -matrices_M "$d/box_M.mtx" -matrices_dofmap "$d/box_dofmap.txt" "${cb[@]}"
expect_error 'size mismatch: -matrices_K .*box_K.mtx is 48 x 48 but -matrices_M .*free_M.mtx is 60 x 60' "$d/bad2.h5" \
  reduce -matrices_K "$d/box_K.mtx" -matrices_M "$d/free_M.mtx" "${cb[@]}"
expect_error 'long_dofmap.txt:50: this line names row 49 but the matrices have only 48 rows' "$d/bad3.h5" \
  reduce -matrices_K "$d/box_K.mtx" -matrices_M "$d/box_M.mtx" -matrices_dofmap "$d/long_dofmap.txt" "${cb[@]}"
expect_error '-cb_write_basis writes nodal mode shapes of a mesh' "$d/bad4.h5" reduce "${mtx[@]}" "${cb[@]}" -cb_write_basis
expect_error 'morse static needs a mesh: its nonlinear (SVK) forces' "$d/bad5.h5" static "${mtx[@]}" \
  -load_sets x1 -load_x1_dir y -load_x1_amplitude 1
expect_error "boundary set 'x9' is not a row set" "$d/bad6.h5" reduce "${mtx[@]}" -boundary x9 -cb_num_fixed_modes 2
expect_error 'give either -mesh or -matrices_K' "$d/bad7.h5" reduce "${model[@]}" "${mtx[@]}" "${cb[@]}"
# modes from the matrices against modes from the mesh.
run modes "${model[@]}" -modes_nev 6 -out "$d/modes_mesh.h5"
run modes "${mtx[@]}" -modes_nev 6 -out "$d/modes_mtx.h5"
/usr/bin/python3 - "$d" <<'PY' || [ $? -eq 127 ]
import sys, h5py, numpy as np
d = sys.argv[1]
a, b = h5py.File(f"{d}/modes_mesh.h5", "r"), h5py.File(f"{d}/modes_mtx.h5", "r")
fa, fb = a["/fom/frequencies_hz"][:], b["/fom/frequencies_hz"][:]
assert fa.shape == fb.shape == (6,), (fa.shape, fb.shape)
assert np.max(np.abs(fa - fb) / fa) < 1e-10, (fa, fb)
assert "/mesh" not in b and "/dofs/node" in b
node, comp = b["/dofs/node"][:], b["/dofs/component"][:]
va, vb = a["/fom/mode_shapes"][:], b["/fom/mode_shapes"][:]
assert vb.shape == (6, len(node)), vb.shape
index = {int(i): k for k, i in enumerate(a["/mesh/node_ids"][:])}
for j in range(6):
    ref = np.array([va[j, index[int(n)], int(c) - 1] for n, c in zip(node, comp)])
    s = np.sign(ref @ vb[j])
    assert np.max(np.abs(s * vb[j] - ref)) < 1e-6 * np.max(np.abs(ref)), ("mode", j)
PY
echo "case_matrices_chain: OK"
