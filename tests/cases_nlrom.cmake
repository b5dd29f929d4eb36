# Case tests of `morse nlrom` and `morse simulate` on the generated box (fixture case_setup_box),
# each on 1 and 2 ranks: bad input fails cleanly (message naming the option or file, no output
# file); the chains fom (snapshots) -> nlrom (cb, cbmd, pod) -> simulate run and write their files,
# and a simulate step above the critical one is refused with the limit. Included from
# tests/CMakeLists.txt after cases.cmake.
set(MORSE_NLR_BOX -mesh ${MORSE_CASE_BOX} -clamp x0 ${MORSE_CASE_MATERIAL})

morse_add_error_case(nlrom_basis_too_large "morse: error: .*larger than the model" nlrom_too_large.h5 BOX
  ARGS nlrom ${MORSE_NLR_BOX} -boundary x1 -nlrom_num_fixed_modes 100000)
morse_add_error_case(nlrom_missing_snapshots "morse: error: .*no_such_fom\\.h5" nlrom_missing_snap.h5 BOX
  ARGS nlrom ${MORSE_NLR_BOX} -boundary x1 -nlrom_basis pod -nlrom_num_pod 2
       -nlrom_snapshots ${MORSE_CASE_DIR}/no_such_fom.h5)
morse_add_error_case(nlrom_bad_basis "morse: error: .*-nlrom_basis" nlrom_bad_basis.h5 BOX
  ARGS nlrom ${MORSE_NLR_BOX} -boundary x1 -nlrom_basis svd)
morse_add_error_case(nlrom_cbmd_without_training "morse: error: .*training load" nlrom_no_training.h5 BOX
  ARGS nlrom ${MORSE_NLR_BOX} -boundary x1 -nlrom_basis cbmd -nlrom_num_fixed_modes 2 -nlrom_num_derivatives 2)
morse_add_error_case(simulate_missing_rom "morse: error: .*no_such_rom\\.h5" simulate_missing_rom.h5 BOX
  ARGS simulate -rom ${MORSE_CASE_DIR}/no_such_rom.h5 -sim_dt 1e-6 -sim_tfinal 1e-4)
# Misspelled contact options are refused before any work (before the model file is even opened).
morse_add_error_case(simulate_misspelled_casing
  "morse: error: unknown option\\(s\\): -casing_clearence \\(did you mean -casing_clearance\\?\\)"
  simulate_misspelled_casing.h5
  ARGS simulate -rom ${MORSE_CASE_DIR}/no_such_rom.h5 -sim_dt 1e-6 -sim_tfinal 1e-4 -contact_set x1
       -casing_clearence 2e-4)
morse_add_error_case(sweep_misspelled_contact
  "morse: error: unknown option\\(s\\): -contact_muu \\(did you mean -contact_mu\\?\\)"
  sweep_misspelled_contact.h5
  ARGS sweep -rom ${MORSE_CASE_DIR}/no_such_rom.h5 -sim_dt 1e-6 -sim_revolutions 2 -contact_set x1 -contact_muu 0.1)
# A friction law that does not exist is named with the two there are, before the model is opened.
morse_add_error_case(simulate_bad_sliding
  "morse: error: .*Unknown option coulomb for -contact_sliding. Available options: rotation relative"
  simulate_bad_sliding.h5
  ARGS simulate -rom ${MORSE_CASE_DIR}/no_such_rom.h5 -sim_dt 1e-6 -sim_tfinal 1e-4 -contact_set x1
       -contact_sliding coulomb)
morse_add_error_case(sweep_bad_sliding
  "morse: error: .*Unknown option exact for -contact_sliding. Available options: rotation relative"
  sweep_bad_sliding.h5
  ARGS sweep -rom ${MORSE_CASE_DIR}/no_such_rom.h5 -sim_dt 1e-6 -sim_revolutions 2 -contact_set x1
       -contact_sliding exact)
