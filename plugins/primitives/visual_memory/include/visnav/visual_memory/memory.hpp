// visnav visual memory — the taught path as a chain of key reference images (seed 003 Fig. 2).
// The types and the payload codec are in the SDK (visnav/visual_memory_payload.hpp) so that other
// plugins (the place index of relocalisation) read visual-memory edges without this plugin's headers.
#pragma once

#include "visnav/visual_memory_payload.hpp"
