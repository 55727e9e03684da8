// visnav SDK — version of the runtime library the code is linked against.
#pragma once

namespace visnav {
/// Semantic version string of the runtime library, e.g. "0.1.0".
const char* runtime_version();
}  // namespace visnav