# Values that cannot be run are refused at option time, naming the option: a speed grid beyond
# the bound of a sweep (with the file size it would need) or not finite, non-finite initial states
# and loads, a case given twice or escaping -out's directory, a bad -compare_tmax or training step.
set(MORSE_NLR_SWEEP sweep -rom ${MORSE_CASE_DIR}/no_such_rom.h5 -contact_set x1 -sim_dt 4e-6 -sweep_monitor x1)
morse_add_error_case(sweep_too_many_speeds
  "morse: error: -sweep_omega_min 800, -sweep_omega_max 1e\\+15 and -sweep_omega_step 1e-06 give 1e\\+21 speeds; a sweep takes at most 1000000 \\(its file would need about .* GB"
  sweep_too_many_speeds.h5
  ARGS ${MORSE_NLR_SWEEP} -sweep_omega_min 800 -sweep_omega_max 1e15 -sweep_omega_step 1e-6)
morse_add_error_case(sweep_omega_max_inf "morse: error: -sweep_omega_max inf: expected a finite number"
  sweep_omega_max_inf.h5 ARGS ${MORSE_NLR_SWEEP} -sweep_omega_min 800 -sweep_omega_max inf -sweep_omega_step 100)
set(MORSE_NLR_SIM simulate -rom ${MORSE_CASE_DIR}/no_such_rom.h5 -sim_dt 1e-6 -sim_tfinal 1e-4)
morse_add_error_case(simulate_q0_nan "morse: error: -sim_q0 0,nan: item 'nan': expected a finite number"
  simulate_q0_nan.h5 ARGS ${MORSE_NLR_SIM} -sim_q0 0,nan)
morse_add_error_case(simulate_load_amplitude_inf "morse: error: -load_x1_amplitude inf: expected a finite number"
  simulate_load_inf.h5 ARGS ${MORSE_NLR_SIM} -load_sets x1 -load_x1_dir y -load_x1_amplitude inf)
morse_add_error_case(simulate_case_twice "morse: error: -sim_cases: case a is given twice"
  simulate_case_twice.h5 ARGS ${MORSE_NLR_SIM} -sim_cases a,b,a)
morse_add_error_case(simulate_case_escapes "morse: error: -sim_cases: case name '\\.\\./x' must not be empty nor contain"
  simulate_case_escapes.h5 ARGS ${MORSE_NLR_SIM} -sim_cases a,../x)
morse_add_error_case(compare_tmax_nan "morse: error: -compare_tmax nan: expected a finite number"
  compare_tmax_nan.h5 ARGS compare ${MORSE_CASE_DIR}/no_fom.h5 ${MORSE_CASE_DIR}/no_sim.h5 -compare_tmax nan)
morse_add_error_case(compare_tmax_negative "morse: error: -compare_tmax must be a finite time >= 0 \\[s\\] \\(got -1\\)"
  compare_tmax_negative.h5 ARGS compare ${MORSE_CASE_DIR}/no_fom.h5 ${MORSE_CASE_DIR}/no_sim.h5 -compare_tmax -1)
morse_add_error_case(nlrom_training_dt_negative
  "morse: error: -nlrom_training_dt must be a finite positive time step \\[s\\] \\(got -1\\)"
  nlrom_training_dt.h5 BOX
  ARGS nlrom ${MORSE_NLR_BOX} -boundary x1 -nlrom_basis cbmd -nlrom_num_fixed_modes 2 -nlrom_num_derivatives 2
       -load_sets x1 -load_x1_dir y -load_x1_amplitude 1 -nlrom_training_tfinal 1e-3 -nlrom_training_dt -1)
morse_add_error_case(mesh_node_set_missing_id "morse: error: .*-mesh_node_set_tipx.*987654321" node_set_bad.h5 BOX
  ARGS modes ${MORSE_NLR_BOX} -mesh_node_sets tipx -mesh_node_set_tipx 1,987654321)

# Sizes checked before allocating (each ended in a bare std::bad_alloc): the cubic tensor of a
# basis of r = 5363 vectors (PB), 10^12 simulate steps written every step (a small rom, fixture
# case_setup_rom), 10^9 sweep spectrum bins at 1000 speeds (refused before the rom is read).
add_test(NAME case_setup_box_large
         COMMAND ${MORSE_MPIEXEC} ${MORSE_MPI_FLAGS} -n 1 $<TARGET_FILE:morse> mesh box -box_type hex8
                 -box_nx 30 -box_ny 10 -box_nz 10 -out ${MORSE_CASE_DIR}/box_large.msh)
