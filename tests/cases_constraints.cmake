# Case chain of a Nastran deck with a rigid spider (tests/case_constraints_chain.sh), on 1 and 2
# ranks. Included from tests/CMakeLists.txt after cases.cmake.
foreach(np 1 2)
  add_test(NAME case_constraints_chain_np${np}
           COMMAND ${MORSE_BASH} ${CMAKE_CURRENT_SOURCE_DIR}/case_constraints_chain.sh
                   ${MORSE_CASE_DIR}/constraints_chain_np${np} $<TARGET_FILE:morse> ${np} ${MORSE_CASE_BOX}
                   ${MORSE_MPIEXEC} ${MORSE_MPI_FLAGS} -- ${MORSE_CASE_MATERIAL})
  set_tests_properties(case_constraints_chain_np${np} PROPERTIES LABELS "case;np${np}" TIMEOUT 300
    ENVIRONMENT "${MORSE_CASE_ENV}" FIXTURES_REQUIRED morse_case_box)
endforeach()
