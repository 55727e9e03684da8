// A Camera over a list of image files with times (image_list_camera.hpp).
#include "visnav/recorded/image_list_camera.hpp"

#include <algorithm>
#include <thread>

#include <opencv2/imgcodecs.hpp>

namespace visnav::recorded {

ImageListCamera::ImageListCamera(FrameList list, Pacing pacing, ImagePipeline pipeline, const Clock& clock, bool loop)
    : list_(std::move(list)), pacer_(pacing), pipeline_(std::move(pipeline)), clock_(&clock), loop_(loop) {
  times_.reserve(list_.frames.size());
  for (const auto& f : list_.frames) times_.push_back(f.t_s);
}

double ImageListCamera::wall_now_s() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start_).count();
}

Result<std::optional<Frame>> ImageListCamera::grab(double timeout_s) {
  if (next_ >= times_.size() && !times_.empty() && pacer_.pacing() != Pacing::fast) {
    // The sequence ends when its next frame would have been due, not when the last one was taken.
    const double spacing = times_.size() > 1 ? (times_.back() - times_.front()) / static_cast<double>(times_.size() - 1) : 0.0;
    const bool over = pacer_.pacing() == Pacing::clock
                          ? clock_->now_s() > times_.back() + 1e-9
                          : pacer_.wait_s(times_, times_.size() - 1, wall_now_s() - spacing) <= 0.0;
    if (!over) return std::optional<Frame>{};
  }
  if (next_ >= times_.size()) {
    if (!loop_ || times_.empty())
      return fail(ErrorCode::missing, {list_.file}, "end of the image sequence after " + std::to_string(delivered_) + " frames");
    // Start again; later laps continue the time line (period = span + mean spacing).
    const double span = times_.back() - times_.front();
    const double step = times_.size() > 1 ? span / static_cast<double>(times_.size() - 1) : 0.1;
    for (double& t : times_) t += span + step;
    loop_offset_s_ += span + step;
    next_ = 0;
  }
  const double deadline = wall_now_s() + std::max(0.0, timeout_s);
  std::optional<std::size_t> index;
  for (;;) {
    index = pacer_.due(times_, next_, wall_now_s(), clock_->now_s());
    if (index || pacer_.pacing() != Pacing::realtime) break;
    const double wait = std::min(pacer_.wait_s(times_, next_, wall_now_s()), deadline - wall_now_s());
    if (wait <= 0.0) break;
    std::this_thread::sleep_for(std::chrono::duration<double>(std::min(wait, 0.05)));
  }
  if (!index) return std::optional<Frame>{};
  const FrameEntry& entry = list_.frames[*index];
  const ErrorLocation where = entry.line > 0 ? ErrorLocation{list_.file, entry.line, "file"} : ErrorLocation{entry.path};
  cv::Mat raw;
  try {
    raw = cv::imread(entry.path, cv::IMREAD_ANYCOLOR);
  } catch (const cv::Exception& e) {
    return fail(ErrorCode::io, where, "image '" + entry.path + "' cannot be read: " + e.what());
  }
  if (raw.empty())
    return fail(ErrorCode::io, where, "image '" + entry.path + "' cannot be read (missing, truncated or not an image)");
  Frame frame;
  if (auto st = pipeline_.apply(raw, frame.image); !st)
    return fail(st.error().code, where, "image '" + entry.path + "': " + st.error().message);
  frame.timestamp_s = pacer_.stamp(times_, *index, clock_->now_s());
  frame.sequence = entry.sequence;
  next_ = *index + 1;
  ++delivered_;
  return std::optional<Frame>(std::move(frame));
}

}  // namespace visnav::recorded
