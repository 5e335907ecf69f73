// Files the I/O library reads: its error type and the checks made before reading.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>

namespace arap::io {

// A file that cannot be read or written; the message names the file and the problem.
class FileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Lower-case extension of `path` without the dot ("" when none).
std::string extension_of(const std::string& path);

// Files larger than this are refused rather than read into memory.
constexpr std::uintmax_t kMaxFileBytes = std::uintmax_t(1) << 30;

// The size of `path`, a regular file of at most kMaxFileBytes; otherwise
// throws FileError naming it as `what` ("mesh file", "scenario file"):
// devices and FIFOs (/dev/zero, a pipe) would be read forever.
std::uintmax_t require_regular_file(const std::string& path, const std::string& what);

}  // namespace arap::io
