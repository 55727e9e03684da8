// feature_replay core — descriptor matching and histogram-voting heading estimation. The estimator
// is in the SDK (visnav/histogram_voting.hpp) so that relocalisation shares it.
#pragma once

#include "visnav/histogram_voting.hpp"
