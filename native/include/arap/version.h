#pragma once

namespace arap {
// Bumped with the project version in the top-level CMakeLists.txt.
const char* version();
}  // namespace arap
