#!/usr/bin/env bash
# Case chain of `morse rampup` (seed 000 §3) on a superelement of the generated box:
#  1. reduce (10 fixed-interface candidates, basis kept) -> rampup: the reference run;
#  2. the reference check of issue 11: for every selection method, select keeping every candidate
#     -> rampup against the reference: eq. 24 errors are 0 to round-off (same modes, same loads);
#  3. a truncated selection (EIM, 3 modes) runs and reports a non-zero error;
#  4. bad input: each refused with a message naming the option, file or node, and no output file.
# usage: case_rampup_chain.sh DIR MORSE NP BOX MPIEXEC [MPI FLAGS...] -- [MATERIAL OPTIONS...]
set -euo pipefail
. "$(dirname "$0")/case_common.sh" "$@"
run reduce "${model[@]}" -boundary x1 -cb_num_fixed_modes 10 -cb_write_basis -cb_xdmf 0 -out "$d/basis.h5"
# One rotor along z: a disk with an unbalance at its free end, a bearing seated on the four x1
# nodes of the box (their mean) and one on the ground.
engine=(-rampup_stators box -rampup_stator_box_damping_ratio 0.02
        -rampup_rotors r -rampup_rotor_r_z 0,0.25,0.5,0.75 -rampup_rotor_r_d_outer 0.06
        -rampup_rotor_r_disks d -rampup_disk_d_z 0.75 -rampup_disk_d_mass 20 -rampup_disk_d_Ip 0.2
        -rampup_disk_d_Id 0.1 -rampup_unbalance d -rampup_unbalance_me 1e-3
        -rampup_bearings front,rear
        -rampup_bearing_front_rotor r -rampup_bearing_front_z 0 -rampup_bearing_front_stator box
        -rampup_bearing_front_nodes x1 -rampup_bearing_front_k 1e8 -rampup_bearing_front_c 1e3
        -rampup_bearing_rear_rotor r -rampup_bearing_rear_z 0.5 -rampup_bearing_rear_stator ground
        -rampup_bearing_rear_k 5e7,4e7 -rampup_bearing_rear_c 1e3
        -rampup_rpm_max 6000 -rampup_ramp_time 0.2 -rampup_dt 1e-4 -rampup_output_every 2
        -rampup_stator_box_cut_hz 2000)
run rampup "${engine[@]}" -rampup_stator_box_file "$d/basis.h5" -out "$d/ref.h5"
for m in frequency lpf eim veim deim omr cmschi ebr imr; do
  run select "${model[@]}" -boundary x1 -select_from "$d/basis.h5" -select_method $m -select_num_modes 10 \
    -out "$d/se_$m.h5" > "$d/select_$m.log"
  run rampup "${engine[@]}" -rampup_stator_box_file "$d/se_$m.h5" -rampup_reference "$d/ref.h5" \
    -out "$d/rampup_$m.h5" > "$d/rampup_$m.log"
done
run select "${model[@]}" -boundary x1 -select_from "$d/basis.h5" -select_method eim -select_num_modes 3 \
  -out "$d/se_eim3.h5" > /dev/null
run rampup "${engine[@]}" -rampup_stator_box_file "$d/se_eim3.h5" -rampup_reference "$d/ref.h5" \
  -out "$d/rampup_eim3.h5" | tee "$d/rampup_eim3.log"
grep -q "against .*ref.h5 (seed 000 eq. 24): bearing loads worst" "$d/rampup_eim3.log"
/usr/bin/python3 - "$d" <<'PY'
import sys, h5py, numpy as np
d = sys.argv[1]
ref = h5py.File(d + "/ref.h5", "r")["/rampup"]
F = ref["bearing_force"][:]
assert F.shape == (1001, 2, 2), F.shape
# The bearing loads are not trivial: the unbalance force at top speed is m e w^2 = 1e-3 (2 pi 100)^2.
assert abs(F).max() > 10.0, abs(F).max()
# Force balance at t = 0 (rest): everything zero.
assert abs(F[0]).max() == 0.0
for m in "frequency lpf eim veim deim omr cmschi ebr imr".split():
    e = h5py.File(d + "/rampup_" + m + ".h5", "r")["/rampup/error"]
    worst = max(e.attrs["force_worst"], e.attrs["displacement_worst"])
    print("every candidate kept, %-9s: eq. 24 worst %.2e" % (m, worst))
    assert worst < 1e-9, (m, worst)
    assert e["bearing_force"].shape == (2, 2)
