# FindBlender: the Blender executable, its version and its Python version.
#
#   BLENDER_EXECUTABLE      path (cache; set it to pick another Blender)
#   BLENDER_VERSION         e.g. 3.4.1
#   BLENDER_PYTHON_VERSION  major.minor of the Python it runs, e.g. 3.11
#   Blender_FOUND
find_program(BLENDER_EXECUTABLE NAMES blender DOC "Blender executable used to run the add-on tests")

if(BLENDER_EXECUTABLE AND NOT BLENDER_PYTHON_VERSION)
  execute_process(COMMAND ${BLENDER_EXECUTABLE} --version
                  OUTPUT_VARIABLE _blender_out ERROR_QUIET TIMEOUT 60)
  string(REGEX MATCH "Blender ([0-9]+\\.[0-9]+(\\.[0-9]+)?)" _m "${_blender_out}")
  set(BLENDER_VERSION "${CMAKE_MATCH_1}" CACHE INTERNAL "Blender version")
  execute_process(
    COMMAND ${BLENDER_EXECUTABLE} --background --factory-startup -noaudio
            --python-expr "import sys; print('ARAP_PYVER=%d.%d' % sys.version_info[:2])"
    OUTPUT_VARIABLE _blender_out ERROR_QUIET TIMEOUT 120)
  string(REGEX MATCH "ARAP_PYVER=([0-9]+\\.[0-9]+)" _m "${_blender_out}")
  set(BLENDER_PYTHON_VERSION "${CMAKE_MATCH_1}" CACHE INTERNAL "Python version of Blender")
endif()

include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(Blender REQUIRED_VARS BLENDER_EXECUTABLE VERSION_VAR BLENDER_VERSION)
