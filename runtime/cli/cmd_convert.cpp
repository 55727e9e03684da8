// `visnav convert IN OUT`: a recorded-run folder to an MCAP file (ROS 2 bag) and back.
#include <filesystem>
#include <iostream>

#include "args.hpp"
#include "command.hpp"
#include "mcap_input.hpp"
#include "visnav/mcap.hpp"

namespace {

namespace fs = std::filesystem;

constexpr const char* kUsage =
    "usage: visnav convert IN OUT [--config C] [--image-topic T] [--odom-topic T] [--compression zstd|lz4|none]\n"
    "                      [--no-compression] [--force]\n"
    "\n"
    "Converts between the two recorded-run formats (docs/recorded_runs.md):\n"
    "  IN a folder, OUT a file   folder -> MCAP: frames as sensor_msgs/msg/CompressedImage (the PNG/JPEG\n"
    "                            bytes unchanged), odometry as nav_msgs/msg/Odometry, the tick commands as\n"
    "                            geometry_msgs/msg/Twist, ground truth, plus visnav's exact rows and\n"
    "                            run.yaml/config.yaml and the mission's telemetry (telemetry.jsonl) as\n"
    "                            /visnav/telemetry + /visnav/status; zstd chunks (or --compression)\n"
    "  IN an .mcap file          MCAP -> folder: a bag written by `visnav record --format mcap` comes\n"
    "                            back exactly; a bag recorded on a ROS 2 robot gives frames from\n"
    "                            --image-topic and odometry from --odom-topic (the odometric distance\n"
    "                            is the path length of the positions)\n"
    "\n"
    "  --config C        take the topics from run.bag_image_topic / run.bag_odom_topic of C\n"
    "  --image-topic T   images (sensor_msgs Image: mono8/bgr8/rgb8, or CompressedImage);\n"
    "                    default /camera/image_raw/compressed\n"
    "  --odom-topic T    nav_msgs/msg/Odometry; default /odom\n"
    "  --compression C   chunk compression of an MCAP OUT: zstd (default), lz4 or none\n"
    "  --no-compression  same as --compression none\n"
    "  --force           replace an existing OUT\n"
    "\n"
    "Exit status: 0 converted, 1 error (the message names the file, byte offset or topic), 2 usage.\n";

int convert(const std::vector<std::string>& raw) {
  using visnav::cli::Opt;
  std::vector<std::string> args = raw;
  std::vector<std::string> positional;
  while (!args.empty() && args[0].rfind("-", 0) != 0) {
    positional.push_back(args[0]);
    args.erase(args.begin());
  }
  visnav::cli::Args a;
  if (auto st = a.parse(args, {{"--image-topic", Opt::value}, {"--odom-topic", Opt::value}, {"--config", Opt::value},
                               {"--compression", Opt::value}, {"--no-compression", Opt::flag}, {"--force", Opt::flag}});
      !st)
    return visnav::cli::usage_error("convert", st.error().message);
  if (positional.size() != 2) return visnav::cli::usage_error("convert", "expected IN and OUT");
  const std::string compression = a.has("--no-compression") ? "none" : a.get("--compression", "zstd");
  if (compression != "zstd" && compression != "lz4" && compression != "none")
    return visnav::cli::usage_error("convert", "--compression must be zstd, lz4 or none, got '" + compression + "'");
  const std::string in = positional[0], out = positional[1];
  std::error_code ec;
  if (!fs::exists(in, ec)) {
    std::cerr << "visnav convert: " << in << " does not exist\n";
    return 1;
  }
  if (fs::exists(out, ec)) {
    if (!a.has("--force")) {
      std::cerr << "visnav convert: " << out << " exists (use --force to replace it)\n";
      return 1;
    }
    fs::remove_all(out, ec);
  }
  if (fs::is_directory(in, ec)) {
    visnav::mcap::WriterOptions o;
    o.compress = compression != "none";
    if (o.compress) o.compression = compression;
    auto r = visnav::mcap::run_folder_to_mcap(in, out, o);
    if (!r) {
      std::cerr << "visnav convert: " << r.error().message << "\n";
      return 1;
    }
    std::cout << "visnav convert: " << r->frames << " frames, " << r->odometry_samples << " odometry samples, " << r->ticks
              << " ticks, " << r->telemetry << " statuses -> " << out << " (MCAP"
              << ((compression == "zstd" && visnav::mcap::zstd_available()) || (compression == "lz4" && visnav::mcap::lz4_available())
                      ? ", " + compression : std::string())
              << ")\n";
    return 0;
  }
  auto topics = visnav::cli::bag_topics(a, a.get("--config"));
  if (!topics) {
    std::cerr << "visnav convert: " << topics.error().message << "\n";
    return 1;
  }
  auto r = visnav::mcap::mcap_to_run_folder(in, out, topics->run);
  if (!r) {
    std::cerr << "visnav convert: " << r.error().message << "\n";
    return 1;
  }
  std::cout << "visnav convert: " << r->frames << " frames, " << r->odometry_samples << " odometry samples, " << r->ticks
            << " ticks -> " << out << (r->exact ? " (exact: a visnav recording)" : " (from the bag's topics)")
            << (r->truncated ? "; the bag ends early (a killed recording): converted up to its last complete chunk" : "")
            << "\n";
  return 0;
}

}  // namespace

VISNAV_COMMAND(convert, "convert", "convert a recorded run between the folder format and MCAP (ROS 2 bag)", kUsage, &convert)