e = h5py.File(d + "/rampup_eim3.h5", "r")["/rampup/error"]
print("EIM, 3 of 10 modes: eq. 24 bearing loads worst %.3e, mean %.3e" % (e.attrs["force_worst"], e.attrs["force_mean"]))
assert e.attrs["force_worst"] > 1e-6
assert abs(e.attrs["force_mean"] - np.mean(e["bearing_force"][:])) < 1e-15
PY
# Bad input.
expect_error "bearing 'front'.*node 1 is not in the interface" "$d/bad_node.h5" rampup "${engine[@]}" \
  -rampup_stator_box_file "$d/basis.h5" -rampup_bearing_front_nodes 1
expect_error "bearing 'rear'.*must be finite and >= 0" "$d/bad_k.h5" rampup "${engine[@]}" \
  -rampup_stator_box_file "$d/basis.h5" -rampup_bearing_rear_k -5e7
expect_error "\-rampup_unbalance fan: no such disk (disks: d)" "$d/bad_disk.h5" rampup "${engine[@]}" \
  -rampup_stator_box_file "$d/basis.h5" -rampup_unbalance fan
expect_error "\-rampup_stator_box_file $d/none.h5: no such file" "$d/no_file.h5" rampup "${engine[@]}" \
  -rampup_stator_box_file "$d/none.h5"
expect_error "no /rom/K" "$d/bad_file.h5" rampup "${engine[@]}" -rampup_stator_box_file "$d/rampup_eim3.h5"
expect_error "\-rampup_stator_box_clamp: nosuchset is neither a node id nor a node set" "$d/bad_set.h5" rampup \
  "${engine[@]}" -rampup_stator_box_file "$d/basis.h5" -rampup_stator_box_clamp nosuchset
expect_error "\-rampup_bearing_rear_z: z = 0.6 is not a station of rotor 'r'" "$d/bad_z.h5" rampup \
  "${engine[@]}" -rampup_stator_box_file "$d/basis.h5" -rampup_bearing_rear_z 0.6
expect_error "unknown option(s): -rampup_bearing_rear_kk" "$d/typo.h5" rampup "${engine[@]}" \
  -rampup_stator_box_file "$d/basis.h5" -rampup_bearing_rear_kk 1
expect_error "the reference has 1001 output times, this run 501" "$d/bad_ref.h5" rampup "${engine[@]}" \
  -rampup_stator_box_file "$d/basis.h5" -rampup_reference "$d/ref.h5" -rampup_output_every 4
# A step too coarse for the top spin frequency runs, with a warning.
run rampup "${engine[@]}" -rampup_stator_box_file "$d/basis.h5" -rampup_dt 1e-3 -out "$d/coarse.h5" 2>&1 |
  tee "$d/coarse.log"
