# Removes from the staged add-on (STAGE) the .py and .toml files that are not listed in KEEP (one path
# relative to STAGE per line): modules moved or deleted in the sources, which Blender would still load.
cmake_minimum_required(VERSION 3.16)
file(STRINGS ${KEEP} _keep)
file(GLOB_RECURSE _found RELATIVE ${STAGE} ${STAGE}/*.py ${STAGE}/*.toml)
foreach(f ${_found})
  if(NOT f IN_LIST _keep)
    message(STATUS "Removing ${STAGE}/${f} (no longer in the sources)")
    file(REMOVE ${STAGE}/${f})
  endif()
endforeach()
