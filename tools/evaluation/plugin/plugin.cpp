// The `evaluation` plugin: the `visnav evaluate` command (evaluate.hpp, docs/recorded_runs.md).
#include <unistd.h>

#include <cstdio>
#include <exception>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "visnav/bt/registry.hpp"
#include "visnav/config.hpp"
#include "visnav/config_node.hpp"
#include "visnav/evaluation/evaluate.hpp"
#include "visnav/mcap.hpp"
#include "visnav/plugin.hpp"

namespace {

using namespace visnav;

const char* const kUsage =
    "usage: visnav evaluate --map M --run RUN -o out.csv [--plot out.png] [--detector D]\n"
    "                       [--param K=V]... [--set K=V]... [--edge ID]... [--start-offset-m D]\n"
    "                       [--config C] [--image-topic T] [--odom-topic T]\n"
    "\n"
    "Compares the recorded traversal RUN (visnav record) with the taught map M frame by frame, like\n"
    "stroll_bearnav's map-vs-view evaluation: for every frame, the odometric distance along the\n"
    "route (the map's feature edges laid end to end), the chosen local map (style B: nearest by\n"
    "distance) or expected landmarks (style A), the estimated horizontal offset and the inliers.\n"
    "\n"
    "  --map M             taught map folder\n"
    "  --run RUN           recorded-run folder, or an MCAP file (visnav record --format mcap, or a ROS 2 bag)\n"
    "  --config C          MCAP: take the topics from run.bag_image_topic / run.bag_odom_topic of C\n"
    "  --image-topic T     MCAP: topic of the images (wins over --config; default /camera/image_raw/compressed)\n"
    "  --odom-topic T      MCAP: topic of nav_msgs/Odometry (wins over --config; default /odom)\n"
    "  -o out.csv          per-frame CSV (docs/recorded_runs.md lists the columns)\n"
    "  --plot out.png      offset_px over the route distance\n"
    "  --detector D        detector type (default star_brief; falls back to orb); use the one the map was taught with\n"
    "  --param K=V         detector parameter (repeatable)\n"
    "  --set K=V           matching/histogram parameter (HeadingParams, repeatable)\n"
    "  --edge ID           route edges in order (repeatable); default: every feature edge in map order\n"
    "  --start-offset-m D  route distance of the run's first frame (default 0)\n"
    "\n"
    "Prints: frames, valid estimates, mean and median |offset| of valid ones, mean inliers.\n"
    "Exit status: 0 done, 1 error (named file/line), 2 usage error.\n";

int usage(const std::string& message) {
  std::fprintf(stderr, "visnav evaluate: %s\n(see 'visnav evaluate --help')\n", message.c_str());
  return 2;
}

Result<ConfigNode> key_values(const std::vector<std::string>& items, const char* label) {
  std::string yaml;
  for (const auto& kv : items) {
    const auto eq = kv.find('=');
    if (eq == std::string::npos || eq == 0) return fail(std::string(label) + " '" + kv + "': expected K=V");
    yaml += kv.substr(0, eq) + ": " + kv.substr(eq + 1) + "\n";
  }
  if (yaml.empty()) return ConfigNode{};
  return parse_yaml_string(yaml, label);
}

int run_evaluate(int argc, char** argv, HostServices& host) {
  std::string map_dir, run_dir, out_csv, plot, detector = "star_brief";
  bool detector_given = false;
  std::vector<std::string> params, sets;
  evaluation::EvaluationOptions options;
  mcap::RunTopics topics;
  std::string config_file;
  std::optional<std::string> image_topic, odom_topic;  // the command line wins over --config
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&](std::string& out) -> bool {
      if (i + 1 >= argc) return false;
      out = argv[++i];
      return true;
    };
    std::string v;
    if (a == "-h" || a == "--help") {
      std::fputs(kUsage, stdout);
      return 0;
    } else if (a == "--map") { if (!value(map_dir)) return usage("--map needs a value"); }
    else if (a == "--run") { if (!value(run_dir)) return usage("--run needs a value"); }
    else if (a == "--image-topic") { if (!value(v)) return usage("--image-topic needs a value"); image_topic = v; }
    else if (a == "--odom-topic") { if (!value(v)) return usage("--odom-topic needs a value"); odom_topic = v; }
    else if (a == "--config") { if (!value(config_file)) return usage("--config needs a value"); }
    else if (a == "-o" || a == "--out") { if (!value(out_csv)) return usage("-o needs a value"); }
    else if (a == "--plot") { if (!value(plot)) return usage("--plot needs a value"); }
    else if (a == "--detector") { if (!value(detector)) return usage("--detector needs a value"); detector_given = true; }
    else if (a == "--param") { if (!value(v)) return usage("--param needs K=V"); params.push_back(v); }
    else if (a == "--set") { if (!value(v)) return usage("--set needs K=V"); sets.push_back(v); }
    else if (a == "--edge") { if (!value(v)) return usage("--edge needs an id"); options.edges.push_back(v); }
    else if (a == "--start-offset-m") {
      if (!value(v)) return usage("--start-offset-m needs a value");
      try { options.start_offset_m = std::stod(v); } catch (...) { return usage("--start-offset-m: '" + v + "' is not a number"); }
    } else return usage("unknown argument '" + a + "'");
  }
  if (map_dir.empty() || run_dir.empty() || out_csv.empty()) return usage("--map, --run and -o are required");
  if (!config_file.empty()) {
    auto config = load_run_config(config_file, {});
    if (!config) {
      std::fprintf(stderr, "visnav evaluate: %s\n", config.error().message.c_str());
      return 1;
    }
    topics.image = config->run.bag_image_topic;
    topics.odometry = config->run.bag_odom_topic;
  }
  if (image_topic) topics.image = *image_topic;
  if (odom_topic) topics.odometry = *odom_topic;

  auto heading_node = key_values(sets, "--set");
  if (!heading_node) return usage(heading_node.error().message);
  auto heading = feature_replay::HeadingParams::schema().parse(*heading_node);
  if (!heading) return usage("--set: " + heading.error().message);
  options.heading = *heading;
  auto det_node = key_values(params, "--param");
  if (!det_node) return usage(det_node.error().message);
  auto det = host.create_detector(detector, *det_node);
  if (!det && !detector_given) {
    std::fprintf(stderr, "visnav evaluate: detector '%s' is not available (%s); falling back to orb\n", detector.c_str(),
                 det.error().message.c_str());
    det = host.create_detector("orb", *det_node);
  }
  if (!det) {
    std::fprintf(stderr, "visnav evaluate: cannot create detector: %s\n", det.error().message.c_str());
    return 1;
  }
  auto map = MapStore::open(map_dir);
  if (!map) {
    std::fprintf(stderr, "visnav evaluate: %s\n", map.error().message.c_str());
    return 1;
  }
  // An MCAP run is converted into a temporary run folder first (removed on return).
  namespace fs = std::filesystem;
  std::string folder = run_dir;
  struct Remove {
    std::string dir;
    ~Remove() {
      std::error_code ec;
      if (!dir.empty()) fs::remove_all(dir, ec);
    }
  } temp;
  std::error_code ec;
  if (fs::is_regular_file(run_dir, ec)) {
    temp.dir = (fs::temp_directory_path() / ("visnav_evaluate_" + std::to_string(::getpid()))).string();
    fs::remove_all(temp.dir, ec);
    auto converted = mcap::mcap_to_run_folder(run_dir, temp.dir, topics);
    if (!converted) {
      std::fprintf(stderr, "visnav evaluate: %s\n", converted.error().message.c_str());
      return 1;
    }
    folder = temp.dir;
  }
  auto rows = evaluation::evaluate_run(*map, folder, **det, options);
  if (!rows) {
    std::fprintf(stderr, "visnav evaluate: %s\n", rows.error().message.c_str());
    return 1;
  }
  if (auto st = evaluation::write_csv(*rows, out_csv); !st) {
    std::fprintf(stderr, "visnav evaluate: %s\n", st.error().message.c_str());
    return 1;
  }
  if (!plot.empty())
    if (auto st = evaluation::write_plot(*rows, plot, "map " + map_dir + " vs run " + run_dir); !st) {
      std::fprintf(stderr, "visnav evaluate: %s\n", st.error().message.c_str());
      return 1;
    }
  const evaluation::EvaluationSummary s = evaluation::summarize(*rows);
  std::printf("frames %ld valid %ld mean_abs_offset_px %.2f median_abs_offset_px %.2f mean_inliers %.1f -> %s%s%s\n", s.frames,
              s.valid, s.mean_abs_offset_px, s.median_abs_offset_px, s.mean_inliers, out_csv.c_str(),
              plot.empty() ? "" : ", ", plot.c_str());
  return 0;
}

const CommandEntry kCommands[] = {
    {"evaluate", "compare a recorded run with a taught map frame by frame (offsets, inliers -> CSV, PNG)",
     &guarded_command<&run_evaluate>},
};

}  // namespace

VISNAV_PLUGIN({.name = "evaluation",
               .version = "0.1.0",
               .description = "evaluation tools for recorded runs: `visnav evaluate` (map-vs-view offsets)",
               .commands = kCommands})