set_tests_properties(case_setup_box_large PROPERTIES LABELS "case;np1" TIMEOUT 120
  ENVIRONMENT "${MORSE_CASE_ENV}" FIXTURES_SETUP morse_case_box_large FAIL_REGULAR_EXPRESSION "morse: error")
add_test(NAME case_setup_rom
         COMMAND ${MORSE_MPIEXEC} ${MORSE_MPI_FLAGS} -n 1 $<TARGET_FILE:morse> nlrom ${MORSE_NLR_BOX} -boundary x1
                 -nlrom_basis cb -nlrom_num_fixed_modes 3 -nlrom_forces exact -out ${MORSE_CASE_DIR}/case_rom.h5)
set_tests_properties(case_setup_rom PROPERTIES LABELS "case;np1" TIMEOUT 120
  ENVIRONMENT "${MORSE_CASE_ENV}" FIXTURES_REQUIRED morse_case_box FIXTURES_SETUP morse_case_rom
  FAIL_REGULAR_EXPRESSION "morse: error")
morse_add_error_case(nlrom_tensor_too_large
  "morse: error: nlrom r = 5363 needs [0-9.]+ PB for the cubic tensor.*; [0-9.e+]+ [GTP]B available"
  nlrom_tensor_too_large.h5
  ARGS nlrom -mesh ${MORSE_CASE_DIR}/box_large.msh -clamp x0 ${MORSE_CASE_MATERIAL} -boundary x1
       -nlrom_num_fixed_modes 5000 -nlrom_forces exact)
# A Newton failure of the implicit scheme names the time reached, the residual history and what
# to try, and leaves no file.
morse_add_error_case(simulate_newton_failure
  "morse: error: simulate: Newton did not converge at t = 0.0001 \\(step 1\\) in 0 iterations \\(tolerance [0-9.e+-]+; \\|\\|R\\|\\| per iteration: [0-9.e+-]+\\); last converged time 0\\. Try a smaller -sim_dt, a larger -sim_newton_max_it"
  simulate_newton_failure.h5
  ARGS simulate -rom ${MORSE_CASE_DIR}/case_rom.h5 -sim_scheme trapezoidal -sim_dt 1e-4 -sim_tfinal 1e-3
       -sim_newton_max_it 0 -load_sets x1 -load_x1_dir y -load_x1_amplitude 100)
morse_add_error_case(simulate_output_too_large
  "morse: error: simulate: writing 1000000000001 output rows \\(1000000000000 steps, -sim_output_every 1\\) needs [0-9.]+ [TP]B for the histories \\(r = 15\\);.*raise -sim_output_every"
  simulate_output_too_large.h5
  ARGS simulate -rom ${MORSE_CASE_DIR}/case_rom.h5 -sim_dt 1e-9 -sim_tfinal 1e3 -sim_output_every 1)
morse_add_error_case(sweep_spectrum_too_large
  "morse: error: morse sweep: 1000 speeds of 1000000001 spectrum frequencies \\(-sweep_spectrum_bins 1000000000\\), windows of [0-9]+ samples \\(-sim_revolutions 200 at -sweep_omega_min 1\\) needs [0-9.]+ TB for the spectra"
  sweep_spectrum_too_large.h5
  ARGS sweep -rom ${MORSE_CASE_DIR}/no_such_rom.h5 -contact_set x1 -sim_dt 1e-7 -sweep_omega_min 1
       -sweep_omega_max 1000 -sweep_omega_step 1 -sweep_spectrum_bins 1000000000)
morse_add_error_case(sweep_window_too_large
  "morse: error: morse sweep: 10 speeds of 501 spectrum frequencies \\(-sweep_spectrum_bins 500\\), windows of [0-9]+ samples \\(-sim_revolutions 1e\\+08 at -sweep_omega_min 1\\) needs [0-9.]+ [TP]B for the spectra"
  sweep_window_too_large.h5
  ARGS sweep -rom ${MORSE_CASE_DIR}/no_such_rom.h5 -contact_set x1 -sim_dt 1e-7 -sweep_omega_min 1
       -sweep_omega_max 10 -sweep_omega_step 1 -sim_revolutions 1e8)
