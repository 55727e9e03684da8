// Internal helpers of the detector core (not installed, not part of the public API).
#pragma once

#include <opencv2/core/mat.hpp>

namespace visnav::detectors {

/// Makes `m` a rows×cols matrix of `type`, reusing its buffer when nobody else references it.
/// A buffer still shared with another Mat (e.g. features a caller kept from the previous frame)
/// is released instead of overwritten.
inline void prepare_output(cv::Mat& m, int rows, int cols, int type) {
  if (m.u != nullptr && m.u->refcount > 1) m.release();
  if (rows == 0) {
    m.release();
    return;
  }
  m.create(rows, cols, type);
}

}  // namespace visnav::detectors
