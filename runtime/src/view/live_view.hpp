// `visnav run --view PORT`: the run as live channels of a Foxglove WebSocket server
// (docs/live_view.md). Channels (JSON encoding; Foxglove's well-known schemas where one exists):
//   /camera        foxglove.CompressedImage  every new camera frame (JPEG)
//   /camera/annotations foxglove.ImageAnnotations  what the active primitive saw in that frame
//                                            (matched features, heading histogram, path
//                                            segmentation; view/overlay.hpp), same timestamp
//   /camera/overlay foxglove.CompressedImage the frame with those overlays drawn in
//   /robot/pose    foxglove.PoseInFrame      odometry pose (frame "odom"), every tick
//   /map           foxglove.SceneUpdate      the map graph: nodes as spheres, edges as lines
//                                            (colour by primitive), every 2 s
//   /telemetry     visnav.NavStatus          each status a node publishes (edge, confidence
//                                            inputs, command), plus the tick
//   /bt            visnav.TreeStatus         every node's status after each tick
// Work is only done for channels somebody subscribes to. Thread-safety: after_tick() and the
// telemetry sink run in the tick thread; the server has its own thread.
#pragma once

#include <memory>
#include <string>

#include "view/foxglove_server.hpp"
#include "view/overlay.hpp"
#include "visnav/bt/tree.hpp"
#include "visnav/host.hpp"
#include "visnav/runner.hpp"

namespace visnav::view {

class LiveView final : public Telemetry {
 public:
  /// Starts the server on `port` (0 = any free port). The view wraps the session's telemetry
  /// (statuses still reach the original sinks) until it is destroyed.
  [[nodiscard]] static Result<std::unique_ptr<LiveView>> create(int port, Session& session, bool all_interfaces = false);
  ~LiveView() override;
  LiveView(const LiveView&) = delete;
  LiveView& operator=(const LiveView&) = delete;

  /// Publishes this tick's frame, pose, tree statuses and (every 2 s of run time) the map.
  void after_tick(const TickInfo& tick, const bt::Tree& tree);
  void publish(const NavStatus& status) override;
  [[nodiscard]] int port() const { return server_->port(); }
  [[nodiscard]] const FoxgloveServer& server() const { return *server_; }

 private:
  LiveView() = default;
  std::unique_ptr<FoxgloveServer> server_;
  Session* session_ = nullptr;
  std::uint64_t last_frame_sequence_ = ~std::uint64_t{0};
  double last_frame_t_s_ = -1.0;
  double last_map_t_s_ = -1e9;
  std::uint64_t tick_ = 0;
  OverlayCopy overlay_;  // the newest primitive overlay of this tick (copied only for subscribers)
  cv::Mat drawn_;        // /camera/overlay buffer
};

}  // namespace visnav::view
