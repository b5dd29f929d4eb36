# Case tests of the output paths (core/files.hpp, files::prepare_outputs), each on 1 and 2 ranks:
# an -out that names an input file of the command (by another spelling: "./", "..", an absolute
# path, a symbolic link) is refused before any work, naming the option and both paths, and the
# input is left byte for byte as it was; an -out that is a directory, empty or in a missing
# directory is refused at the start, naming the user's path; a stale temporary of a killed run is
# removed by the next run of the same output. Included from tests/CMakeLists.txt after cases.cmake.
if(NOT COMMAND morse_add_error_case OR NOT DEFINED MORSE_CASE_BOX)
  return()
endif()

set(MORSE_OUT_DIR ${MORSE_CASE_DIR}/outputs)
set(MORSE_OUT_BOX -clamp x0 ${MORSE_CASE_MATERIAL})

# Fixture: the files of the later commands (an nlrom model, a simulate run, a fom run with snapshots).
add_test(NAME case_setup_outputs
         COMMAND ${MORSE_BASH} -c "set -e; mkdir -p '${MORSE_OUT_DIR}'; \
run() { '${MORSE_MPIEXEC}' ${MORSE_CASE_MPI_FLAGS_STR} -n 1 '$<TARGET_FILE:morse>' \"$@\"; }; \
run nlrom -mesh '${MORSE_CASE_BOX}' -clamp x0 ${MORSE_CASE_MATERIAL_STR} -boundary x1 -nlrom_basis cb \
  -nlrom_num_fixed_modes 3 -nlrom_forces exact -out '${MORSE_OUT_DIR}/rom.h5'; \
run simulate -rom '${MORSE_OUT_DIR}/rom.h5' -sim_dt 1e-8 -sim_tfinal 2e-7 -sim_monitor x1 -out '${MORSE_OUT_DIR}/sim.h5'; \
run fom -mesh '${MORSE_CASE_BOX}' -clamp x0 ${MORSE_CASE_MATERIAL_STR} -fom_dt 1e-4 -fom_tfinal 4e-4 \
  -fom_snapshot_every 2 -out '${MORSE_OUT_DIR}/fom.h5'")
set_tests_properties(case_setup_outputs PROPERTIES LABELS "case;np1" TIMEOUT 120 ENVIRONMENT "${MORSE_CASE_ENV}"
  FIXTURES_SETUP morse_case_outputs FIXTURES_REQUIRED morse_case_box FAIL_REGULAR_EXPRESSION "morse: error")

# morse_add_output_case(<name> <regex> OUT <path> [INPUT <file> [AS <copy name>]] [LINK <link name>]
#                       [FIXTURE <fixture>] ARGS <morse arguments...>)
# Adds case_<name>_np1 and case_<name>_np2, run in their own directory ${MORSE_OUT_DIR}/<name>_np<N>
# (the working directory; @DIR@ in OUT and ARGS stands for it, @NAME@ in ARGS for <name>_np<N>).
# INPUT is copied there first (as <copy name>, default its own name) and must be byte for byte the
# same after the failed run;
# LINK makes <link name> a symbolic link to that copy. The morse arguments name -out themselves;
# OUT is that -out as check_error.sh checks it (no temporary <OUT>.tmp* may be left).
function(morse_add_output_case name regex)
  cmake_parse_arguments(C "" "OUT;INPUT;AS;LINK;FIXTURE" "ARGS" ${ARGN})
  foreach(np 1 2)
    set(dir ${MORSE_OUT_DIR}/${name}_np${np})
    file(MAKE_DIRECTORY ${dir})
    string(REPLACE "@DIR@" "${dir}" args "${C_ARGS}")
    string(REPLACE "@NAME@" "${name}_np${np}" args "${args}")
    string(REPLACE "@DIR@" "${dir}" out "${C_OUT}")
    set(pre "")
    if(C_INPUT)
      get_filename_component(copy ${C_INPUT} NAME)
      if(C_AS)
        set(copy ${C_AS})
      endif()
      list(APPEND pre --copy ${C_INPUT} ${dir}/${copy})
      if(C_LINK)
        list(APPEND pre --link ${dir}/${C_LINK} ${copy})
      endif()
    endif()
    add_test(NAME case_${name}_np${np}
             COMMAND ${MORSE_BASH} ${MORSE_CASE_CHECK} ${pre} "${regex}" ${out} --
                     ${MORSE_MPIEXEC} ${MORSE_MPI_FLAGS} -n ${np} $<TARGET_FILE:morse> ${args}
             WORKING_DIRECTORY ${dir})
    set_tests_properties(case_${name}_np${np} PROPERTIES LABELS "case;np${np}" TIMEOUT 120
      ENVIRONMENT "${MORSE_CASE_ENV}" FIXTURES_REQUIRED "morse_case_box;${C_FIXTURE}")
  endforeach()
