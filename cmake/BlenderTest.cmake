# arap_add_blender_test(NAME <name> SCRIPT <runner.py> [ARGS ...] [LABELS ...] [WILL_FAIL] [TIMEOUT s])
#
# Runs `blender --background --factory-startup -noaudio --python-exit-code 1
# --python <runner> -- <args>` as one ctest entry. The exit-code flag must come
# before --python, otherwise a Python error still exits 0. Exit code 77 (run.py: every
# test skipped) makes ctest report the entry as skipped, not passed.
# The add-on is found through BLENDER_USER_SCRIPTS (3.x) or BLENDER_USER_EXTENSIONS (4.2+), see
# blender_tests/CMakeLists.txt; BLENDER_USER_CONFIG points at a scratch folder so the user's preferences
# are never read or written.
function(arap_add_blender_test)
  cmake_parse_arguments(T "WILL_FAIL" "NAME;SCRIPT;TIMEOUT" "ARGS;LABELS;ENVIRONMENT" ${ARGN})
  if(NOT T_TIMEOUT)
    set(T_TIMEOUT 300)
  endif()
  add_test(NAME ${T_NAME}
           COMMAND ${BLENDER_EXECUTABLE} --background --factory-startup -noaudio
                   --python-exit-code 1 --python ${T_SCRIPT} -- ${T_ARGS})
  set(_config ${CMAKE_CURRENT_BINARY_DIR}/config/${T_NAME})
  file(MAKE_DIRECTORY ${_config})
  set_tests_properties(${T_NAME} PROPERTIES
    LABELS "${T_LABELS}"
    TIMEOUT ${T_TIMEOUT}
    WILL_FAIL ${T_WILL_FAIL}
    SKIP_RETURN_CODE 77
    ENVIRONMENT "BLENDER_USER_CONFIG=${_config};PYTHONDONTWRITEBYTECODE=1;${T_ENVIRONMENT}")
endfunction()
