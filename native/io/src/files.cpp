#include "arap/io/files.h"

#include <cctype>
#include <filesystem>

namespace arap::io {

std::string extension_of(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  if (!ext.empty()) ext.erase(0, 1);
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

std::uintmax_t require_regular_file(const std::string& path, const std::string& what) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (ec || !fs::exists(st)) throw FileError(path + ": cannot open the " + what + " (no such file)");
  if (!fs::is_regular_file(st)) throw FileError(path + ": the " + what + " is not a regular file");
  const std::uintmax_t size = fs::file_size(path, ec);
  if (ec) throw FileError(path + ": cannot read the size of the " + what);
  if (size > kMaxFileBytes) throw FileError(path + ": the " + what + " is larger than 1 GiB");
  return size;
}

}  // namespace arap::io
