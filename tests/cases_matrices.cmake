# Case chain of the assembled-operator and Nastran inputs (tests/case_matrices_chain.sh) on the
# generated box, on 1 and 2 ranks. Included from tests/CMakeLists.txt after cases.cmake.
foreach(np 1 2)
  add_test(NAME case_matrices_chain_np${np}
           COMMAND ${MORSE_BASH} ${CMAKE_CURRENT_SOURCE_DIR}/case_matrices_chain.sh ${MORSE_CASE_DIR}/matrices_chain_np${np}
                   $<TARGET_FILE:morse> ${np} ${MORSE_CASE_BOX} ${MORSE_MPIEXEC} ${MORSE_MPI_FLAGS} -- ${MORSE_CASE_MATERIAL})
  set_tests_properties(case_matrices_chain_np${np} PROPERTIES LABELS "case;np${np}" TIMEOUT 300
    ENVIRONMENT "${MORSE_CASE_ENV}" FIXTURES_REQUIRED morse_case_box)
endforeach()
