# The batch launcher: ${CMAKE_BINARY_DIR}/arap-batch, generated from addon/arap-batch
# with the staged add-on folder and the Blender found at configure time baked in
# (both can still be overridden with --addon-dir / --blender), and its library
# ${CMAKE_BINARY_DIR}/arap_batch/ (reports, run folders, Slurm, and the add-on's
# temp_files.py: workers and launcher name temporary files by one rule) beside
# it. Executable: it keeps the source file's permissions.
find_package(Blender QUIET)
set(ARAP_BATCH_LAUNCHER ${CMAKE_BINARY_DIR}/arap-batch CACHE INTERNAL "The arap-batch launcher")
configure_file(${CMAKE_CURRENT_SOURCE_DIR}/addon/arap-batch ${ARAP_BATCH_LAUNCHER} @ONLY)
file(GLOB _arap_batch_lib CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/addon/arap_batch/*.py)
list(APPEND _arap_batch_lib ${CMAKE_CURRENT_SOURCE_DIR}/addon/arap_deform/temp_files.py)
foreach(_f ${_arap_batch_lib})
  get_filename_component(_name ${_f} NAME)
  configure_file(${_f} ${CMAKE_BINARY_DIR}/arap_batch/${_name} COPYONLY)
endforeach()