foreach(np 1 2)
  set_tests_properties(case_nlrom_tensor_too_large_np${np} PROPERTIES FIXTURES_REQUIRED morse_case_box_large)
  set_tests_properties(case_simulate_output_too_large_np${np} PROPERTIES FIXTURES_REQUIRED morse_case_rom)
  set_tests_properties(case_simulate_newton_failure_np${np} PROPERTIES FIXTURES_REQUIRED morse_case_rom)
endforeach()

# Chains: fom with snapshots -> nlrom (three bases, STEP and exact, POD filtering) -> simulate,
# and the critical-step refusal (no output file).
foreach(np 1 2)
  add_test(NAME case_nlrom_chain_np${np}
           COMMAND ${MORSE_BASH} ${CMAKE_CURRENT_SOURCE_DIR}/case_nlrom_chain.sh ${MORSE_CASE_DIR}/nlrom_chain_np${np}
                   $<TARGET_FILE:morse> ${np} ${MORSE_CASE_BOX} ${MORSE_MPIEXEC} ${MORSE_MPI_FLAGS} -- ${MORSE_CASE_MATERIAL})
  set_tests_properties(case_nlrom_chain_np${np} PROPERTIES LABELS "case;np${np}" TIMEOUT 300
    ENVIRONMENT "${MORSE_CASE_ENV}" FIXTURES_REQUIRED morse_case_box FAIL_REGULAR_EXPRESSION "morse: error")
endforeach()

# Contact and sweeps: simulate against the casing, a sweep killed and resumed (bitwise the same
# file as an uninterrupted one-rank sweep), and the bad-input refusals.
foreach(np 1 2)
  add_test(NAME case_contact_chain_np${np}
           COMMAND ${MORSE_BASH} ${CMAKE_CURRENT_SOURCE_DIR}/case_contact_chain.sh ${MORSE_CASE_DIR}/contact_chain_np${np}
                   $<TARGET_FILE:morse> ${np} ${MORSE_CASE_BOX} ${MORSE_MPIEXEC} ${MORSE_MPI_FLAGS} -- ${MORSE_CASE_MATERIAL})
  set_tests_properties(case_contact_chain_np${np} PROPERTIES LABELS "case;np${np}" TIMEOUT 300
    ENVIRONMENT "${MORSE_CASE_ENV}" FIXTURES_REQUIRED morse_case_box)
endforeach()

# morse_add_box_script(NAME TIMEOUT): tests/case_NAME.sh on the box (DIR MORSE NP BOX MPIEXEC
# [MPI FLAGS] -- MATERIAL) as case_NAME_np1 and _np2; exit status 77 skips (no h5py, no setsid).
function(morse_add_box_script name timeout)
  foreach(np 1 2)
    add_test(NAME case_${name}_np${np}
             COMMAND ${MORSE_BASH} ${CMAKE_CURRENT_SOURCE_DIR}/case_${name}.sh
                     ${MORSE_CASE_DIR}/${name}_np${np} $<TARGET_FILE:morse> ${np} ${MORSE_CASE_BOX}
                     ${MORSE_MPIEXEC} ${MORSE_MPI_FLAGS} -- ${MORSE_CASE_MATERIAL})
    set_tests_properties(case_${name}_np${np} PROPERTIES LABELS "case;np${np}" TIMEOUT ${timeout}
      ENVIRONMENT "${MORSE_CASE_ENV}" FIXTURES_REQUIRED morse_case_box SKIP_RETURN_CODE 77)
  endforeach()
endfunction()

# Corrupt sweep checkpoints (datasets of the wrong shape, an index given twice or outside the
# grid) are refused naming the file and the dataset, and left unchanged (skipped without h5py).
morse_add_box_script(sweep_checkpoint 300)

# Adaptive refinement of a sweep: rounds run, a finished refined sweep resumes whole, a cut file
# resumes to the same speeds bitwise, bad refinement options refused (skipped without h5py).
morse_add_box_script(sweep_refine 300)

# The cluster recipe (run/cluster) with fake sbatch and srun: a chain of jobs runs and resumes a
# sweep from an options file (skipped without h5py).
morse_add_box_script(cluster_chain 300)

