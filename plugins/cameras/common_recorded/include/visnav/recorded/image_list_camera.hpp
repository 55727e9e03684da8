// visnav recorded-run helpers — a Camera over a list of image files with times (the engine of the
// `image_folder` and `recorded` camera types).
//
// grab(timeout_s): picks the frame to deliver with a FramePacer (pacing.hpp), reads it
// (cv::IMREAD_ANYCOLOR: grey stays grey, 16-bit is scaled to 8-bit), applies the ImagePipeline
// and returns it. Realtime pacing waits (at most timeout_s) for the next frame to fall due.
// Once the frame after the last one would be due (fast: at the next grab; clock: when the run
// clock passes the last frame time; realtime: one mean frame spacing after the last frame), grab()
// returns an error "<list file>: end of the image sequence after N frames" (the run loop stops
// with that reason), or starts again when `loop` is on.
// An unreadable image is an error naming the image (and the list file:line it came from).
// Frame sequence numbers: the list's sequence (recorded runs keep the recorded ones).
// Thread-safety: one thread at a time (devices.hpp).
#pragma once

#include <chrono>
#include <memory>
#include <optional>

#include "visnav/devices.hpp"
#include "visnav/host.hpp"
#include "visnav/recorded/image_pipeline.hpp"
#include "visnav/recorded/pacing.hpp"
#include "visnav/recorded/run_format.hpp"

namespace visnav::recorded {

class ImageListCamera : public Camera {
 public:
  /// `list` must be non-empty with non-decreasing times (as the readers return it).
  ImageListCamera(FrameList list, Pacing pacing, ImagePipeline pipeline, const Clock& clock, bool loop);

  Result<std::optional<Frame>> grab(double timeout_s) override;
  /// The mount from the camera's params (CameraMountOptions::mount()); nullopt until set.
  [[nodiscard]] std::optional<CameraMount> mount() const override { return mount_; }
  void set_mount(std::optional<CameraMount> mount) { mount_ = mount; }
  /// Frames delivered so far.
  [[nodiscard]] std::size_t delivered() const { return delivered_; }
  [[nodiscard]] const FrameList& list() const { return list_; }

 private:
  double wall_now_s() const;

  FrameList list_;
  std::vector<double> times_;
  FramePacer pacer_;
  ImagePipeline pipeline_;
  const Clock* clock_;
  bool loop_;
  std::optional<CameraMount> mount_;
  std::size_t next_ = 0;
  std::size_t delivered_ = 0;
  double loop_offset_s_ = 0.0;
  std::chrono::steady_clock::time_point wall_start_ = std::chrono::steady_clock::now();
};

}  // namespace visnav::recorded
