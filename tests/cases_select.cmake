# Case tests of `morse select` (ctest -R case_select), each on 1 and 2 ranks, in the style of
# tests/cases.cmake, whose helpers and variables they reuse (included after it from
# tests/CMakeLists.txt): morse_add_error_case / morse_add_ok_case, the generated 4x1x1 hex8 beam
# ${MORSE_CASE_BOX} (fixture case_setup_box; x0 clamped, x1 = 4 boundary nodes, 12 boundary DOFs,
# 36 interior DOFs), ${MORSE_CASE_MATERIAL}. Outputs go under ${MORSE_CASE_DIR}.
#  - bad options: morse must stop with a message naming the option and the accepted range, and
#    leave no output file (tests/check_error.sh);
#  - one run with all nine methods that must write its HDF5 file.

if(NOT COMMAND morse_add_error_case OR NOT DEFINED MORSE_CASE_BOX)
  message(WARNING "tests/cases_select.cmake needs tests/cases.cmake (included first): select cases skipped")
  return()
endif()

set(MORSE_SELECT_CASE_MODEL -mesh ${MORSE_CASE_BOX} -clamp x0 -boundary x1 -cb_num_fixed_modes 10
    ${MORSE_CASE_MATERIAL})

# --- option errors (checked before the model is built)
morse_add_error_case(select_unknown_method
  "morse: error: -select_method foo: unknown method \\(frequency lpf eim veim deim omr cmschi ebr imr\\)"
  select_unknown_method.h5 BOX
  ARGS select ${MORSE_SELECT_CASE_MODEL} -select_method eim,foo)

morse_add_error_case(select_fraction_zero
  "morse: error: -select_fraction 0 must be in \\(0, 1\\]"
  select_fraction_zero.h5 BOX
  ARGS select ${MORSE_SELECT_CASE_MODEL} -select_fraction 0)

morse_add_error_case(select_fraction_above_one
  "morse: error: -select_fraction 1.5 must be in \\(0, 1\\]"
  select_fraction_above_one.h5 BOX
  ARGS select ${MORSE_SELECT_CASE_MODEL} -select_fraction 1.5)

morse_add_error_case(select_xdmf
  "morse: error: -cb_xdmf is a reduce option \\(the mode shapes of -cb_write_basis\\): select writes no mode shapes"
  select_xdmf.h5 BOX
  ARGS select ${MORSE_SELECT_CASE_MODEL} -cb_xdmf 0)

# --- method data errors (checked once the candidate modes exist)
morse_add_error_case(select_ebr_no_excitation
  "morse: error: EBR without excitation: every amplitude of -select_ebr_amp is zero"
  select_ebr_no_excitation.h5 BOX
  ARGS select ${MORSE_SELECT_CASE_MODEL} -select_method ebr -select_ebr_freq 100,200 -select_ebr_amp 0,0)

morse_add_error_case(select_ebr_load_bad_node
  "morse: error: .*ebr_load_bad_node\\.txt:3: node 1 is not in the boundary set"
  select_ebr_load_bad_node.h5 BOX
  ARGS select ${MORSE_SELECT_CASE_MODEL} -select_method ebr -select_ebr_load ${MORSE_CASE_DATA}/ebr_load_bad_node.txt)

morse_add_error_case(select_ebr_load_and_freq
  "morse: error: give the EBR excitation either as -select_ebr_load FILE or as -select_ebr_freq"
  select_ebr_load_and_freq.h5 BOX
  ARGS select ${MORSE_SELECT_CASE_MODEL} -select_method ebr -select_ebr_load ${MORSE_CASE_DATA}/ebr_load_bad_node.txt
       -select_ebr_freq 100)

# IMR with the interface free: the system modes are the full model's modes below the analysis band.
morse_add_error_case(select_imr_modes_range
  "morse: error: -select_imr_modes 999 is out of range \\(1\\.\\.[0-9]+ system modes below [0-9.e+]+ Hz\\)"
  select_imr_modes_range.h5 BOX
  ARGS select ${MORSE_SELECT_CASE_MODEL} -select_method imr -select_imr_modes 999)

# IMR with the interface clamped: the system modes are the 10 candidate fixed-interface modes.
morse_add_error_case(select_imr_modes_range_clamped
  "morse: error: -select_imr_modes 999 is out of range \\(1\\.\\.10 fixed-interface modes\\)"
  select_imr_modes_range_clamped.h5 BOX
  ARGS select ${MORSE_SELECT_CASE_MODEL} -select_method imr -select_imr_support clamped
       -select_imr_modes 999)

# --- positive case: every method, 4 of 10 candidates each, EIM superelement in /rom.
morse_add_ok_case(select_ok select_ok.h5
  select -mesh '${MORSE_CASE_BOX}' -clamp x0 -boundary x1 -cb_num_fixed_modes 10 -select_num_modes 4
  -select_method frequency,lpf,eim,veim,deim,omr,cmschi,ebr,imr -select_rom_method eim
  ${MORSE_CASE_MATERIAL_STR})

# A component held only by its interface (no clamp: the box is free but for x0, its boundary):
# every method runs, the full model's six rigid-body modes are matched at zero frequency
# (tests/test_free_free.cpp checks the numbers), IMR uses the flexible system modes and refuses a
# rigid one by name.
morse_add_ok_case(select_free_interface select_free_interface.h5
  select -mesh '${MORSE_CASE_BOX}' -boundary x0 -cb_num_fixed_modes 10 -select_num_modes 4
  -select_method frequency,lpf,eim,veim,deim,omr,cmschi,ebr,imr ${MORSE_CASE_MATERIAL_STR})
morse_add_error_case(select_imr_rigid_mode
  "morse: error: -select_imr_modes 2: system mode 2 is a rigid-body mode \\(0 Hz; the model has 6\\): IMR needs flexible system modes"
  select_imr_rigid_mode.h5 BOX
  ARGS select -mesh ${MORSE_CASE_BOX} -boundary x0 -cb_num_fixed_modes 10 -select_method imr -select_imr_modes 2
       ${MORSE_CASE_MATERIAL})
