// libvisnav_visual_memory.so — edges of kind `visual_memory` (seeds 003 and 004, issue 15).
//
//  * TeachVisualMemoryEdge — teaches the edge as a chain of reference images with their local
//    3D geometry (MemoryTeacher, teacher.hpp); payload: VisualMemory (memory.hpp).
//  * ReplayVisualMemoryEdge — drives the edge by visual servoing on the references
//    (MemoryFollower, follower.hpp) with the law named by `controller`.
// Both are SDK primitive types: the runtime's adapter makes the tree nodes and handles the edge,
// payload, distance, frames, lost policy, telemetry and halt (docs/plugins.md). The nodes are
// thin: they translate the adapter's input into the core's and its answer back.
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>

#include "visnav/edge_evidence.hpp"
#include "visnav/plugin.hpp"
#include "visnav/primitive.hpp"
#include "visnav/visual_memory/follower.hpp"
#include "visnav/visual_memory/teacher.hpp"

namespace visnav::visual_memory {
namespace {

constexpr const char* kKind = "visual_memory";

class VisualMemoryTeacher final : public EdgeTeacher {
 public:
  using Params = TeachParams;
  static constexpr bool kUsesDetector = false;
  explicit VisualMemoryTeacher(const Params& params) : params_(params) {}

  Status begin(const TeachStart& /*start*/) override {
    VISNAV_ASSIGN(MemoryTeacher made, MemoryTeacher::create(params_));
    teacher_.emplace(std::move(made));
    return ok();
  }

  Status step(const TeachInput& in) override {
    if (in.frame == nullptr || in.frame_problem != nullptr) return ok();
    VISNAV_ASSIGN(TeachFrameResult r, teacher_->add_frame(in.frame->image, in.odometry, in.edge_distance_m));
    (void)r;
    return ok();
  }

  Result<TaughtEdge> finish(const TeachInput& /*last*/) override {
    VISNAV_ASSIGN(VisualMemory memory, teacher_->finish());
    TaughtEdge edge;
    edge.kind = kKind;
    edge.payload = memory.encode(params_.png_compression);
    double with_3d = 0.0;
    for (const Reference& r : memory.references) with_3d += r.count_3d();
    edge.statistics["references"] = static_cast<double>(memory.references.size());
    edge.statistics["references_without_3d"] = static_cast<double>(teacher_->references_without_3d());
    edge.statistics["points_3d_per_reference"] = with_3d / static_cast<double>(memory.references.size());
    // where the reference images are (`visnav map render` draws a tick at each)
    for (std::size_t k = 0; k < memory.references.size(); ++k) {
      char key[32];
      std::snprintf(key, sizeof key, "mark.ref%04zu_m", k);
      edge.statistics[key] = memory.references[k].distance_m;
    }
    return edge;
  }

 private:
  Params params_;
  std::optional<MemoryTeacher> teacher_;
};

class VisualMemoryReplayer final : public EdgeReplayer {
 public:
  using Params = ReplayParams;
  static constexpr bool kUsesDetector = false;
  explicit VisualMemoryReplayer(const Params& params) : params_(params) {}

  Status begin(const ReplayStart& start) override {
    VISNAV_ASSIGN(VisualMemory memory, VisualMemory::decode(start.payload));
    VISNAV_ASSIGN(MemoryFollower made, MemoryFollower::create(params_, std::move(memory), start.edge.length_m));
    follower_.emplace(std::move(made));
    return ok();
  }

  ReplayStep step(const ReplayInput& in) override {
    ReplayStep out;
    out.distance_m = in.edge_distance_m;
    if (in.frame_problem != nullptr) {
      out.status = std::string("bad frame: ") + in.frame_problem;
      return out;  // zero command, confidence 0: the lost policy decides
    }
    const FollowStep s = follower_->step(in.frame.image, in.edge_distance_m);
    out.command = s.command;
    out.confidence = s.confidence;
    out.saturated = s.saturated;
    out.matches = s.tracked;
    out.inliers = s.tracked_3d;
    out.offset_px = s.offset_norm * follower_->memory().focal_px;
    out.finished = s.finished();
    out.informative = s.status != FollowStatus::goal_by_odometry;
    out.status = std::string(to_string(s.status)) + " (reference " + std::to_string(s.target) + "/" +
                 std::to_string(follower_->memory().references.size() - 1) + ")";
    if (!s.detail.empty()) out.status += ": " + s.detail;
    if (s.status == FollowStatus::failed) {  // the follower's one failure: no reference matched
      out.failure = s.failure;
      out.failure_code = replay_failure::view_lost;
    }
    return out;
  }

 private:
  Params params_;
  std::optional<MemoryFollower> follower_;
};

Status register_nodes(bt::NodeRegistry& registry, HostServices& host) {
  VISNAV_TRY(register_teacher<VisualMemoryTeacher>(
      registry, host, "TeachVisualMemoryEdge",
      "Teaches a visual_memory edge: key reference images with their local 3D geometry (seed 003)", {kKind}));
  return register_replayer<VisualMemoryReplayer>(
      registry, host, "ReplayVisualMemoryEdge",
      "Drives a visual_memory edge by visual servoing on its reference images (seeds 003/004)", {kKind});
}

Status check_payload(std::span<const std::uint8_t> body, const EdgeRecord& edge) noexcept {
  try {
    auto memory = VisualMemory::decode(body);
    if (!memory) return std::move(memory).error();
    if (edge.from == edge.to)
      return fail(ErrorCode::inconsistent,
                  "edge from node '" + edge.from + "' to itself: a visual_memory edge joins two places");
    const double evidence_end_m = memory->references.empty() ? 0.0 : memory->references.back().distance_m;
    return check_length_evidence(edge.length_m, evidence_end_m, "reference images");
  } catch (...) {  // decode allocates; nothing may cross the ABI
    return fail("visual-memory payload reader threw an exception");
  }
}

const PayloadCheckEntry kPayloadChecks[] = {{kKind, &check_payload}};

}  // namespace
}  // namespace visnav::visual_memory

VISNAV_PLUGIN({.name = "visual_memory",
               .version = "0.1.0",
               .description = "Visual-memory edges: reference images, local 3D geometry and visual servoing "
                              "(seeds 003/004)",
               .register_nodes = &visnav::visual_memory::register_nodes,
               .payload_checks = visnav::visual_memory::kPayloadChecks})
