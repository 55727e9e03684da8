// `visnav reloc-index MAP`: builds, rebuilds or checks a map's place index (docs/relocalisation.md).
#pragma once

#include "visnav/host.hpp"

namespace visnav::reloc {

extern const char* const kIndexUsage;
int run_reloc_index(int argc, char** argv, HostServices& host);

}  // namespace visnav::reloc
