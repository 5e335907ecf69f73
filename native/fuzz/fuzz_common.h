// Shared by the fuzz targets: a per-process scratch file for readers that
// take a path, and the one way a target reports a broken promise.
#pragma once

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>

namespace arap_fuzz {

// The file `name` in a folder of this process's own ($ARAP_FUZZ_SCRATCH, else
// /tmp/arap-fuzz-PID), rewritten with `bytes`.
inline std::string scratch_file(const std::string& name, const uint8_t* bytes, size_t size) {
  static const std::string dir = [] {
    const char* given = std::getenv("ARAP_FUZZ_SCRATCH");
    std::string d = given ? given : "/tmp/arap-fuzz-" + std::to_string(::getpid());
    std::system(("mkdir -p '" + d + "'").c_str());
    return d;
  }();
  const std::string path = dir + "/" + name;
  std::ofstream(path, std::ios::binary | std::ios::trunc).write(reinterpret_cast<const char*>(bytes), size);
  return path;
}

// A result that breaks the library's promises (NaN positions after a
// successful solve, an index out of range after a successful read): crash so
// that libFuzzer keeps the input.
[[noreturn]] inline void broken(const char* what) {
  std::fprintf(stderr, "broken promise: %s\n", what);
  std::abort();
}

}  // namespace arap_fuzz
