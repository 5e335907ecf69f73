#include "memory_headroom.h"

#include "arap/errors.h"

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>

#if defined(__linux__)
#include <sys/resource.h>
#endif

namespace arap {

namespace {

using Size = std::size_t;
constexpr Size kUnknown = static_cast<Size>(-1);
// cgroup v1 writes "no limit" as a huge page-rounded number; anything above this is no limit.
constexpr Size kNoLimit = Size(1) << 60;

// The value of `key:` in a /proc file whose lines read "Key:   1234 kB", in bytes.
Size proc_kib(const char* path, const std::string& key) {
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line))
    if (line.compare(0, key.size() + 1, key + ":") == 0) {
      std::istringstream rest(line.substr(key.size() + 1));
      unsigned long long kib = 0;
      if (rest >> kib) return static_cast<Size>(kib) * 1024;
    }
  return kUnknown;
}

// A file holding one number ("max" or unreadable: unknown).
Size file_number(const std::string& path) {
  std::ifstream in(path);
  unsigned long long value = 0;
  if (!(in >> value)) return kUnknown;
  return static_cast<Size>(value);
}

void keep_least(MemoryHeadroom& h, Size bytes, const std::string& limit) {
  if (bytes < h.bytes) h.bytes = bytes, h.limit = limit;
}

// The value of `key` in a cgroup's memory.stat ("key 1234" lines), 0 if absent.
Size stat_value(const std::string& path, const std::string& key) {
  std::ifstream in(path);
  std::string name;
  unsigned long long value = 0;
  while (in >> name >> value)
    if (name == key) return static_cast<Size>(value);
  return 0;
}

// Limit less usage at `dir` and every parent folder up to `root` (a limit set
// on a parent group binds its children too). The usage counts the page cache;
// its inactive file pages are given back before the group's OOM killer runs.
void cgroup_levels(MemoryHeadroom& h, const std::string& root, std::string path, const char* max_file,
                   const char* usage_file, const char* inactive_file) {
  while (true) {
    const std::string dir = root + path;
    const Size max = file_number(dir + "/" + max_file);
    Size usage = file_number(dir + "/" + usage_file);
    if (usage != kUnknown) usage -= std::min(usage, stat_value(dir + "/memory.stat", inactive_file));
    if (max < kNoLimit && usage != kUnknown)
      keep_least(h, max > usage ? max - usage : 0, "the memory limit of cgroup " + (path.empty() ? "/" : path));
    if (path.empty() || path == "/") break;
    const size_t slash = path.find_last_of('/');
    path = slash == std::string::npos ? "" : path.substr(0, slash);
  }
}

void cgroups(MemoryHeadroom& h) {
  std::ifstream in("/proc/self/cgroup");
  std::string line;
  while (std::getline(in, line)) {
    // "hierarchy-ID:controllers:path"; v2 has ID 0 and no controllers.
    const size_t a = line.find(':'), b = line.find(':', a + 1);
    if (a == std::string::npos || b == std::string::npos) continue;
    const std::string controllers = line.substr(a + 1, b - a - 1), path = line.substr(b + 1);
    if (controllers.empty()) {
      for (const char* root : {"/sys/fs/cgroup", "/sys/fs/cgroup/unified"})
        cgroup_levels(h, root, path == "/" ? "" : path, "memory.max", "memory.current", "inactive_file");
    } else if (("," + controllers + ",").find(",memory,") != std::string::npos) {
      cgroup_levels(h, "/sys/fs/cgroup/memory", path == "/" ? "" : path, "memory.limit_in_bytes",
                    "memory.usage_in_bytes", "total_inactive_file");
    }
  }
}

}  // namespace

MemoryHeadroom memory_headroom() {
  MemoryHeadroom h;
#if defined(__linux__)
  const Size available = proc_kib("/proc/meminfo", "MemAvailable");
  const Size swap = proc_kib("/proc/meminfo", "SwapFree");
  if (available != kUnknown) keep_least(h, available + (swap == kUnknown ? 0 : swap), "the memory the system has free");
  cgroups(h);
  rlimit limit{};
  if (getrlimit(RLIMIT_AS, &limit) == 0 && limit.rlim_cur != RLIM_INFINITY) {
    const Size size = proc_kib("/proc/self/status", "VmSize");
    const Size cap = static_cast<Size>(limit.rlim_cur);
    if (size != kUnknown) keep_least(h, cap > size ? cap - size : 0, "the address-space limit (ulimit -v)");
  }
#endif
  return h;
}

std::string format_bytes(double bytes) {
  char text[32];
  if (bytes >= 1024.0 * 1024 * 1024)
    std::snprintf(text, sizeof text, "%.1f GiB", bytes / (1024.0 * 1024 * 1024));
  else
    std::snprintf(text, sizeof text, "%.0f MiB", bytes / (1024.0 * 1024));
  return text;
}

void require_headroom(double bytes, const std::string& what) {
  const MemoryHeadroom h = memory_headroom();
  if (h.limit.empty() || bytes <= static_cast<double>(h.bytes)) return;
  throw Error(ErrorCode::OutOfMemory, what + " needs about " + format_bytes(bytes) + " more memory, but only " +
                                          format_bytes(static_cast<double>(h.bytes)) + " is left under " + h.limit +
                                          "; nothing was changed (free memory, raise the limit or decimate the mesh)");
}

}  // namespace arap
