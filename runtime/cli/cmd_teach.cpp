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
#include "visnav/file_io.hpp"
#include "visnav/params.hpp"

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
    "                     (navigation, feature_replay, path_following, teleop, relocalisation) before any --set\n"
    "  --image-topic T, --odom-topic T   topics of a ROS 2 bag (as `visnav convert`; default\n"
    "                     run.bag_image_topic / run.bag_odom_topic of --config)\n"
    "\n"
    "Exit status: as `visnav play` (0 when the map was taught).\n";

const visnav::cli::Command* find_command(const std::string& name) {
  for (const auto& c : visnav::cli::commands())
    if (name == c.name) return &c;
  return nullptr;
}

/// The run-clock time of the recording's last frame (teaching ends a margin before it).
visnav::Result<double> last_frame_time(const fs::path& run, const std::string& run_arg) {
  if (auto checked = visnav::check_input_file((run / "frames.csv").string(), visnav::kMaxTableFileBytes, "frames");
      !checked && checked.error().code != visnav::ErrorCode::not_found)
    return checked.error();
  std::ifstream frames(run / "frames.csv");
  if (!frames) return visnav::fail(visnav::ErrorCode::not_found, {run_arg}, "not a recorded run (no frames.csv)");
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
  if (!any) return visnav::fail(visnav::ErrorCode::missing, {run_arg}, "has no frames");
  return last_t_s;
}

/// The gamepad's primitive buttons as the Teleop node binds them (`primitive_buttons` of the
/// operator mapping file, or the Teleop defaults when the file has none).
visnav::Result<std::vector<std::pair<int, std::string>>> gamepad_bindings(const std::string& mapping) {
  VISNAV_ASSIGN(const visnav::ConfigNode root, visnav::parse_yaml_file(mapping));
  const visnav::ConfigNode* list = root.is_map() ? root.find("primitive_buttons") : nullptr;
  if (list == nullptr || !list->is_sequence()) return std::vector<std::pair<int, std::string>>{{0, "feature_segment"}, {2, "path_following"}, {1, ""}};
  std::vector<std::pair<int, std::string>> bindings;
  for (const auto& item : list->items()) {
    const std::string e = item.is_scalar() ? item.scalar() : std::string();
    const auto eq = e.find('=');
    auto button = eq == std::string::npos ? visnav::Result<int>(visnav::fail("no '='")) : visnav::detail::parse_int(e.substr(0, eq));
    if (!button)
      return visnav::fail(visnav::ErrorCode::invalid_value, {mapping, item.where().line, "primitive_buttons"},
                          "entry '" + e + "' is not button=kind");
    bindings.emplace_back(*button, e.substr(eq + 1));
  }
  return bindings;
}

/// The marks file teaching follows, and whether it was written here (removed afterwards).
struct Marks {
  std::string path;
  fs::path generated;  ///< empty: the user's file
};

fs::path temporary_marks_path() { return fs::temp_directory_path() / ("visnav_marks_" + std::to_string(::getpid()) + ".csv"); }

/// --joy-topic (from the gamepad presses in the bag), --primitive (one edge), --marks or RUN/marks.csv.
visnav::Result<Marks> marks_for(const visnav::cli::Args& a, const std::string& joy_topic, const fs::path& run) {
  Marks m{a.get("--marks"), {}};
  if (!joy_topic.empty()) {
    VISNAV_ASSIGN(auto bindings,
                  gamepad_bindings(a.get("--mapping", (fs::path(VISNAV_SOURCE_DIR) / "config" / "teleop" / "gamepad.yaml").string())));
    VISNAV_ASSIGN(auto joy, visnav::mcap::joy_marks(a.get("--run"), joy_topic, bindings));
    m.generated = temporary_marks_path();
    std::ofstream out(m.generated);
    out.precision(17);
    out << "t_s,primitive\n";
    for (const auto& [t, kind] : joy) out << t << "," << kind << "\n";
    m.path = m.generated.string();
    std::cout << "visnav teach: " << joy.size() << " primitive switches from " << joy_topic << "\n";
  } else if (a.has("--primitive")) {
    m.generated = temporary_marks_path();
    std::ofstream(m.generated) << "t_s,primitive\n-1e9," << a.get("--primitive") << "\n";
    m.path = m.generated.string();
  } else if (m.path.empty()) {
    m.path = (run / "marks.csv").string();
  }
  std::error_code ec;
  if (!fs::exists(m.path, ec))
    return visnav::fail(visnav::ErrorCode::not_found, {m.path},
                        "no marks file: give --marks F (CSV t_s,primitive) or --primitive KIND for a single-primitive drive");
  return m;
}

/// The `visnav play` command line that teaches: the teaching tree, the map, the marks and the end.
std::vector<std::string> play_arguments(const visnav::cli::Args& a, const fs::path& run, const std::string& marks, double end_s) {
  std::ostringstream end;
  end.precision(17);
  end << end_s;
  std::vector<std::string> play{run.string(), "--tree",
                                a.get("--tree", (fs::path(VISNAV_SOURCE_DIR) / "trees" / "teach_recorded.xml").string()),
                                "--map", a.get("--map"), "--create", "--no-compare",
                                "--bb", "marks_file=" + fs::absolute(marks).string(),
                                "--bb", "end_time_s=" + end.str(),
                                "--bb", std::string("close_loop=") + (a.has("--close-loop") ? "true" : "false")};
  auto add = [&play](const char* option, const std::string& value) {
    play.push_back(option);
    play.push_back(value);
  };
  if (a.has("--config")) add("--config", a.get("--config"));
  add("--set", "nodes=[navigation,feature_replay,path_following,teleop,relocalisation]");  // a later --set nodes=... replaces it
  for (const auto& s : a.all("--set")) add("--set", s);
  for (const auto& b : a.all("--bb")) add("--bb", b);
  if (a.has("--log-level")) add("--log-level", a.get("--log-level"));
  return play;
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
  auto margin_s = visnav::detail::parse_double(a.get("--end-margin-s", "0.5"));
  if (!margin_s) return visnav::cli::usage_error("teach", "--end-margin-s needs a number");
  auto report_error = [](const visnav::Error& e) {
    std::cerr << "visnav teach: " << e.message << "\n";
    return 1;
  };

  auto topics = visnav::cli::bag_topics(a, a.get("--config"), a.all("--set"));
  if (!topics) return report_error(topics.error());
  // run.bag_joy_topic applies unless the switches are given another way.
  if (a.has("--marks") || a.has("--primitive")) topics->joy.clear();
  visnav::cli::TempRun temp;
  auto folder = visnav::cli::run_folder_of(a.get("--run"), topics->run, temp);
  if (!folder) return report_error(folder.error());
  const fs::path run(*folder);
  auto last_t_s = last_frame_time(run, a.get("--run"));
  if (!last_t_s) return report_error(last_t_s.error());
  auto marks = marks_for(a, topics->joy, run);
  if (!marks) return report_error(marks.error());

  const visnav::cli::Command* p = find_command("play");
  if (p == nullptr) return report_error(visnav::fail("the play command is missing from this build"));
  const int rc = p->run(play_arguments(a, run, marks->path, *last_t_s - *margin_s));
  std::error_code ec;
  if (!marks->generated.empty()) fs::remove(marks->generated, ec);
  if (rc == 0) std::cout << "visnav teach: map " << a.get("--map") << " taught from " << a.get("--run") << "\n";
  return rc;
}

}  // namespace

VISNAV_COMMAND(teach, "teach", "teach a map offline from a recorded drive (folder or MCAP) and a marks file", kUsage,
               &teach)
