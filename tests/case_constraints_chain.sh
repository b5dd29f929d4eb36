#!/usr/bin/env bash
# Case chain of a Nastran deck with a rigid spider (tests/data/spider_beam.bdf: a 4x1x1 CHEXA
# cantilever, RBE2 100 from grid 9001 at the tip centre to the four tip grids, a 1.5 kg CONM2 on
# 9001, ASET1 123456 9001):
#  - mesh info reports the constraints;
#  - modes: the constraints are eliminated (4 grids x 3 translations), the model's mass is the
#    steel's 7.8 kg plus the CONM2's 1.5 kg;
#  - reduce with the point as the boundary (-boundary ASET): six boundary DOFs, node 9001
#    components 1..6; its free-DOF K, M and DOF map (-matrices_write) hold the point's six rows,
#    and reduce from those matrices gives the same superelement (the matrix path takes 6-DOF
#    labels);
#  - select on the constrained deck;
#  - export: the MBDyn node 9001 at (0.4, 0.025, 0.025);
#  - bad input: element-by-element commands refuse the deck naming the constraints; a dependent
#    grid that is also clamped, and a circular MPC, fail naming the card and the grid; no file is
#    left.
# usage: case_constraints_chain.sh DIR MORSE NP BOX MPIEXEC [MPI FLAGS...] -- [MATERIAL OPTIONS...]
set -euo pipefail
. "$(dirname "$0")/case_common.sh" "$@"
deck=$(dirname "$0")/data/spider_beam.bdf
out=$(run modes -mesh "$deck" -clamp '*BOUNDARY' -modes_nev 4 -out "$d/modes.h5" 2>&1)
grep -q "constraints: 1 rigid element, 0 interpolation elements, 0 linear constraints, 1 six-DOF point; 12 DOF(s) eliminated, 6 point DOF(s) kept" <<<"$out" || { echo "$out"; exit 1; }
grep -q "mass 9.3$" <<<"$out" || { echo "mass: $out"; exit 1; }
info=$(run mesh info -mesh "$deck" 2>&1)
grep -q "constraints: 1 rigid element, 0 interpolation elements, 0 linear constraints, 1 six-DOF point" <<<"$info" ||
  { echo "mesh info: $info"; exit 1; }
cb=(-clamp '*BOUNDARY' -boundary ASET -cb_num_fixed_modes 4)
run reduce -mesh "$deck" "${cb[@]}" -matrices_write "$d/spider" -out "$d/se.h5"
run reduce -matrices_K "$d/spider_K.mtx" -matrices_M "$d/spider_M.mtx" -matrices_dofmap "$d/spider_dofmap.txt" \
  -boundary ASET -cb_num_fixed_modes 4 -out "$d/se_mtx.h5"
run select -mesh "$deck" -clamp '*BOUNDARY' -boundary ASET -cb_num_fixed_modes 8 -select_method eim \
  -select_num_modes 3 -out "$d/sel.h5"
run export -export_from "$d/se.h5" -export_format mbdyn,dmig -out "$d/se"
grep -A1 "RECORD GROUP 2" "$d/se.fem" | grep -q "^9001$"
grep -A1 "RECORD GROUP 5" "$d/se.fem" | grep -q "^0.4"
grep -q "point_rows_ok" < <(grep -c "^9001 " "$d/spider_dofmap.txt" | sed 's/^6$/point_rows_ok/')
/usr/bin/python3 - "$d" <<'PY' || [ $? -eq 127 ]
import sys, h5py, numpy as np
d = sys.argv[1]
a, b = h5py.File(f"{d}/se.h5", "r"), h5py.File(f"{d}/se_mtx.h5", "r")
bd = a["/rom/boundary_dofs"][:]
assert bd.tolist() == [[9001, c] for c in range(1, 7)], bd
# The modes' signs are conventions of each path: compare the frequencies and the boundary blocks.
nb = 6
for k, x, y in [(k, a[k][:], b[k][:]) for k in ["/rom/frequencies_hz", "/cb/fixed_interface/frequencies_hz"]] + \
        [(k + "_bb", a[k][:nb, :nb], b[k][:nb, :nb]) for k in ["/rom/K", "/rom/M"]]:
    err = np.max(np.abs(x - y)) / np.max(np.abs(x))
    assert err < 1e-9, (k, err)
assert (b["/rom/boundary_dofs"][:] == bd).all()
# The boundary mass block holds the CONM2 and the beam: its translational diagonal exceeds 1.5 kg.
M = a["/rom/M"][:]
assert all(M[i, i] > 1.5 for i in range(3)), np.diag(M)[:3]
PY
expect_error "the rigid elements, interpolation elements and MPCs of .*spider_beam.bdf are supported by modes, reduce, select and export only" \
  "$d/static.h5" static -mesh "$deck" -clamp '*BOUNDARY' -load_sets ASET -load_ASET_dir x -load_ASET_amplitude 1
sed 's/^RBE2,100,9001,123456,5,10,15,20$/RBE2,100,9001,123456,5,10,15,20,1/' "$deck" >"$d/clamped_dep.bdf"
expect_error "RBE2 100: node 1 component 1 (x) is dependent but also fixed" "$d/bad1.h5" modes -mesh "$d/clamped_dep.bdf" \
  -clamp '*BOUNDARY' -modes_nev 2
sed 's/^ENDDATA$/MPC,1,2,1,1.,3,1,-1.\nMPC,1,3,1,1.,2,1,-1.\nENDDATA/' "$deck" >"$d/cycle.bdf"
expect_error "circular dependency between constraints" "$d/bad2.h5" modes -mesh "$d/cycle.bdf" -clamp '*BOUNDARY' \
  -modes_nev 2
echo "constraints chain: OK"
