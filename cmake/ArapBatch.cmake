# The batch launcher in the build tree: ${CMAKE_BINARY_DIR}/arap-batch (the thin
# script addon/arap-batch, executable as in the source tree) and its package
# ${CMAKE_BINARY_DIR}/arap_batch/ (addon/arap_batch/*.py), plus
# arap_batch/build_paths.py, which gives this build's staged add-on folder and
# the Blender found at configure time as the launcher's defaults (--addon-dir and
# --blender override them). The same script runs from the source tree, where
# there are no such defaults.
find_package(Blender QUIET)
set(ARAP_BATCH_LAUNCHER ${CMAKE_BINARY_DIR}/arap-batch CACHE INTERNAL "The arap-batch launcher")
configure_file(${CMAKE_CURRENT_SOURCE_DIR}/addon/arap-batch ${ARAP_BATCH_LAUNCHER} COPYONLY)
file(GLOB _arap_batch_lib CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/addon/arap_batch/*.py)
foreach(_f ${_arap_batch_lib})
  get_filename_component(_name ${_f} NAME)
  configure_file(${_f} ${CMAKE_BINARY_DIR}/arap_batch/${_name} COPYONLY)
endforeach()
set(_arap_batch_blender "")
if(BLENDER_EXECUTABLE)
  set(_arap_batch_blender ${BLENDER_EXECUTABLE})
endif()
file(CONFIGURE OUTPUT ${CMAKE_BINARY_DIR}/arap_batch/build_paths.py CONTENT
"# Written by cmake/ArapBatch.cmake: where this build staged the add-on, and its Blender (\"\": none found).
ADDON_DIR = \"${ARAP_ADDON_STAGE_DIR}\"
BLENDER = \"${_arap_batch_blender}\"
")
