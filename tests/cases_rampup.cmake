# Case chain of `morse rampup` on a superelement of the generated box (fixture case_setup_box), on
# 1 and 2 ranks: the reference run, the reference check of issue 11 (every selection method with
# every candidate kept gives the reference bearing loads to round-off), a truncated selection,
# and bad input refused cleanly (tests/case_rampup_chain.sh). Included from tests/CMakeLists.txt
# after cases.cmake.
foreach(np 1 2)
  add_test(NAME case_rampup_chain_np${np}
           COMMAND ${MORSE_BASH} ${CMAKE_CURRENT_SOURCE_DIR}/case_rampup_chain.sh ${MORSE_CASE_DIR}/rampup_chain_np${np}
                   $<TARGET_FILE:morse> ${np} ${MORSE_CASE_BOX} ${MORSE_MPIEXEC} ${MORSE_MPI_FLAGS} -- ${MORSE_CASE_MATERIAL})
  set_tests_properties(case_rampup_chain_np${np} PROPERTIES LABELS "case;np${np}" TIMEOUT 300
    ENVIRONMENT "${MORSE_CASE_ENV}" FIXTURES_REQUIRED morse_case_box)
endforeach()