# A second run on the output of a running sweep is refused (naming the output and the holder's
# pid), and the ranks of a sweep whose launcher is killed (kill -9 of its process group) stop
# within 1 s without writing the file again (skipped without setsid, pgrep or h5py).
morse_add_box_script(sweep_lock 120)

# Massless-boundary models (issue 27): the fixture builds one (exact tensors, a one-node set for the
# sweep monitor: node 5 is a corner of face x1); bad options and runs are refused with the option,
# value or node named and nothing written, and a massless sweep writes its file.
add_test(NAME case_setup_rom_massless
         COMMAND ${MORSE_MPIEXEC} ${MORSE_MPI_FLAGS} -n 1 $<TARGET_FILE:morse> nlrom ${MORSE_NLR_BOX} -boundary x1
                 -nlrom_basis cb -nlrom_num_fixed_modes 3 -nlrom_forces exact -nlrom_boundary_mass massless
                 -mesh_node_sets tipnode -mesh_node_set_tipnode 5 -out ${MORSE_CASE_DIR}/case_rom_massless.h5)
set_tests_properties(case_setup_rom_massless PROPERTIES LABELS "case;np1" TIMEOUT 120
  ENVIRONMENT "${MORSE_CASE_ENV}" FIXTURES_REQUIRED morse_case_box FIXTURES_SETUP morse_case_rom_massless
  FAIL_REGULAR_EXPRESSION "morse: error")
add_test(NAME case_setup_rom_linear
         COMMAND ${MORSE_MPIEXEC} ${MORSE_MPI_FLAGS} -n 1 $<TARGET_FILE:morse> nlrom ${MORSE_NLR_BOX} -boundary x1
                 -nlrom_basis cb -nlrom_num_fixed_modes 3 -nlrom_forces none -nlrom_boundary_mass massless
                 -out ${MORSE_CASE_DIR}/case_rom_linear.h5)
set_tests_properties(case_setup_rom_linear PROPERTIES LABELS "case;np1" TIMEOUT 120
  ENVIRONMENT "${MORSE_CASE_ENV}" FIXTURES_REQUIRED morse_case_box FIXTURES_SETUP morse_case_rom_linear
  FAIL_REGULAR_EXPRESSION "morse: error")
set(MORSE_ML_ROM ${MORSE_CASE_DIR}/case_rom_massless.h5)
morse_add_error_case(nlrom_massless_fmax_negative
  "morse: error: -nlrom_massless_fmax must be a finite frequency >= 0 \\[Hz\\] \\(got -5\\)" ml_fmax.h5 BOX
  ARGS nlrom ${MORSE_NLR_BOX} -boundary x1 -nlrom_num_fixed_modes 3 -nlrom_boundary_mass massless
       -nlrom_massless_fmax -5)
morse_add_error_case(nlrom_massless_fmax_without_massless
  "morse: error: -nlrom_massless_fmax applies to -nlrom_boundary_mass massless" ml_fmax2.h5 BOX
  ARGS nlrom ${MORSE_NLR_BOX} -boundary x1 -nlrom_num_fixed_modes 3 -nlrom_massless_fmax 100)
morse_add_error_case(nlrom_massless_scaled_without_fmax
  "morse: error: -nlrom_massless_interior scaled needs -nlrom_massless_fmax HZ > 0" ml_scaled.h5 BOX
  ARGS nlrom ${MORSE_NLR_BOX} -boundary x1 -nlrom_num_fixed_modes 3 -nlrom_boundary_mass massless
       -nlrom_massless_interior scaled)
morse_add_error_case(nlrom_massless_interior_without_massless
  "morse: error: -nlrom_massless_interior applies to -nlrom_boundary_mass massless" ml_scaled2.h5 BOX
  ARGS nlrom ${MORSE_NLR_BOX} -boundary x1 -nlrom_num_fixed_modes 3 -nlrom_massless_interior static)
# Selective mass scaling (-nlrom_mass_scaling_fmax): the command reports the modes moved and the
# critical step before and after (the library's checks are in test_massless).
add_test(NAME case_nlrom_mass_scaling
         COMMAND ${MORSE_MPIEXEC} ${MORSE_MPI_FLAGS} -n 1 $<TARGET_FILE:morse> nlrom ${MORSE_NLR_BOX} -boundary x1
                 -nlrom_basis cb -nlrom_num_fixed_modes 3 -nlrom_forces exact -nlrom_mass_scaling_fmax 2000
                 -nlrom_damping_modal 0.01 -nlrom_damping_modes all -out ${MORSE_CASE_DIR}/case_rom_mass_scaled.h5)