endfunction()

# --- an -out that is an input of the command
morse_add_output_case(fom_out_is_mesh
  "morse: error: -out \\./box\\.msh is the input file -mesh .*/fom_out_is_mesh_np./box\\.msh \\(the same file\\)"
  OUT @DIR@/box.msh INPUT ${MORSE_CASE_BOX}
  ARGS fom -mesh @DIR@/box.msh ${MORSE_OUT_BOX} -fom_dt 1e-4 -fom_tfinal 2e-4 -out ./box.msh)
morse_add_output_case(fom_out_is_load_history
  "morse: error: -out .*/\\.\\./fom_out_is_load_history_np./history\\.csv is the input file -load_history "
  OUT @DIR@/history.csv INPUT ${MORSE_CASE_DATA}/load_history_box.csv AS history.csv
  ARGS fom -mesh ${MORSE_CASE_BOX} ${MORSE_OUT_BOX} -fom_dt 1e-4 -fom_tfinal 2e-4 -load_history history.csv
       -load_history_outside zero -out @DIR@/../@NAME@/history.csv)
morse_add_output_case(reduce_out_is_mesh_link
  "morse: error: -out .*/link\\.msh is the input file -mesh box\\.msh \\(the same file\\)"
  OUT @DIR@/link.msh INPUT ${MORSE_CASE_BOX} LINK link.msh
  ARGS reduce -mesh box.msh ${MORSE_OUT_BOX} -boundary x1 -cb_num_fixed_modes 2 -out @DIR@/link.msh)
# Two outputs of one run that are one file.
morse_add_output_case(reduce_matrices_write_is_out
  "morse: error: -out m_K\\.mtx and -matrices_write m_K\\.mtx are the same output file"
  OUT @DIR@/m_K.mtx
  ARGS reduce -mesh ${MORSE_CASE_BOX} ${MORSE_OUT_BOX} -boundary x1 -cb_num_fixed_modes 2 -matrices_write m
       -out m_K.mtx)
morse_add_output_case(modes_out_is_mesh
  "morse: error: -out box\\.msh is the input file -mesh .*box\\.msh"
  OUT @DIR@/box.msh INPUT ${MORSE_CASE_BOX}
  ARGS modes -mesh @DIR@/box.msh ${MORSE_OUT_BOX} -modes_nev 2 -out box.msh)
morse_add_output_case(static_out_is_mesh
  "morse: error: -out .*box\\.msh is the input file -mesh \\./box\\.msh"
  OUT @DIR@/box.msh INPUT ${MORSE_CASE_BOX}
  ARGS static -mesh ./box.msh ${MORSE_OUT_BOX} -load_sets x1 -load_x1_dir y -load_x1_amplitude 1 -out @DIR@/box.msh)
morse_add_output_case(nlrom_out_is_snapshots
  "morse: error: -out \\./fom\\.h5 is the input file -nlrom_snapshots .*fom\\.h5 \\(the same file\\)"
  OUT @DIR@/fom.h5 INPUT ${MORSE_OUT_DIR}/fom.h5 FIXTURE morse_case_outputs
  ARGS nlrom -mesh ${MORSE_CASE_BOX} ${MORSE_OUT_BOX} -boundary x1 -nlrom_basis cb -nlrom_num_fixed_modes 2
       -nlrom_forces exact -nlrom_snapshots @DIR@/fom.h5 -out ./fom.h5)
