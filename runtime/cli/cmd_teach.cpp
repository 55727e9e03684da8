// `visnav teach --run RUN --map M`: teach a map offline from a recorded drive (folder or MCAP),
// as a live teach would have taught it — by playing RUN with trees/teach_recorded.xml.
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include "args.hpp"
#include "command.hpp"
#include "mcap_input.hpp"
#include "visnav/config.hpp"

namespace {

namespace fs = std::filesystem;

constexpr const char* kUsage =
    "usage: visnav teach --run RUN --map M [--marks F | --primitive KIND | --joy-topic T [--mapping F]] [--config C]\n"
    "                    [--tree T] [--close-loop]\n"
    "                    [--end-margin-s S] [--set k=v]... [--bb k=v]... [--image-topic T] [--odom-topic T]\n"
    "                    [--log-level L]\n"
    "\n"
    "Builds the map M from a recorded drive RUN — a recorded-run folder, an MCAP file written by\n"
    "`visnav record --format mcap`, or a ROS 2 bag (then give --config C and the topics) — the way a\n"
    "live teach of that drive would: the recording is played back (`visnav play`) with the tree\n"
    "trees/teach_recorded.xml, whose RecordedOperator switches the primitive at the times of the\n"
    "marks file.\n"
    "\n"
    "  --run RUN          the recorded drive\n"
    "  --map M            map folder to write (created)\n"
    "  --marks F          CSV t_s,primitive (run-clock times; primitive '' = turning, not recorded);\n"
    "                     default RUN/marks.csv\n"
    "  --primitive KIND   no marks: teach the whole drive as one edge of this kind (e.g. feature_segment)\n"
    "  --joy-topic T      MCAP RUN: the marks are the gamepad's primitive-button presses recorded on this\n"
    "                     sensor_msgs/msg/Joy topic (e.g. /joy), bound by --mapping (default\n"
    "                     run.bag_joy_topic of --config, unless --marks or --primitive is given)\n"
    "  --mapping F        operator mapping with primitive_buttons (default config/teleop/gamepad.yaml)\n"
    "  --config C         configuration (detector, nodes); default the recording's config.yaml\n"
    "  --tree T           teaching tree (default trees/teach_recorded.xml of the source tree)\n"
    "  --close-loop       the drive ends where it started: the last edge ends at the start node\n"
    "  --end-margin-s S   teaching ends S s before the recording does (default 0.5), so the last edge\n"
    "                     is stored before the playback runs out of data\n"
    "  --set, --bb        as `visnav play`; `nodes` is set to the teaching tree's plugins\n"
    "                     (navigation, feature_replay, path_following, teleop) before any --set\n"
    "  --image-topic T, --odom-topic T   topics of a ROS 2 bag (as `visnav convert`; default\n"
    "                     run.bag_image_topic / run.bag_odom_topic of --config)\n"
    "\n"
    "Exit status: as `visnav play` (0 when the map was taught).\n";

const visnav::cli::Command* find_command(const std::string& name) {
  for (const auto& c : visnav::cli::commands())
    if (name == c.name) return &c;
  return nullptr;
}

int teach(const std::vector<std::string>& args) {
  using visnav::cli::Opt;
  visnav::cli::Args a;
  if (auto st = a.parse(args, {{"--run", Opt::value}, {"--map", Opt::value}, {"--marks", Opt::value},
                               {"--primitive", Opt::value}, {"--config", Opt::value}, {"--tree", Opt::value},
                               {"--close-loop", Opt::flag}, {"--end-margin-s", Opt::value}, {"--set", Opt::repeated},
                               {"--bb", Opt::repeated}, {"--image-topic", Opt::value}, {"--odom-topic", Opt::value},
                               {"--log-level", Opt::value}, {"--joy-topic", Opt::value}, {"--mapping", Opt::value}});
      !st)
    return visnav::cli::usage_error("teach", st.error().message);
  if (auto st = a.require({"--run", "--map"}); !st) return visnav::cli::usage_error("teach", st.error().message);
  if (static_cast<int>(a.has("--marks")) + static_cast<int>(a.has("--primitive")) + static_cast<int>(a.has("--joy-topic")) > 1)
    return visnav::cli::usage_error("teach", "give one of --marks, --primitive and --joy-topic");
  double margin_s = 0.5;
  try {
    margin_s = std::stod(a.get("--end-margin-s", "0.5"));
  } catch (...) {
    return visnav::cli::usage_error("teach", "--end-margin-s needs a number");
  }

  auto topics = visnav::cli::bag_topics(a, a.get("--config"), a.all("--set"));
  if (!topics) {
    std::cerr << "visnav teach: " << topics.error().message << "\n";
    return 1;
  }
  // run.bag_joy_topic applies unless the switches are given another way.
  if (a.has("--marks") || a.has("--primitive")) topics->joy.clear();
  visnav::cli::TempRun temp;
  auto folder = visnav::cli::run_folder_of(a.get("--run"), topics->run, temp);
  if (!folder) {
    std::cerr << "visnav teach: " << folder.error().message << "\n";
    return 1;
  }
  const fs::path run(*folder);

  // The end of the recording: the last frame's time.
  std::ifstream frames(run / "frames.csv");
  if (!frames) {
    std::cerr << "visnav teach: " << a.get("--run") << ": not a recorded run (no frames.csv)\n";
    return 1;
  }
  double last_t_s = 0.0;
  bool any = false;
  for (std::string line; std::getline(frames, line);) {
    if (line.empty() || line[0] == '#' || line.rfind("index", 0) == 0) continue;
    const auto c1 = line.find(',');
    if (c1 == std::string::npos) continue;
    try {
      last_t_s = std::stod(line.substr(c1 + 1));
      any = true;
    } catch (...) {
    }
  }
  if (!any) {
    std::cerr << "visnav teach: " << a.get("--run") << " has no frames\n";
    return 1;
  }

  std::string marks = a.get("--marks");
  fs::path generated;
  if (!topics->joy.empty()) {
    // The gamepad's primitive buttons, as the Teleop node binds them.
    const std::string mapping =
        a.get("--mapping", (fs::path(VISNAV_SOURCE_DIR) / "config" / "teleop" / "gamepad.yaml").string());
    auto root = visnav::parse_yaml_file(mapping);
    if (!root) {
      std::cerr << "visnav teach: " << root.error().message << "\n";
      return 1;
    }
    std::vector<std::pair<int, std::string>> bindings;
    if (const visnav::ConfigNode* list = root->is_map() ? root->find("primitive_buttons") : nullptr;
        list != nullptr && list->is_sequence()) {
      for (const auto& item : list->items()) {
        const std::string e = item.is_scalar() ? item.scalar() : std::string();
        const auto eq = e.find('=');
        try {
          if (eq == std::string::npos) throw 0;
          bindings.emplace_back(std::stoi(e.substr(0, eq)), e.substr(eq + 1));
        } catch (...) {
          std::cerr << "visnav teach: " << mapping << ": primitive_buttons entry '" << e << "' is not button=kind\n";
          return 1;
        }
      }
    } else {
      bindings = {{0, "feature_segment"}, {2, "path_following"}, {1, ""}};  // the Teleop defaults
    }
    auto joy = visnav::mcap::joy_marks(a.get("--run"), topics->joy, bindings);
    if (!joy) {
      std::cerr << "visnav teach: " << joy.error().message << "\n";
      return 1;
    }
    generated = fs::temp_directory_path() / ("visnav_marks_" + std::to_string(::getpid()) + ".csv");
    std::ofstream out(generated);
    out.precision(17);
    out << "t_s,primitive\n";
    for (const auto& [t, kind] : *joy) out << t << "," << kind << "\n";
    marks = generated.string();
    std::cout << "visnav teach: " << joy->size() << " primitive switches from " << topics->joy << "\n";
  } else if (a.has("--primitive")) {
    generated = fs::temp_directory_path() / ("visnav_marks_" + std::to_string(::getpid()) + ".csv");
    std::ofstream(generated) << "t_s,primitive\n-1e9," << a.get("--primitive") << "\n";
    marks = generated.string();
  } else if (marks.empty()) {
    marks = (run / "marks.csv").string();
  }
  std::error_code ec;
  if (!fs::exists(marks, ec)) {
    std::cerr << "visnav teach: no marks file " << marks
              << ": give --marks F (CSV t_s,primitive) or --primitive KIND for a single-primitive drive\n";
    return 1;
  }

  std::ostringstream end;
  end.precision(17);
  end << last_t_s - margin_s;
  std::vector<std::string> play{run.string(), "--tree",
                                a.get("--tree", (fs::path(VISNAV_SOURCE_DIR) / "trees" / "teach_recorded.xml").string()),
                                "--map", a.get("--map"), "--create", "--no-compare",
                                "--bb", "marks_file=" + fs::absolute(marks).string(),
                                "--bb", "end_time_s=" + end.str(),
                                "--bb", std::string("close_loop=") + (a.has("--close-loop") ? "true" : "false")};
  if (a.has("--config")) {
    play.push_back("--config");
    play.push_back(a.get("--config"));
  }
  // The teaching tree's nodes (a later --set nodes=... replaces this).
  play.push_back("--set");
  play.push_back("nodes=[navigation,feature_replay,path_following,teleop,relocalisation]");
  for (const auto& s : a.all("--set")) {
    play.push_back("--set");
    play.push_back(s);
  }
  for (const auto& b : a.all("--bb")) {
    play.push_back("--bb");
    play.push_back(b);
  }
  if (a.has("--log-level")) {
    play.push_back("--log-level");
    play.push_back(a.get("--log-level"));
  }
  const visnav::cli::Command* p = find_command("play");
  if (p == nullptr) {
    std::cerr << "visnav teach: the play command is missing from this build\n";
    return 1;
  }
  const int rc = p->run(play);
  if (!generated.empty()) fs::remove(generated, ec);
  if (rc == 0) std::cout << "visnav teach: map " << a.get("--map") << " taught from " << a.get("--run") << "\n";
  return rc;
}

}  // namespace

VISNAV_COMMAND(teach, "teach", "teach a map offline from a recorded drive (folder or MCAP) and a marks file", kUsage,
               &teach)