grep -q "morse: warning: dt = 0.001 s gives" "$d/coarse.log"
test -s "$d/coarse.h5"
# Model A's pieces (docs/rampup-theory.md §4.3): a second rotor g geared at ratio 2 to r's free end,
# hung on r by an intershaft bearing, r driven at z = 0, an aerodynamic torque on g; constant speed
# with a damped mesh: the twist settles to the static one, where the drive's torque carries the fan's
# c w_g^2 through the ratio, c w_g^2 / 2 (power balance), and the mesh torque equals it.
geared=(-rampup_rotors r,g -rampup_rotor_g_z 0 -rampup_rotor_g_speed_ratio 0.5 -rampup_rotor_g_disks gd
        -rampup_disk_gd_z 0 -rampup_disk_gd_mass 5 -rampup_disk_gd_Ip 0.5 -rampup_disk_gd_Id 0.25
        -rampup_bearings front,rear,gi -rampup_bearing_gi_rotor g -rampup_bearing_gi_z 0
        -rampup_bearing_gi_rotor2 r -rampup_bearing_gi_z2 0.75 -rampup_bearing_gi_k 1e7
        -rampup_drives m -rampup_drive_m_rotor r -rampup_drive_m_z 0
        -rampup_gearboxes gb -rampup_gearbox_gb_input r -rampup_gearbox_gb_input_z 0.75 -rampup_gearbox_gb_output g
        -rampup_gearbox_gb_output_z 0 -rampup_gearbox_gb_ratio 2 -rampup_gearbox_gb_k 1e5 -rampup_gearbox_gb_c 45
        -rampup_torques aero -rampup_torque_aero_rotor g -rampup_torque_aero_z 0
        -rampup_torque_aero_coefficient 1e-3 -rampup_rotor_r_rayleigh 0,1e-3 -rampup_constant_speed
        -rampup_t_final 0.5)
run rampup "${engine[@]}" "${geared[@]}" -rampup_stator_box_file "$d/basis.h5" -out "$d/geared.h5" | tee "$d/geared.log"
grep -q "torsion: 1 drive(s), 1 gearbox(es), 1 torque(s)" "$d/geared.log"
/usr/bin/python3 - "$d" <<'PY'
import sys, math, h5py
f = h5py.File(sys.argv[1] + "/geared.h5", "r")["/rampup"]
w_g = 0.5 * 6000 * 2 * math.pi / 60
T = 1e-3 * w_g ** 2 / 2
drive, mesh = f["drive_torque"][-1, 0], f["gearbox_torque"][-1, 0]
print("geared: drive torque %.6f, mesh torque %.6f, static c w_g^2 / 2 = %.6f N m" % (drive, mesh, T))
assert abs(drive - T) < 1e-6 * T and abs(mesh - T) < 1e-6 * T, (drive, mesh, T)
assert f["bearing_force"].shape[1] == 3 and abs(f["bearing_force"][:, 2, :]).max() > 0
drives = f.attrs["drives"]
drives = drives.decode() if isinstance(drives, bytes) else str(drives)
assert drives == "m" and f["torsion_frequencies"].shape[0] == 4, (drives, f["torsion_frequencies"].shape)
PY
expect_error "gearbox 'gb': ratio 3, but rotor 'r' turns at 1 and 'g' at 0.5" "$d/bad_ratio.h5" rampup "${engine[@]}" \
  "${geared[@]}" -rampup_stator_box_file "$d/basis.h5" -rampup_gearbox_gb_ratio 3
expect_error "rotor 'h' is not driven" "$d/undriven.h5" rampup "${engine[@]}" "${geared[@]}" \
  -rampup_stator_box_file "$d/basis.h5" -rampup_rotors r,g,h -rampup_rotor_h_z 0
expect_error "give -rampup_bearing_gi_stator or -rampup_bearing_gi_rotor2 (intershaft), not both" "$d/bad_gi.h5" \
  rampup "${engine[@]}" "${geared[@]}" -rampup_stator_box_file "$d/basis.h5" -rampup_bearing_gi_stator box
expect_error "gearbox gb: give -rampup_gearbox_gb_k" "$d/no_k.h5" rampup "${engine[@]}" -rampup_rotors r,g \
  -rampup_rotor_g_z 0 -rampup_gearboxes gb -rampup_gearbox_gb_input r -rampup_gearbox_gb_input_z 0.75 \
  -rampup_gearbox_gb_output g -rampup_gearbox_gb_output_z 0 -rampup_gearbox_gb_ratio 2 \
  -rampup_stator_box_file "$d/basis.h5"
expect_error "\-rampup_drive_m_rotor x: no such rotor" "$d/bad_drive.h5" rampup "${engine[@]}" "${geared[@]}" \
  -rampup_stator_box_file "$d/basis.h5" -rampup_drive_m_rotor x
