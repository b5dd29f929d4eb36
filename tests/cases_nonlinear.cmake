# Case tests of `morse static` and `morse fom` on the generated box (fixture case_setup_box), each
# on 1 and 2 ranks: bad input fails cleanly with a message naming the set/option and leaves no
# output file; good input writes its file. Included from tests/CMakeLists.txt after cases.cmake.
set(MORSE_NL_BOX -mesh ${MORSE_CASE_BOX} -clamp x0 ${MORSE_CASE_MATERIAL})

morse_add_error_case(static_unknown_load_set "morse: error: .*nosuchset" static_unknown_set.h5 BOX
  ARGS static ${MORSE_NL_BOX} -load_sets nosuchset -load_nosuchset_dir z -load_nosuchset_amplitude 1)
morse_add_error_case(static_zero_direction "morse: error: .*-load_x1_dir.*zero vector" static_zero_dir.h5 BOX
  ARGS static ${MORSE_NL_BOX} -load_sets x1 -load_x1_dir 0,0,0 -load_x1_amplitude 1)
morse_add_error_case(static_bad_direction "morse: error: .*-load_x1_dir.*not x, y, z" static_bad_dir.h5 BOX
  ARGS static ${MORSE_NL_BOX} -load_sets x1 -load_x1_dir w -load_x1_amplitude 1)
morse_add_error_case(static_no_amplitude "morse: error: .*-load_x1_amplitude" static_no_amp.h5 BOX
  ARGS static ${MORSE_NL_BOX} -load_sets x1 -load_x1_dir z)
morse_add_error_case(static_no_load "morse: error: .*no load" static_no_load.h5 BOX
  ARGS static ${MORSE_NL_BOX})
morse_add_error_case(fom_negative_dt "morse: error: .*-fom_dt must be positive" fom_negative_dt.h5 BOX
  ARGS fom ${MORSE_NL_BOX} -load_sets x1 -load_x1_dir z -load_x1_amplitude 1 -fom_dt -1e-4 -fom_tfinal 1e-3)
morse_add_error_case(fom_bad_scheme "morse: error: .*-fom_scheme" fom_bad_scheme.h5 BOX
  ARGS fom ${MORSE_NL_BOX} -fom_dt 1e-4 -fom_tfinal 1e-3 -fom_scheme euler)
morse_add_error_case(fom_misspelled_option "morse: error: unknown option.*-fom_dtt" fom_typo.h5 BOX
  ARGS fom ${MORSE_NL_BOX} -fom_dtt 1e-4 -fom_tfinal 1e-3)
# A misspelled inner-solver option is refused once the solvers are set up (after the first step),
# not at the end of the run: this run of 10^6 steps would take far beyond the case's time-out.
morse_add_error_case(fom_misspelled_solver_option
  "morse: error: unknown option\\(s\\): -fom_krylov_ksp_monitr: not read by the fom's settings and solvers"
  fom_typo_solver.h5 BOX
  ARGS fom ${MORSE_NL_BOX} -load_sets x1 -load_x1_dir z -load_x1_amplitude 1 -fom_dt 1e-4 -fom_tfinal 100
       -fom_krylov_ksp_monitr)
morse_add_error_case(static_misspelled_solver_option
  "morse: error: unknown option\\(s\\): -static_snes_monitr: not read by the static solver"
  static_typo_solver.h5 BOX
  ARGS static ${MORSE_NL_BOX} -load_sets x1 -load_x1_dir z -load_x1_amplitude 1 -static_steps 1000
       -static_snes_monitr)
# A misspelled set-list option is refused, and so are the per-set options it would have named; a
# misspelled per-set option names the registered one.
morse_add_error_case(fom_misspelled_load_sets
  "morse: error: unknown option\\(s\\): -load_set \\(did you mean -load_sets\\?\\) -load_x1_amplitude -load_x1_dir \\(see -help\\)"
  fom_typo_load_sets.h5 BOX
  ARGS fom ${MORSE_NL_BOX} -load_set x1 -load_x1_dir z -load_x1_amplitude 1 -fom_dt 1e-4 -fom_tfinal 1e-3)
morse_add_error_case(fom_misspelled_load_option
  "morse: error: unknown option\\(s\\): -load_x1_amplitud \\(did you mean -load_x1_amplitude\\?\\)"
  fom_typo_load_option.h5 BOX
  ARGS fom ${MORSE_NL_BOX} -load_sets x1 -load_x1_dir z -load_x1_amplitud 1 -load_x1_amplitude 1 -fom_dt 1e-4
       -fom_tfinal 1e-3)
morse_add_error_case(fom_diverges "morse: error: fom: .*last converged time" fom_diverges.h5 BOX
  ARGS fom ${MORSE_NL_BOX} -load_sets x1 -load_x1_dir z -load_x1_amplitude 1e15 -fom_dt 1e-3 -fom_tfinal 1e-2
       -fom_newton_max_it 5)
