#include "arap/version.h"

namespace arap {
const char* version() { return ARAP_VERSION; }
}  // namespace arap