set_tests_properties(case_nlrom_mass_scaling PROPERTIES LABELS "case;np1" TIMEOUT 120
  ENVIRONMENT "${MORSE_CASE_ENV}" FIXTURES_REQUIRED morse_case_box
  PASS_REGULAR_EXPRESSION "mass scaling: [0-9]+ modes above 2000 Hz moved to it; critical step of central differences 1.59[0-9]*e-04 s"
  FAIL_REGULAR_EXPRESSION "morse: error")
morse_add_error_case(nlrom_mass_scaling_massless
  "morse: error: -nlrom_mass_scaling_fmax applies to a mass-carrying model" ms_massless.h5 BOX
  ARGS nlrom ${MORSE_NLR_BOX} -boundary x1 -nlrom_num_fixed_modes 3 -nlrom_boundary_mass massless
       -nlrom_mass_scaling_fmax 1000)
morse_add_error_case(nlrom_mass_scaling_negative
  "morse: error: -nlrom_mass_scaling_fmax must be a finite frequency >= 0 \\[Hz\\] \\(got -3\\)" ms_negative.h5 BOX
  ARGS nlrom ${MORSE_NLR_BOX} -boundary x1 -nlrom_num_fixed_modes 3 -nlrom_mass_scaling_fmax -3)
# Damping (issue 28): -nlrom_damping_modes takes a count or all, strictly; -nlrom_rayleigh two finite
# values, and neither with -nlrom_damping_modal nor with a massless boundary.
morse_add_error_case(nlrom_damping_modes_suffix
  "morse: error: -nlrom_damping_modes 5abc: expected a number of modes >= 0 or all" damp_suffix.h5 BOX
  ARGS nlrom ${MORSE_NLR_BOX} -boundary x1 -nlrom_num_fixed_modes 3 -nlrom_damping_modal 5e-4
       -nlrom_damping_modes 5abc)
morse_add_error_case(nlrom_damping_modes_negative
  "morse: error: -nlrom_damping_modes -2: expected a number of modes >= 0 or all" damp_negative.h5 BOX
  ARGS nlrom ${MORSE_NLR_BOX} -boundary x1 -nlrom_num_fixed_modes 3 -nlrom_damping_modal 5e-4
       -nlrom_damping_modes -2)
morse_add_error_case(nlrom_rayleigh_one_value
  "morse: error: -nlrom_rayleigh takes two values alpha,beta \\(got 1\\)" damp_ray_one.h5 BOX
  ARGS nlrom ${MORSE_NLR_BOX} -boundary x1 -nlrom_num_fixed_modes 3 -nlrom_rayleigh 1)
morse_add_error_case(nlrom_rayleigh_nan
  "morse: error: -nlrom_rayleigh nan,0: item 'nan': expected a finite number" damp_ray_nan.h5 BOX
  ARGS nlrom ${MORSE_NLR_BOX} -boundary x1 -nlrom_num_fixed_modes 3 -nlrom_rayleigh nan,0)
morse_add_error_case(nlrom_rayleigh_massless
  "morse: error: -nlrom_rayleigh is not defined on the massless model \\(-nlrom_boundary_mass massless\\)"
  damp_ray_massless.h5 BOX
  ARGS nlrom ${MORSE_NLR_BOX} -boundary x1 -nlrom_num_fixed_modes 3 -nlrom_boundary_mass massless
       -nlrom_rayleigh 1,1e-6)
morse_add_error_case(nlrom_rayleigh_with_modal
  "morse: error: -nlrom_rayleigh and -nlrom_damping_modal are two damping models: give one of them"
  damp_ray_modal.h5 BOX
  ARGS nlrom ${MORSE_NLR_BOX} -boundary x1 -nlrom_num_fixed_modes 3 -nlrom_rayleigh 1,1e-6
       -nlrom_damping_modal 5e-4 -nlrom_damping_modes all)
