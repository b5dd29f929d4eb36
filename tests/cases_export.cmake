# Case tests of `morse export` (ctest -R case_export), each on 1 and 2 ranks, in the style of
# tests/cases.cmake, whose variables they reuse (included after it from tests/CMakeLists.txt):
# the generated 4x1x1 hex8 beam ${MORSE_CASE_BOX} (fixture case_setup_box), ${MORSE_CASE_MATERIAL},
# ${MORSE_CASE_CHECK}. Outputs go under ${MORSE_CASE_DIR}.
#  - a fixture writes a superelement (reduce: boundary x0, nothing clamped, modal damping) and a
#    file without /rom (modes);
#  - bad input: morse must stop with a message naming the option or file, and leave no file with
#    the output prefix (tests/check_error.sh, then a glob on the prefix);
#  - one export in every format that must write every file.

if(NOT DEFINED MORSE_CASE_BOX OR NOT DEFINED MORSE_CASE_CHECK)
  message(WARNING "tests/cases_export.cmake needs tests/cases.cmake (included first): export cases skipped")
  return()
endif()

set(MORSE_EXPORT_SE ${MORSE_CASE_DIR}/export_se.h5)
set(MORSE_EXPORT_NOROM ${MORSE_CASE_DIR}/export_modes.h5)

add_test(NAME case_export_setup_reduce
         COMMAND ${MORSE_MPIEXEC} ${MORSE_MPI_FLAGS} -n 1 $<TARGET_FILE:morse> reduce -mesh ${MORSE_CASE_BOX}
                 -boundary x0 -cb_num_fixed_modes 4 -cb_damping 0.01 ${MORSE_CASE_MATERIAL} -out ${MORSE_EXPORT_SE})
add_test(NAME case_export_setup_modes
         COMMAND ${MORSE_MPIEXEC} ${MORSE_MPI_FLAGS} -n 1 $<TARGET_FILE:morse> modes -mesh ${MORSE_CASE_BOX}
                 -clamp x0 -modes_nev 2 -modes_xdmf 0 ${MORSE_CASE_MATERIAL} -out ${MORSE_EXPORT_NOROM})
set_tests_properties(case_export_setup_reduce case_export_setup_modes PROPERTIES LABELS "case;np1" TIMEOUT 120
  ENVIRONMENT "${MORSE_CASE_ENV}" FIXTURES_REQUIRED morse_case_box FIXTURES_SETUP morse_case_export
  FAIL_REGULAR_EXPRESSION "morse: error")

# morse_add_export_error_case(<name> <regex> ARGS <morse export arguments...>)
# case_<name>_np1/np2: tests/check_error.sh with -out ${MORSE_CASE_DIR}/<name>_np<N> (a prefix),
# then no file may start with that prefix.
function(morse_add_export_error_case name regex)
  cmake_parse_arguments(C "" "" "ARGS" ${ARGN})
  foreach(np 1 2)
    set(out ${MORSE_CASE_DIR}/${name}_np${np})
    # bash -c SCRIPT $0 $1 ...: $0 the checker, $1 the regex, $2 the prefix, then -- and the command.
    add_test(NAME case_${name}_np${np}
             COMMAND ${MORSE_BASH} -c "rm -f \"$2\"* && \"$0\" \"$@\" && if compgen -G \"$2*\" >/dev/null; then echo \"export case: FAIL: files left: $(echo $2*)\"; exit 1; fi"
                     ${MORSE_CASE_CHECK} "${regex}" ${out} --
                     ${MORSE_MPIEXEC} ${MORSE_MPI_FLAGS} -n ${np} $<TARGET_FILE:morse> export ${C_ARGS} -out ${out})
    set_tests_properties(case_${name}_np${np} PROPERTIES LABELS "case;np${np}" TIMEOUT 120
      ENVIRONMENT "${MORSE_CASE_ENV}" FIXTURES_REQUIRED morse_case_export)
  endforeach()
endfunction()

morse_add_export_error_case(export_no_from
  "morse: error: no superelement given: use -export_from FILE"
  ARGS)

morse_add_export_error_case(export_no_rom
  "morse: error: .*export_modes\\.h5: no /rom/K: not a superelement file"
  ARGS -export_from ${MORSE_EXPORT_NOROM})

morse_add_export_error_case(export_missing_file
  "morse: error: .*no_such_se\\.h5: no such file"
  ARGS -export_from ${MORSE_CASE_DIR}/no_such_se.h5)

morse_add_export_error_case(export_unknown_format
  "morse: error: -export_format nastran: unknown format \\(mbdyn, op4, dmig, mtx\\)"
  ARGS -export_from ${MORSE_EXPORT_SE} -export_format mbdyn,nastran)

morse_add_export_error_case(export_misspelled_option
  "morse: error: unknown option\\(s\\): -export_fromat \\(did you mean -export_format\\?\\)"
  ARGS -export_from ${MORSE_EXPORT_SE} -export_fromat mtx)

morse_add_export_error_case(export_all_nodes_without_basis
  "morse: error: .*export_se\\.h5: no dataset /cb/constraint_modes .*-cb_write_basis"
  ARGS -export_from ${MORSE_EXPORT_SE} -export_mbdyn_nodes all)

# One OP4 file or DMIG deck holds K, M and C: their names must differ (Nastran ignores case).
morse_add_export_error_case(export_op4_duplicate_names
  "morse: error: -export_op4_names: the names of K, M, C \\(a, a, BAA\\) must differ: a is given twice"
  ARGS -export_from ${MORSE_EXPORT_SE} -export_op4_names a,a)
morse_add_export_error_case(export_dmig_duplicate_names
  "morse: error: -export_dmig_names: the names of K, M, C \\(KX, MX, kx\\) must differ: kx is given twice"
  ARGS -export_from ${MORSE_EXPORT_SE} -export_dmig_names KX,MX,kx)

# Positive case: every format, every file, no temporary left.
foreach(np 1 2)
  set(out ${MORSE_CASE_DIR}/export_ok_np${np})
  set(files "${out}.fem ${out}.op4 ${out}_dmig.bdf ${out}_grids.bdf ${out}_K.mtx ${out}_M.mtx ${out}_C.mtx ${out}_dofs.txt")
  add_test(NAME case_export_ok_np${np}
           COMMAND ${MORSE_BASH} -c "rm -f '${out}'* && '${MORSE_MPIEXEC}' ${MORSE_CASE_MPI_FLAGS_STR} -n ${np} '$<TARGET_FILE:morse>' export -export_from '${MORSE_EXPORT_SE}' -out '${out}' && for f in ${files}; do test -s $f || { echo \"case: FAIL: $f missing\"; exit 1; }; done && if compgen -G '${out}*.part*' >/dev/null || compgen -G '${out}*.tmp' >/dev/null || compgen -G '${out}*.tmp.*' >/dev/null; then echo 'case: FAIL: temporary file left'; exit 1; fi && echo 'case: ok: every export written'")
  set_tests_properties(case_export_ok_np${np} PROPERTIES LABELS "case;np${np}" TIMEOUT 120
    ENVIRONMENT "${MORSE_CASE_ENV}" FIXTURES_REQUIRED morse_case_export FAIL_REGULAR_EXPRESSION "morse: error")
endforeach()
