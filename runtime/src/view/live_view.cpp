#include "view/live_view.hpp"

#include <cmath>
#include <cstdio>
#include <map>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "visnav/map.hpp"
#include "visnav/runtime_host.hpp"

namespace visnav::view {
namespace {

enum Channel : std::uint32_t { kCamera = 1, kPose = 2, kMap = 3, kTelemetry = 4, kTree = 5, kAnnotations = 6, kOverlay = 7 };

constexpr const char* kObjectSchema = "{\"type\":\"object\"}";

std::string num(double v) {
  if (!std::isfinite(v)) return "0";
  char b[32];
  std::snprintf(b, sizeof b, "%.9g", v);
  return b;
}

std::uint64_t to_ns(double t_s) { return t_s <= 0.0 ? 0 : static_cast<std::uint64_t>(std::llround(t_s * 1e9)); }

std::string stamp(double t_s) {
  const std::uint64_t ns = to_ns(t_s);
  return "{\"sec\":" + std::to_string(ns / 1000000000ULL) + ",\"nsec\":" + std::to_string(ns % 1000000000ULL) + "}";
}

std::string quaternion_yaw(double yaw) {
  return "{\"x\":0,\"y\":0,\"z\":" + num(std::sin(yaw / 2)) + ",\"w\":" + num(std::cos(yaw / 2)) + "}";
}

std::string color_of(const std::string& kind) {
  if (kind.rfind("path", 0) == 0) return "{\"r\":0.2,\"g\":0.8,\"b\":0.2,\"a\":1}";
  if (kind.rfind("feature", 0) == 0) return "{\"r\":0.2,\"g\":0.5,\"b\":1,\"a\":1}";
  return "{\"r\":0.8,\"g\":0.8,\"b\":0.8,\"a\":1}";
}

/// Node positions: the taught position hint, else chained along edges from the first node.
std::map<std::string, Pose2D> layout(const MapStore& map) {
  std::map<std::string, Pose2D> pos;
  for (const auto& n : map.nodes())
    if (n.position_hint) pos[n.id] = *n.position_hint;
  if (!map.nodes().empty() && pos.empty()) pos[map.nodes().front().id] = Pose2D{};
  for (std::size_t pass = 0; pass < map.edges().size() + 1; ++pass) {
    bool changed = false;
    for (const auto& e : map.edges()) {
      if (pos.count(e.from) != 0 && pos.count(e.to) == 0) {
        const Pose2D& a = pos[e.from];
        pos[e.to] = {a.x_m + e.length_m * std::cos(e.azimuth_rad), a.y_m + e.length_m * std::sin(e.azimuth_rad), 0.0};
        changed = true;
      }
    }
    if (!changed) break;
  }
  for (const auto& n : map.nodes())
    if (pos.count(n.id) == 0) pos[n.id] = Pose2D{};
  return pos;
}

std::string scene_update(const MapStore& map, double t_s) {
  const auto pos = layout(map);
  std::string spheres, lines, texts;
  for (const auto& n : map.nodes()) {
    const Pose2D& p = pos.at(n.id);
    const std::string pose = "{\"position\":{\"x\":" + num(p.x_m) + ",\"y\":" + num(p.y_m) + ",\"z\":0},\"orientation\":" +
                             quaternion_yaw(0) + "}";
    if (!spheres.empty()) spheres += ',';
    spheres += "{\"pose\":" + pose +
               ",\"size\":{\"x\":0.4,\"y\":0.4,\"z\":0.4},\"color\":{\"r\":1,\"g\":0.6,\"b\":0,\"a\":1}}";
    if (!texts.empty()) texts += ',';
    texts += "{\"pose\":" + pose + ",\"billboard\":true,\"font_size\":14,"
             "\"scale_invariant\":true,\"color\":{\"r\":1,\"g\":1,\"b\":1,\"a\":1},\"text\":\"" +
             json_escape(n.name.empty() ? n.id : n.name) + "\"}";
  }
  for (const auto& e : map.edges()) {
    const Pose2D& a = pos.at(e.from);
    const Pose2D& b = pos.at(e.to);
    if (!lines.empty()) lines += ',';
    lines += std::string("{\"type\":0,\"pose\":{\"position\":{\"x\":0,\"y\":0,\"z\":0},\"orientation\":") +
             quaternion_yaw(0) + "},\"thickness\":0.1,\"scale_invariant\":false,\"points\":[{\"x\":" + num(a.x_m) + ",\"y\":" +
             num(a.y_m) + ",\"z\":0},{\"x\":" + num(b.x_m) + ",\"y\":" + num(b.y_m) + ",\"z\":0}],\"color\":" + color_of(e.kind) +
             ",\"colors\":[],\"indices\":[]}";
  }
  return "{\"deletions\":[],\"entities\":[{\"timestamp\":" + stamp(t_s) +
         ",\"frame_id\":\"odom\",\"id\":\"map\",\"lifetime\":{\"sec\":0,\"nsec\":0},\"frame_locked\":false,\"metadata\":[],"
         "\"arrows\":[],\"cubes\":[],\"spheres\":[" + spheres + "],\"cylinders\":[],\"lines\":[" + lines +
         "],\"triangles\":[],\"texts\":[" + texts + "],\"models\":[]}]}";
}

}  // namespace

Result<std::unique_ptr<LiveView>> LiveView::create(int port, Session& session, bool all_interfaces) {
  std::unique_ptr<LiveView> v(new LiveView());
  std::vector<ChannelInfo> channels{
      {"/camera", "json", "foxglove.CompressedImage", kObjectSchema, "jsonschema"},
      {"/robot/pose", "json", "foxglove.PoseInFrame", kObjectSchema, "jsonschema"},
      {"/map", "json", "foxglove.SceneUpdate", kObjectSchema, "jsonschema"},
      {"/telemetry", "json", "visnav.NavStatus", kObjectSchema, "jsonschema"},
      {"/bt", "json", "visnav.TreeStatus", kObjectSchema, "jsonschema"},
      {"/camera/annotations", "json", "foxglove.ImageAnnotations", kObjectSchema, "jsonschema"},
      {"/camera/overlay", "json", "foxglove.CompressedImage", kObjectSchema, "jsonschema"}};
  VISNAV_ASSIGN(v->server_, FoxgloveServer::create(port, std::move(channels), all_interfaces));
  v->session_ = &session;
  session.add_telemetry_sink(v.get());
  return v;
}

LiveView::~LiveView() {
  if (session_ != nullptr) session_->remove_telemetry_sink(this);
}

void LiveView::publish(const NavStatus& s) {
  if (s.overlay != nullptr && (server_->has_subscribers(kAnnotations) || server_->has_subscribers(kOverlay)))
    overlay_.copy_from(*s.overlay);  // the pointer dies with this call
  if (!server_->has_subscribers(kTelemetry)) return;
  const double t_s = session_->clock().now_s();
  const std::string json = "{\"t_s\":" + num(t_s) + ",\"tick\":" + std::to_string(tick_) + ",\"node_path\":\"" +
                           json_escape(s.node_path) + "\",\"map_node\":\"" + json_escape(s.map_node) + "\",\"edge\":\"" +
                           json_escape(s.edge) + "\",\"distance_m\":" + num(s.distance_m) + ",\"matches\":" +
                           std::to_string(s.matches) + ",\"inliers\":" + std::to_string(s.inliers) + ",\"offset_px\":" +
                           num(s.offset_px) + ",\"linear_mps\":" + num(s.command.linear_mps) + ",\"angular_radps\":" +
                           num(s.command.angular_radps) + ",\"status\":\"" + json_escape(s.status) + "\"}";
  server_->publish(kTelemetry, to_ns(t_s), json);
}

void LiveView::after_tick(const TickInfo& tick, const bt::Tree& tree) {
  tick_ = tick.tick;
  const std::uint64_t ns = to_ns(tick.t_s);
  const bool camera = server_->has_subscribers(kCamera);
  const bool annotations = server_->has_subscribers(kAnnotations);
  const bool overlay = server_->has_subscribers(kOverlay);
  if (camera || annotations || overlay) {
    if (auto f = session_->frame_bus().latest_frame();
        f && !f->image.empty() && (f->sequence != last_frame_sequence_ || f->timestamp_s != last_frame_t_s_)) {
      last_frame_sequence_ = f->sequence;
      last_frame_t_s_ = f->timestamp_s;
      auto publish_jpeg = [&](std::uint32_t channel, const cv::Mat& image) {
        std::vector<std::uint8_t> jpeg;
        if (!cv::imencode(".jpg", image, jpeg, {cv::IMWRITE_JPEG_QUALITY, 80})) return;
        const std::string data = base64(std::string(jpeg.begin(), jpeg.end()));
        server_->publish(channel, to_ns(f->timestamp_s),
                         "{\"timestamp\":" + stamp(f->timestamp_s) + ",\"frame_id\":\"camera\",\"format\":\"jpeg\",\"data\":\"" +
                             data + "\"}");
      };
      if (camera) publish_jpeg(kCamera, f->image);
      // Stamped like the frame, so Foxglove's Image panel pairs the annotations with it.
      if (annotations) server_->publish(kAnnotations, to_ns(f->timestamp_s), annotations_json(overlay_, f->image.size(), f->timestamp_s));
      if (overlay) {
        if (f->image.channels() == 1) cv::cvtColor(f->image, drawn_, cv::COLOR_GRAY2BGR);
        else f->image.copyTo(drawn_);
        draw_overlay(drawn_, overlay_);
        publish_jpeg(kOverlay, drawn_);
      }
    }
  }
  overlay_.clear();  // an overlay belongs to the tick that produced it
  if (server_->has_subscribers(kPose)) {
    if (auto o = session_->frame_bus().latest_odometry()) {
      server_->publish(kPose, ns,
                       "{\"timestamp\":" + stamp(o->timestamp_s) + ",\"frame_id\":\"odom\",\"pose\":{\"position\":{\"x\":" +
                           num(o->pose.x_m) + ",\"y\":" + num(o->pose.y_m) + ",\"z\":0},\"orientation\":" +
                           quaternion_yaw(o->pose.heading_rad) + "}}");
    }
  }
  if (server_->has_subscribers(kMap) && session_->map() != nullptr && tick.t_s - last_map_t_s_ >= 2.0) {
    last_map_t_s_ = tick.t_s;
    server_->publish(kMap, ns, scene_update(*session_->map(), tick.t_s));
  }
  if (server_->has_subscribers(kTree)) {
    std::string nodes;
    tree.visit([&](bt::TreeNode& n) {
      if (!nodes.empty()) nodes += ',';
      nodes += "{\"path\":\"" + json_escape(n.path()) + "\",\"id\":\"" +
               json_escape(n.registration_id()) + "\",\"status\":\"" + bt::to_string(n.status()) + "\"}";
    });
    server_->publish(kTree, ns, "{\"t_s\":" + num(tick.t_s) + ",\"tick\":" + std::to_string(tick.tick) + ",\"root\":\"" +
                                    bt::to_string(tick.status) + "\",\"nodes\":[" + nodes + "]}");
  }
}

}  // namespace visnav::view