morse_add_error_case(fom_missing_initial "morse: error: .*no_such_static\\.h5" fom_missing_initial.h5 BOX
  ARGS fom ${MORSE_NL_BOX} -fom_dt 1e-4 -fom_tfinal 1e-3 -fom_initial ${MORSE_CASE_DIR}/no_such_static.h5)

morse_add_ok_case(static_ok static_ok.h5
  static -mesh '${MORSE_CASE_BOX}' -clamp x0 ${MORSE_CASE_MATERIAL_STR} -load_sets x1 -load_x1_dir z
  -load_x1_amplitude 1e8 -static_steps 2 -static_monitor x1)
morse_add_ok_case(fom_ok fom_ok.h5
  fom -mesh '${MORSE_CASE_BOX}' -clamp x0 ${MORSE_CASE_MATERIAL_STR} -load_sets x1 -load_x1_dir z
  -load_x1_amplitude 1e6 -load_x1_omega 300 -fom_dt 1e-4 -fom_tfinal 2e-3 -fom_monitor x1 -fom_snapshot_every 5)
# The energy scheme keeps the balance (no drift warning) and fom prints its energy diagnostics.
morse_add_ok_case(fom_energy_scheme_balance fom_energy_ok.h5
  fom -mesh '${MORSE_CASE_BOX}' -clamp x0 ${MORSE_CASE_MATERIAL_STR} -load_sets x1 -load_x1_dir z
  -load_x1_amplitude 1e6 -load_x1_omega 300 -fom_dt 1e-4 -fom_tfinal 2e-3 -fom_scheme energy)
foreach(np 1 2)
  set_tests_properties(case_fom_energy_scheme_balance_np${np} PROPERTIES
    PASS_REGULAR_EXPRESSION "energy: balance drift [0-9.e+-]+ J \\(largest total energy [0-9.e+-]+ J\\).*case: ok: "
    FAIL_REGULAR_EXPRESSION "morse: error;warning: the energy balance drifts")
endforeach()
morse_add_ok_case(fom_linear_damped_ok fom_linear_ok.h5
  fom -mesh '${MORSE_CASE_BOX}' -clamp x0 ${MORSE_CASE_MATERIAL_STR} -load_sets x1 -load_x1_dir y
  -load_x1_amplitude 1e6 -load_x1_omega 300 -fom_dt 1e-4 -fom_tfinal 2e-3 -fom_linear -fom_damping_modal 0.01
  -fom_damping_modes 2 -fom_rayleigh 1,1e-6)

# -load_history: bad tables fail on every rank before the run, naming the file (and line, dataset
# or node); good tables (CSV and HDF5, with a harmonic load beside) write their file.
set(MORSE_LH_FOM fom ${MORSE_NL_BOX} -fom_dt 1e-4 -fom_tfinal 2e-3)
morse_add_error_case(fom_history_missing_file "morse: error: -load_history .*no_such_table\\.csv: cannot open"
  fom_history_missing.h5 BOX ARGS ${MORSE_LH_FOM} -load_history ${MORSE_CASE_DIR}/no_such_table.csv)
morse_add_error_case(fom_history_missing_dataset
  "morse: error: -load_history .*load_history_box\\.h5: /no_forces is neither a load table.*/no_forces/forces"
  fom_history_no_dataset.h5 BOX ARGS ${MORSE_LH_FOM} -load_history ${MORSE_CASE_DATA}/load_history_box.h5:/no_forces)
morse_add_error_case(fom_history_missing_group "morse: error: -load_history .*load_history_box\\.h5: no group /nosuch"
  fom_history_no_group.h5 BOX ARGS ${MORSE_LH_FOM} -load_history ${MORSE_CASE_DATA}/load_history_box.h5:/nosuch)
morse_add_error_case(fom_history_bad_times
  "morse: error: -load_history .*load_history_bad_times\\.csv:4: the times are not increasing"
  fom_history_bad_times.h5 BOX ARGS ${MORSE_LH_FOM} -load_history ${MORSE_CASE_DATA}/load_history_bad_times.csv)
morse_add_error_case(fom_history_nan "morse: error: -load_history .*load_history_nan\\.csv:2: value 4 is not finite"
  fom_history_nan.h5 BOX ARGS ${MORSE_LH_FOM} -load_history ${MORSE_CASE_DATA}/load_history_nan.csv)
morse_add_error_case(fom_history_fractional_node
  "morse: error: -load_history .*load_history_fractional_node\\.csv:4: node id 1401\\.5 is not an integer node id"
  fom_history_fractional_node.h5 BOX
  ARGS ${MORSE_LH_FOM} -load_history ${MORSE_CASE_DATA}/load_history_fractional_node.csv)