# and both run and write their model (tests/test_nlrom.cpp checks the ratios against closed forms).
morse_add_ok_case(nlrom_damping_all nlrom_damping_all.h5
  nlrom -mesh '${MORSE_CASE_BOX}' -clamp x0 ${MORSE_CASE_MATERIAL_STR} -boundary x1 -nlrom_num_fixed_modes 3
  -nlrom_forces none -nlrom_damping_modal 5e-4 -nlrom_damping_modes all)
morse_add_ok_case(nlrom_damping_rayleigh nlrom_damping_rayleigh.h5
  nlrom -mesh '${MORSE_CASE_BOX}' -clamp x0 ${MORSE_CASE_MATERIAL_STR} -boundary x1 -nlrom_num_fixed_modes 3
  -nlrom_forces none -nlrom_rayleigh 10,1e-7)
morse_add_error_case(nlrom_massless_bad_mass
  "morse: error: .*-nlrom_boundary_mass" ml_mass.h5 BOX
  ARGS nlrom ${MORSE_NLR_BOX} -boundary x1 -nlrom_num_fixed_modes 3 -nlrom_boundary_mass light)
morse_add_error_case(simulate_massless_dt_above_critical
  "morse: error: simulate: -sim_dt 1 s is above the critical step of central differences on the massless model, [0-9.e-]+ s"
  ml_dt.h5
  ARGS simulate -rom ${MORSE_ML_ROM} -sim_dt 1 -sim_tfinal 10 -contact_set x1 -casing_clearance 2e-4)
morse_add_error_case(simulate_massless_trapezoidal
  "morse: error: simulate: the implicit schemes \\(-sim_scheme trapezoidal, energy\\) do not take a massless-boundary model"
  ml_trap.h5
  ARGS simulate -rom ${MORSE_ML_ROM} -sim_dt 1e-5 -sim_tfinal 1e-4 -sim_scheme trapezoidal)
morse_add_error_case(simulate_massless_contact_not_boundary
  "morse: error: .*case_rom_massless\\.h5: node 1 of set y0 is not a physical boundary node of the reduced model"
  ml_contact.h5
  ARGS simulate -rom ${MORSE_ML_ROM} -sim_dt 1e-6 -sim_tfinal 1e-4 -contact_set y0 -casing_clearance 2e-4)
morse_add_error_case(simulate_linear_model_run_nonlinear
  "morse: error: simulate: the reduced model has no nonlinear force of size 15 \\(a linear model, -nlrom_forces none\\): run it with -sim_linear"
  ml_linear.h5
  ARGS simulate -rom ${MORSE_CASE_DIR}/case_rom_linear.h5 -sim_dt 1e-6 -sim_tfinal 1e-4)
foreach(np 1 2)
  foreach(c simulate_massless_dt_above_critical simulate_massless_trapezoidal simulate_massless_contact_not_boundary)
    set_tests_properties(case_${c}_np${np} PROPERTIES FIXTURES_REQUIRED morse_case_rom_massless)
  endforeach()
  set_tests_properties(case_simulate_linear_model_run_nonlinear_np${np} PROPERTIES
    FIXTURES_REQUIRED morse_case_rom_linear)
  add_test(NAME case_sweep_massless_np${np}
           COMMAND ${MORSE_MPIEXEC} ${MORSE_MPI_FLAGS} -n ${np} $<TARGET_FILE:morse> sweep -rom ${MORSE_ML_ROM}
                   -contact_set x1 -casing_clearance 2e-4 -casing_bump_height 6e-4 -casing_width 0.3 -sim_dt 4e-6
                   -sim_revolutions 1 -sweep_omega_min 1000 -sweep_omega_max 1200 -sweep_omega_step 100
                   -sweep_monitor tipnode -sweep_restart -out ${MORSE_CASE_DIR}/sweep_massless_np${np}.h5)
  set_tests_properties(case_sweep_massless_np${np} PROPERTIES LABELS "case;np${np}" TIMEOUT 120
    ENVIRONMENT "${MORSE_CASE_ENV}" FIXTURES_REQUIRED morse_case_rom_massless
    FAIL_REGULAR_EXPRESSION "morse: error" PASS_REGULAR_EXPRESSION "3 speeds")
endforeach()
