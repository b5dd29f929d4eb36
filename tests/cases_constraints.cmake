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

# Spiders on the generated box (tests/cases.cmake): bad options, and spiders of one node (an RBE3
# of one node cannot fix its reference's rotations) named by set and node.
set(MORSE_CON_BOX -mesh ${MORSE_CASE_BOX} -clamp x0 ${MORSE_CASE_MATERIAL})
morse_add_error_case(spiders_no_radius
  "morse: error: -mesh_spiders needs -mesh_spider_radius R" spiders_no_radius.h5 BOX
  ARGS modes ${MORSE_CON_BOX} -mesh_spiders x1 -modes_nev 2)
morse_add_error_case(spiders_unknown_set
  "morse: error: -mesh_spiders: node set 'nowhere' not found" spiders_unknown_set.h5 BOX
  ARGS modes ${MORSE_CON_BOX} -mesh_spiders nowhere -mesh_spider_radius 0.1 -modes_nev 2)
morse_add_error_case(spiders_bad_type
  "morse: error: .*Unknown option rbe9 for -mesh_spider_type" spiders_bad_type.h5 BOX
  ARGS modes ${MORSE_CON_BOX} -mesh_spiders x1 -mesh_spider_radius 0.1 -mesh_spider_type rbe9 -modes_nev 2)
morse_add_error_case(spiders_one_node
  "morse: error: -mesh_spiders x1: the spider at node .* 1 nodes within 1e-06.*do not determine the reference's motion"
  spiders_one_node.h5 BOX
  ARGS modes ${MORSE_CON_BOX} -mesh_spiders x1 -mesh_spider_radius 1e-6 -modes_nev 2)
# issue 29's gap: a -sweep_kernel that does not exist is named.
morse_add_error_case(sweep_bad_kernel
  "morse: error: .*Unknown option fast for -sweep_kernel. Available options: auto lane folded potential"
  sweep_bad_kernel.h5
  ARGS sweep -rom ${MORSE_CASE_DIR}/no_such_rom.h5 -contact_set x1 -sim_dt 4e-6 -sweep_monitor x1
       -sweep_omega_min 800 -sweep_omega_max 900 -sweep_omega_step 100 -sweep_kernel fast)
# A build of the batched potential kernel that does not exist is named with the choices.
morse_add_error_case(sweep_bad_isa
  "morse: error: .*Unknown option sse4 for -sweep_isa. Available options: auto baseline avx2 avx512"
  sweep_bad_isa.h5
  ARGS sweep -rom ${MORSE_CASE_DIR}/no_such_rom.h5 -contact_set x1 -sim_dt 4e-6 -sweep_monitor x1
       -sweep_omega_min 800 -sweep_omega_max 900 -sweep_omega_step 100 -sweep_isa sse4)
