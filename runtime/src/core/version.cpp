#include "visnav/version.hpp"

namespace visnav {
const char* runtime_version() { return VISNAV_VERSION; }
}  // namespace visnav
