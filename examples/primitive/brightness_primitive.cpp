// Example out-of-tree navigation primitive, edge kind "brightness". TeachBrightnessEdge stores
// the mean grey level of the camera image every sample_spacing_m along the edge;
// ReplayBrightnessEdge drives the edge straight at speed_mps and reports how well the view's
// brightness matches the taught one as its confidence, so the runtime's lost policy stops the
// robot when the view stops matching. The runtime's adapter does the rest (ports, edge lookup,
// payload read, distance, frames, telemetry, halt): a primitive is params, a teacher, a
// replayer and two registration lines.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

#include <opencv2/core.hpp>
#include <visnav/plugin.hpp>
#include <visnav/primitive.hpp>

namespace {

constexpr const char* kKind = "brightness";
constexpr std::uint32_t kMagic = 0x56425231;  // "VBR1": brightness profile, version 1

struct BrightnessParams {
  double sample_spacing_m = 0.25;  ///< teach: one sample per this distance
  double speed_mps = 0.3;          ///< replay: forward speed
  double tolerance_levels = 40.0;  ///< replay: grey-level difference at which the confidence is 0

  [[nodiscard]] visnav::Status validate() const { return schema().check(*this); }
  static const visnav::ParamSchema<BrightnessParams>& schema() {
    using P = BrightnessParams;
    static const auto s = visnav::ParamSchema<P>{}
                              .field("sample_spacing_m", &P::sample_spacing_m, "teach: distance between samples, m")
                              .range(0.05, 10.0)
                              .field("speed_mps", &P::speed_mps, "replay: forward speed, m/s")
                              .range(0.05, 1.0)
                              .field("tolerance_levels", &P::tolerance_levels,
                                     "replay: brightness difference (grey levels) at which the confidence reaches 0")
                              .range(1.0, 255.0);
    return s;
  }
};

double mean_grey(const cv::Mat& image) {
  const cv::Scalar m = cv::mean(image);
  return image.channels() == 1 ? m[0] : (m[0] + m[1] + m[2]) / 3.0;
}

/// Payload body: magic, sample spacing (m), sample count, one grey level per sample.
struct Profile {
  double spacing_m = 0.0;
  std::vector<double> grey;

  [[nodiscard]] std::vector<std::uint8_t> encode() const {
    visnav::PayloadWriter w;
    w.put<std::uint32_t>(kMagic);
    w.put<double>(spacing_m);
    w.put<std::uint32_t>(static_cast<std::uint32_t>(grey.size()));
    for (double g : grey) w.put<double>(g);
    return w.take();
  }
  static visnav::Result<Profile> decode(std::span<const std::uint8_t> body) {
    visnav::PayloadReader r(body);
    Profile p;
    VISNAV_ASSIGN(auto magic, r.get<std::uint32_t>());
    if (magic != kMagic) return visnav::fail("not a brightness profile (bad magic)");
    VISNAV_ASSIGN(p.spacing_m, r.get<double>());
    VISNAV_ASSIGN(auto count, r.get<std::uint32_t>());
    if (!(p.spacing_m > 0.0) || count == 0 || count > body.size()) return visnav::fail("inconsistent profile");
    p.grey.resize(count);
    for (double& g : p.grey) { VISNAV_ASSIGN(g, r.get<double>()); }
    if (!r.at_end()) return visnav::fail("trailing bytes after the profile");
    return p;
  }
};

class BrightnessTeacher final : public visnav::EdgeTeacher {
 public:
  using Params = BrightnessParams;
  static constexpr bool kUsesDetector = false;
  explicit BrightnessTeacher(const Params& params) { profile_.spacing_m = params.sample_spacing_m; }

  visnav::Status begin(const visnav::TeachStart&) override { return visnav::ok(); }
  visnav::Status step(const visnav::TeachInput& in) override {
    if (in.frame == nullptr || in.frame_problem != nullptr) return visnav::ok();
    const double grey = mean_grey(in.frame->image);
    while (in.edge_distance_m >= static_cast<double>(profile_.grey.size()) * profile_.spacing_m)
      profile_.grey.push_back(grey);
    return visnav::ok();
  }
  visnav::Result<visnav::TaughtEdge> finish(const visnav::TeachInput&) override {
    if (profile_.grey.empty()) return visnav::fail("no usable frame on the edge");
    return visnav::TaughtEdge{kKind, profile_.encode(), {{"samples", static_cast<double>(profile_.grey.size())}}};
  }

 private:
  Profile profile_;
};

class BrightnessReplayer final : public visnav::EdgeReplayer {
 public:
  using Params = BrightnessParams;
  static constexpr bool kUsesDetector = false;
  explicit BrightnessReplayer(const Params& params) : params_(params) {}

  visnav::Status begin(const visnav::ReplayStart& start) override {
    VISNAV_ASSIGN(profile_, Profile::decode(start.payload));
    length_m_ = start.edge.length_m;
    return visnav::ok();
  }
  visnav::ReplayStep step(const visnav::ReplayInput& in) override {
    visnav::ReplayStep out;
    out.distance_m = in.edge_distance_m;
    if (in.edge_distance_m >= length_m_) {
      out.finished = true;
      out.informative = false;  // the end is odometric
      out.status = "edge done";
      return out;
    }
    const auto i = static_cast<std::size_t>(std::max(0.0, in.edge_distance_m / profile_.spacing_m));
    const double taught = profile_.grey[std::min(i, profile_.grey.size() - 1)];
    const double diff = in.frame_problem != nullptr ? params_.tolerance_levels : std::abs(mean_grey(in.frame.image) - taught);
    out.confidence = std::max(0.0, 1.0 - diff / params_.tolerance_levels);
    out.command = visnav::Twist{params_.speed_mps, 0.0};
    out.status = "driving";
    return out;
  }

 private:
  Params params_;
  Profile profile_;
  double length_m_ = 0.0;
};

visnav::Status register_nodes(visnav::bt::NodeRegistry& registry, visnav::HostServices& host) {
  VISNAV_TRY(visnav::register_teacher<BrightnessTeacher>(registry, host, "TeachBrightnessEdge",
                                                         "teaches a brightness edge (example primitive)", {kKind}));
  return visnav::register_replayer<BrightnessReplayer>(registry, host, "ReplayBrightnessEdge",
                                                       "drives a brightness edge (example primitive)", {kKind});
}

}  // namespace

VISNAV_PLUGIN({.name = "brightness_primitive",
               .version = "1.0",
               .description = "example out-of-tree navigation primitive",
               .register_nodes = &register_nodes})