morse_add_output_case(simulate_out_is_rom
  "morse: error: -out .*rom_link\\.h5 is the input file -rom .*rom\\.h5 \\(the same file\\)"
  OUT @DIR@/rom_link.h5 INPUT ${MORSE_OUT_DIR}/rom.h5 LINK rom_link.h5 FIXTURE morse_case_outputs
  ARGS simulate -rom @DIR@/rom.h5 -sim_dt 1e-8 -sim_tfinal 2e-7 -out rom_link.h5)
# With cases the files are <out stem>_<case>.h5: case b's is the model.
morse_add_output_case(simulate_case_out_is_rom
  "morse: error: -out \\(case b\\) run_b\\.h5 is the input file -rom .*run_b\\.h5"
  OUT @DIR@/run_b.h5 INPUT ${MORSE_OUT_DIR}/rom.h5 AS run_b.h5 FIXTURE morse_case_outputs
  ARGS simulate -rom @DIR@/run_b.h5 -sim_dt 1e-8 -sim_tfinal 2e-7 -sim_cases a,b -out run.h5)
morse_add_output_case(stress_out_is_rom
  "morse: error: -out rom\\.h5 is the input file -rom .*rom\\.h5"
  OUT @DIR@/rom.h5 INPUT ${MORSE_OUT_DIR}/rom.h5 FIXTURE morse_case_outputs
  ARGS stress -mesh ${MORSE_CASE_BOX} ${MORSE_OUT_BOX} -rom @DIR@/rom.h5 -sim ${MORSE_OUT_DIR}/sim.h5
       -stress_time 0 -out rom.h5)
morse_add_output_case(stress_out_is_sim
  "morse: error: -out .*/\\./sim\\.h5 is the input file -sim sim\\.h5"
  OUT @DIR@/sim.h5 INPUT ${MORSE_OUT_DIR}/sim.h5 FIXTURE morse_case_outputs
  ARGS stress -mesh ${MORSE_CASE_BOX} ${MORSE_OUT_BOX} -rom ${MORSE_OUT_DIR}/rom.h5 -sim sim.h5 -stress_time 0
       -out @DIR@/./sim.h5)
morse_add_output_case(sweep_out_is_rom
  "morse: error: -out \\./rom\\.h5 is the input file -rom .*rom\\.h5"
  OUT @DIR@/rom.h5 INPUT ${MORSE_OUT_DIR}/rom.h5 FIXTURE morse_case_outputs
  ARGS sweep -rom @DIR@/rom.h5 -contact_set x1 -sim_dt 1e-6 -sweep_omega_min 800 -sweep_omega_max 900
       -sweep_omega_step 100 -sweep_monitor x1 -sweep_restart -out ./rom.h5)
morse_add_output_case(select_out_is_select_from
  "morse: error: -out basis\\.h5 is the input file -select_from .*basis\\.h5"
  OUT @DIR@/basis.h5 INPUT ${MORSE_OUT_DIR}/rom.h5 AS basis.h5 FIXTURE morse_case_outputs
  ARGS select -mesh ${MORSE_CASE_BOX} ${MORSE_OUT_BOX} -boundary x1 -select_from @DIR@/basis.h5 -out basis.h5)
morse_add_output_case(export_out_is_coordinates
  "morse: error: -out se_dofs\\.txt is the input file -export_coordinates .*se_dofs\\.txt"
  OUT @DIR@/se_dofs.txt INPUT ${MORSE_CASE_DATA}/ebr_load_bad_node.txt AS se_dofs.txt FIXTURE morse_case_outputs
  ARGS export -export_from ${MORSE_OUT_DIR}/rom.h5 -export_coordinates @DIR@/se_dofs.txt -out se)
