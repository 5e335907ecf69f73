# The batch launcher: ${CMAKE_BINARY_DIR}/arap-batch, generated from addon/arap-batch
# with the staged add-on folder and the Blender found at configure time baked in
# (both can still be overridden with --addon-dir / --blender). Executable: it
# keeps the source file's permissions.
find_package(Blender QUIET)
set(ARAP_BATCH_LAUNCHER ${CMAKE_BINARY_DIR}/arap-batch CACHE INTERNAL "The arap-batch launcher")
configure_file(${CMAKE_CURRENT_SOURCE_DIR}/addon/arap-batch ${ARAP_BATCH_LAUNCHER} @ONLY)
