// visnav path following — where along the taught edge the robot is, from the edge's thumbnails.
//
// A path-following edge is ended on odometry. The teach run and the replay each have their own
// odometry scale error (a few per cent on a real robot: tyre pressure, load, ground), so a 30 m
// gravel path ends a metre early or late, and the corner after it turns that into a cross-track
// error of the next edge. The path teacher stores a low-resolution view every 0.5 m of the edge
// (VPF2 payload, visnav/path_payload.hpp); this estimator compares the live view with the taught
// views near where odometry says the robot is and keeps a smoothed correction
//     shift_m = taught distance the views say - odometric distance,
// so the replay ends the edge where the taught views end (bearnav2 corrects its distance along the
// path by matching neighbouring map images the same way).
//
// Per frame: normalised cross-correlation (best over a small horizontal shift, for heading
// differences) with every taught thumbnail within window_m of the current estimate; the best one,
// refined by a parabola through its neighbours, is a measurement when it is correlated enough,
// stands out of the window (the view changes along the path there), is not at the window's edge
// and agrees with the estimate within gate_m. Accepted measurements move the shift by `gain` of
// their innovation (an exponential smoother: odometry scale errors make the shift grow linearly,
// which a smoother follows with a lag of well under a thumbnail spacing at driving speed).
// Where nothing stands out (open grass, a view that does not change), the shift is held.
//
// Units: metres of the teach run's edge distance; the live frame is any CV_8UC1/CV_8UC3 image of
// the camera the edge was taught with. Pure: no clock, no I/O. Not thread-safe; one per edge replay.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "visnav/params.hpp"
#include "visnav/path_payload.hpp"
#include "visnav/result.hpp"

namespace visnav::path_following {

struct AlongTrackParams {
  double gain = 0.1;              ///< share of an accepted innovation taken per frame; 0 = off
  double window_m = 1.5;          ///< taught thumbnails within this of the estimate are compared, m
  int max_shift_px = 6;           ///< horizontal shift search, thumbnail pixels (of 64: about 6 deg each way)
  double min_ncc = 0.45;          ///< the best match's correlation must reach this
  double min_contrast = 0.1;      ///< and exceed the window's weakest by this (the view changes here)
  double gate_m = 1.0;            ///< innovations larger than this are ignored, m
  double max_shift_m = 3.0;       ///< |shift| bound, m

  [[nodiscard]] Status validate() const;
  static const ParamSchema<AlongTrackParams>& schema();
};

class AlongTrackEstimator {
 public:
  /// `thumbnails` by increasing distance (as decoded). Fewer than 3 thumbnails: never measures.
  AlongTrackEstimator(const AlongTrackParams& params, const std::vector<path_payload::Thumbnail>& thumbnails);

  /// One live frame at odometric edge distance `odometric_m`. Returns true when the frame gave an
  /// accepted measurement. A frame that cannot be thumbnailed is ignored.
  bool update(const cv::Mat& image, double odometric_m);

  /// Taught distance minus odometric distance, m (0 until a measurement is accepted).
  [[nodiscard]] double shift_m() const { return shift_m_; }
  /// The last frame's measurement (taught distance of the best match), valid when update() was true.
  [[nodiscard]] double last_measurement_m() const { return last_measurement_m_; }
  [[nodiscard]] int accepted() const { return accepted_; }
  [[nodiscard]] int rejected() const { return rejected_; }
  /// The edge has thumbnails to compare with and the gain is on.
  [[nodiscard]] bool active() const { return params_.gain > 0.0 && references_.size() >= 3; }

 private:
  AlongTrackParams params_;
  std::vector<double> distance_m_;
  std::vector<cv::Mat> references_;  // normalised, CV_32FC1
  std::vector<double> scores_;       // per reference, this frame (reused)
  cv::Mat live_u8_;
  cv::Mat live_;
  double shift_m_ = 0.0;
  double last_measurement_m_ = 0.0;
  int accepted_ = 0;
  int rejected_ = 0;
  int width_px_ = path_payload::kThumbnailWidthPx;
  int height_px_ = path_payload::kThumbnailHeightPx;
};

}  // namespace visnav::path_following