morse_add_error_case(fom_history_unknown_node
  "morse: error: .*load_history_unknown_node\\.csv: 1 node id\\(s\\) of the load table are not nodes of .*\\(777\\)"
  fom_history_unknown_node.h5 BOX ARGS ${MORSE_LH_FOM} -load_history ${MORSE_CASE_DATA}/load_history_unknown_node.csv)
morse_add_error_case(fom_history_too_short
  "morse: error: .*load_history_box\\.csv: the load history covers \\[0, 0\\.003\\] s, not the run's \\[0, 0\\.005\\] s"
  fom_history_short.h5 BOX
  ARGS fom ${MORSE_NL_BOX} -fom_dt 1e-4 -fom_tfinal 5e-3 -load_history ${MORSE_CASE_DATA}/load_history_box.csv)
morse_add_error_case(fom_history_bad_outside "morse: error: -load_history_outside: 'later' is not error, zero or hold"
  fom_history_outside.h5 BOX
  ARGS ${MORSE_LH_FOM} -load_history ${MORSE_CASE_DATA}/load_history_box.csv -load_history_outside later)
morse_add_ok_case(fom_history_csv_ok fom_history_csv.h5
  fom -mesh '${MORSE_CASE_BOX}' -clamp x0 ${MORSE_CASE_MATERIAL_STR} -load_sets x1 -load_x1_dir y
  -load_x1_amplitude 1e5 -load_x1_omega 300 -fom_dt 1e-4 -fom_tfinal 2e-3 -fom_monitor x1
  -load_history '${MORSE_CASE_DATA}/load_history_box.csv')
morse_add_ok_case(fom_history_h5_ok fom_history_h5.h5
  fom -mesh '${MORSE_CASE_BOX}' -clamp x0 ${MORSE_CASE_MATERIAL_STR} -fom_dt 1e-4 -fom_tfinal 5e-3
  -load_history '${MORSE_CASE_DATA}/load_history_box.h5' -load_history_outside hold -load_history_scale 0.5)

# morse stress -fom: the stress of a full-model snapshot (seed 003 Fig. 11's reference). A fom run
# with snapshots, then the stress of its snapshot nearest 1e-3 s: the file is written, its time is
# the snapshot's, and every mesh node (the clamped ones at rest) has a displacement.
foreach(np 1 2)
  set(fo ${MORSE_CASE_DIR}/stress_fom_src_np${np}.h5)
  set(so ${MORSE_CASE_DIR}/stress_fom_np${np}.h5)
  add_test(NAME case_stress_from_fom_np${np}
           COMMAND ${MORSE_BASH} -c "rm -f '${fo}' '${so}' && '${MORSE_MPIEXEC}' ${MORSE_CASE_MPI_FLAGS_STR} -n ${np} '$<TARGET_FILE:morse>' fom -mesh '${MORSE_CASE_BOX}' -clamp x0 ${MORSE_CASE_MATERIAL_STR} -load_sets x1 -load_x1_dir z -load_x1_amplitude 1e6 -load_x1_omega 300 -fom_dt 1e-4 -fom_tfinal 2e-3 -fom_snapshot_every 5 -out '${fo}' >/dev/null && '${MORSE_MPIEXEC}' ${MORSE_CASE_MPI_FLAGS_STR} -n ${np} '$<TARGET_FILE:morse>' stress -mesh '${MORSE_CASE_BOX}' -clamp x0 ${MORSE_CASE_MATERIAL_STR} -fom '${fo}' -stress_time 1.04e-3 -out '${so}' && test -s '${so}'")
  set_tests_properties(case_stress_from_fom_np${np} PROPERTIES LABELS "case;np${np}" TIMEOUT 120
    ENVIRONMENT "${MORSE_CASE_ENV}" FIXTURES_REQUIRED morse_case_box
    PASS_REGULAR_EXPRESSION "stress of the full model at t = 0\\.001 s \\(snapshot 2 of .*max von Mises [0-9.e+]+ MPa.*morse: wrote"
    FAIL_REGULAR_EXPRESSION "morse: error")
endforeach()
morse_add_error_case(stress_fom_without_time "morse: error: morse stress -fom: give -stress_time" stress_fom_no_time.h5 BOX
  ARGS stress ${MORSE_NL_BOX} -fom ${MORSE_CASE_DIR}/stress_fom_src_np1.h5)
morse_add_error_case(stress_fom_and_rom "morse: error: morse stress: give either -fom, or -rom and -sim, not both"
  stress_fom_and_rom.h5 BOX
  ARGS stress ${MORSE_NL_BOX} -fom ${MORSE_CASE_DIR}/x.h5 -rom ${MORSE_CASE_DIR}/y.h5 -stress_time 0)
morse_add_error_case(stress_fom_no_snapshots "morse: error: .*no_such_fom\\.h5: no full-field snapshots"
  stress_fom_no_snapshots.h5 BOX
  ARGS stress ${MORSE_NL_BOX} -fom ${MORSE_CASE_DIR}/no_such_fom.h5 -stress_time 0)