morse_add_output_case(compare_rom_is_fom
  "morse: error: ROM\\.h5 \\./sim\\.h5 is the input file FOM\\.h5 .*sim\\.h5"
  OUT @DIR@/sim.h5 INPUT ${MORSE_OUT_DIR}/sim.h5 FIXTURE morse_case_outputs
  ARGS compare @DIR@/sim.h5 ./sim.h5 -compare_tmax 1e-7)

# --- an -out that cannot be an output file: refused at the start, naming the user's path
morse_add_output_case(fom_out_is_directory
  "morse: error: -out .*/fom_out_is_directory_np. is a directory: give the name of the output file"
  OUT @DIR@/none.h5
  ARGS fom -mesh ${MORSE_CASE_BOX} ${MORSE_OUT_BOX} -fom_dt 1e-4 -fom_tfinal 2e-4 -out @DIR@)
morse_add_output_case(reduce_out_is_empty
  "morse: error: -out is empty: give the name of the output file"
  OUT @DIR@/none.h5
  ARGS reduce -mesh ${MORSE_CASE_BOX} ${MORSE_OUT_BOX} -boundary x1 -cb_num_fixed_modes 2 -out)
morse_add_output_case(modes_out_in_missing_directory
  "morse: error: cannot write -out no_such_dir/modes\\.h5: the directory no_such_dir does not exist"
  OUT @DIR@/modes.h5
  ARGS modes -mesh ${MORSE_CASE_BOX} ${MORSE_OUT_BOX} -modes_nev 2 -out no_such_dir/modes.h5)
morse_add_output_case(mesh_out_is_directory
  "morse: error: -out .*/mesh_out_is_directory_np./d\\.msh is a directory"
  OUT @DIR@/none.msh
  ARGS mesh box -box_nx 2 -box_ny 1 -box_nz 1 -out @DIR@/d.msh)
foreach(np 1 2)
  file(MAKE_DIRECTORY ${MORSE_OUT_DIR}/mesh_out_is_directory_np${np}/d.msh)
endforeach()

# --- a stale temporary of a killed run (its process gone) is removed by the next run of the same
# output; a temporary of a live process (pid 1) and other files are kept; the run leaves none.
foreach(np 1 2)
  set(dir ${MORSE_OUT_DIR}/stale_temporary_np${np})
  add_test(NAME case_stale_temporary_np${np}
           COMMAND ${MORSE_BASH} -c "set -e; rm -rf '${dir}' && mkdir -p '${dir}' && cd '${dir}' && \
dead=$(( $(cat /proc/sys/kernel/pid_max) + 7 )) && \
echo killed > modes.h5.tmp.$dead && echo live > modes.h5.tmp.1 && echo other > modes.h5.tmpx && \
echo other > other.h5.tmp.$dead && \
'${MORSE_MPIEXEC}' ${MORSE_CASE_MPI_FLAGS_STR} -n ${np} '$<TARGET_FILE:morse>' modes -mesh '${MORSE_CASE_BOX}' \
  -clamp x0 ${MORSE_CASE_MATERIAL_STR} -modes_nev 2 -out modes.h5 > log.txt 2>&1 || { cat log.txt; exit 1; }; cat log.txt; \
grep -q \"removed modes.h5.tmp.$dead, the temporary of a killed run\" log.txt; \
test -s modes.h5 && test ! -e modes.h5.tmp.$dead && test -e modes.h5.tmp.1 && test -e modes.h5.tmpx && \
test -e other.h5.tmp.$dead && test -z \"$(ls modes.h5.tmp.* | grep -v 'tmp\\.1$')\" && echo 'case: ok: stale temporary removed'")
  set_tests_properties(case_stale_temporary_np${np} PROPERTIES LABELS "case;np${np}" TIMEOUT 120
    ENVIRONMENT "${MORSE_CASE_ENV}" FIXTURES_REQUIRED morse_case_box FAIL_REGULAR_EXPRESSION "morse: error")
endforeach()
