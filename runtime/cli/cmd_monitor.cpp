// `visnav monitor`: prints the DDS telemetry of a running `visnav run` live, and sends
// mission-control requests (pause, resume, abort, swap_detector).
#include <atomic>
#include <csignal>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <thread>
#include <iostream>

#include "args.hpp"
#include "command.hpp"
#include "visnav/dds.hpp"
#include "visnav/runtime_host.hpp"

namespace {

constexpr const char* kUsage =
    "usage: visnav monitor [--domain N] [--partition P] [--topic T] [--count N] [--duration S] [--json]\n"
    "       visnav monitor --send pause|resume|abort|swap_detector [--arg DETECTOR] [--domain N] [--partition P]\n"
    "                      [--control-topic T] [--wait S]\n"
    "       (both forms) [--keystore DIR --identity NAME]   DDS Security as an operator (docs/security.md)\n"
    "\n"
    "Prints every visnav/msg/Telemetry sample published by `visnav run` (config block `dds:`)\n"
    "as one line: sequence, status, behaviour-tree node, map node and edge, distance along the edge,\n"
    "image offset, inliers/matches and the command (v, w). With --send, publishes one control request\n"
    "instead and exits.\n"
    "\n"
    "  --domain N         DDS domain id (default 0, or $ROS_DOMAIN_ID)\n"
    "  --partition P      DDS partition (default: none)\n"
    "  --topic T          telemetry topic (default rt/visnav/telemetry)\n"
    "  --count N          exit after N samples (default: run until Ctrl-C)\n"
    "  --duration S       exit after S seconds (default: run until Ctrl-C)\n"
    "  --json             print JSON lines instead of the table\n"
    "  --send C           send control request C and exit\n"
    "  --arg DETECTOR     swap_detector: the detector type to switch to (e.g. orb)\n"
    "  --control-topic T  control topic (default rt/visnav/control)\n"
    "  --wait S           --send: wait up to S s for a subscriber first (default 2)\n"
    "  --keystore DIR     DDS Security keystore (`visnav security init`); with --identity NAME (an\n"
    "  --identity NAME    operator): authenticated, encrypted; without: security off\n"
    "\n"
    "Exit status: 0 ok, 1 DDS error / --count not reached / no subscriber for --send, 2 usage error.\n";

std::atomic<bool> g_stop{false};
extern "C" void on_signal(int) { g_stop = true; }

visnav::Result<double> parse_number(const std::string& name, const std::string& text) {
  auto v = visnav::detail::parse_double(text);
  if (!v) return visnav::fail(name + ": " + v.error().message);
  return *v;
}

/// --send: publishes one control request once a subscriber is there. Exit status.
int send_control(const visnav::cli::Args& a, const visnav::dds::TelemetryParams& params) {
  auto command = visnav::dds::parse_control_command(a.get("--send"));
  if (!command) return visnav::cli::usage_error("monitor", command.error().message);
  if (*command == visnav::dds::msg::ControlCommand::swap_detector && a.get("--arg").empty())
    return visnav::cli::usage_error("monitor", "--send swap_detector needs --arg DETECTOR");
  auto wait_s = parse_number("--wait", a.get("--wait", "2"));
  if (!wait_s) return visnav::cli::usage_error("monitor", wait_s.error().message);
  auto publisher = visnav::dds::ControlPublisher::create(params);
  if (!publisher) {
    std::cerr << "visnav monitor: " << publisher.error().message << "\n";
    return 1;
  }
  const bool matched = (*publisher)->wait_for_subscribers(1, *wait_s);
  if (!matched) {
    std::cerr << "visnav monitor: no control subscriber on '" << params.control_topic << "' (domain "
              << params.domain_id << ") within " << *wait_s << " s; is `visnav run` running with a `dds:` config block?\n";
    return 1;
  }
  if (auto st = (*publisher)->send(*command, a.get("--arg")); !st) {
    std::cerr << "visnav monitor: " << st.error().message << "\n";
    return 1;
  }
  // Give the reliable protocol a moment to deliver before the participant goes away.
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  std::cout << "visnav monitor: sent " << visnav::dds::to_string(*command) << "\n";
  return 0;
}

/// One telemetry sample as a JSON line or a table row on stdout.
void print_sample(const visnav::dds::msg::Telemetry& t, bool json) {
  if (json) {
    std::printf(
        "{\"seq\":%llu,\"stamp_s\":%.6f,\"node_path\":\"%s\",\"map_node\":\"%s\",\"edge\":\"%s\",\"distance_m\":%.4f,"
        "\"matches\":%d,\"inliers\":%d,\"offset_px\":%.3f,\"linear_mps\":%.4f,\"angular_radps\":%.4f,\"status\":\"%s\"}\n",
        static_cast<unsigned long long>(t.sequence_number), t.header.stamp.seconds(),
        visnav::json_escape(t.node_path).c_str(), visnav::json_escape(t.map_node).c_str(),
        visnav::json_escape(t.edge).c_str(), t.distance_m, t.matches, t.inliers, t.offset_px, t.linear_mps,
        t.angular_radps, visnav::json_escape(t.status).c_str());
  } else {
    std::printf("#%-6llu %-14s node %-28s map %-10s edge %-8s d %7.2f m  off %+7.1f px  inl %4d/%-4d  v %+5.2f m/s  w %+5.2f rad/s\n",
                static_cast<unsigned long long>(t.sequence_number), t.status.c_str(), t.node_path.c_str(),
                t.map_node.empty() ? "-" : t.map_node.c_str(), t.edge.empty() ? "-" : t.edge.c_str(), t.distance_m,
                t.offset_px, t.inliers, t.matches, t.linear_mps, t.angular_radps);
  }
  std::fflush(stdout);
}

/// The listening form: prints telemetry until Ctrl-C, --count samples or --duration. Exit status.
int listen(const visnav::cli::Args& a, const visnav::dds::TelemetryParams& params) {
  long max_count = 0;
  if (a.has("--count")) {
    auto c = visnav::detail::parse_int(a.get("--count"));
    if (!c || *c <= 0) return visnav::cli::usage_error("monitor", "--count: expected a positive integer");
    max_count = *c;
  }
  double duration_s = 0.0;
  if (a.has("--duration")) {
    auto d = parse_number("--duration", a.get("--duration"));
    if (!d || *d <= 0) return visnav::cli::usage_error("monitor", "--duration: expected a positive number of seconds");
    duration_s = *d;
  }
  const bool json = a.has("--json");
  auto fail_with = [](const std::string& message) {
    std::cerr << "visnav monitor: " << message << "\n";
    return 1;
  };
  auto participant = visnav::dds::Participant::create(params.domain_id);
  if (!participant) return fail_with(participant.error().message);
  const visnav::dds::Qos qos{visnav::dds::Reliability::reliable, visnav::dds::Durability::volatile_data, 100, 0.0};
  auto reader = visnav::dds::Reader<visnav::dds::msg::Telemetry>::create(
      *participant, visnav::dds::EndpointOptions{params.telemetry_topic, qos, params.partition});
  if (!reader) return fail_with(reader.error().message);
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  if (!json)
    std::cerr << "visnav monitor: listening on '" << params.telemetry_topic << "' (domain " << params.domain_id
              << (params.partition.empty() ? "" : ", partition " + params.partition) << "); Ctrl-C to stop\n";

  const auto start = std::chrono::steady_clock::now();
  long received = 0;
  while (!g_stop) {
    if (max_count > 0 && received >= max_count) break;
    if (duration_s > 0 && std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() >= duration_s)
      break;
    auto ready = reader->wait(0.1);
    if (!ready) return fail_with(ready.error().message);
    if (!*ready) continue;
    auto taken = reader->take([&](visnav::dds::msg::Telemetry&& t, const visnav::dds::SampleInfo&) {
      if (max_count != 0 && received >= max_count) return;
      ++received;
      print_sample(t, json);
    });
    if (!taken) return fail_with(taken.error().message);
  }
  if (max_count > 0 && received < max_count) {
    std::cerr << "visnav monitor: received " << received << " of " << max_count << " samples\n";
    return 1;
  }
  return 0;
}

int monitor(const std::vector<std::string>& args) {
  using visnav::cli::Opt;
  visnav::cli::Args a;
  if (auto st = a.parse(args, {{"--domain", Opt::value}, {"--partition", Opt::value}, {"--topic", Opt::value},
                               {"--count", Opt::value}, {"--duration", Opt::value}, {"--json", Opt::flag},
                               {"--send", Opt::value}, {"--arg", Opt::value}, {"--control-topic", Opt::value},
                               {"--wait", Opt::value}, {"--keystore", Opt::value}, {"--identity", Opt::value}});
      !st)
    return visnav::cli::usage_error("monitor", st.error().message);

  visnav::dds::TelemetryParams params;
  std::string domain_text = a.get("--domain");
  if (domain_text.empty() && std::getenv("ROS_DOMAIN_ID") != nullptr) domain_text = std::getenv("ROS_DOMAIN_ID");
  if (!domain_text.empty()) {
    auto d = visnav::detail::parse_int(domain_text);
    if (!d || *d < 0 || *d > 232) return visnav::cli::usage_error("monitor", "--domain: expected 0..232, got '" + domain_text + "'");
    params.domain_id = *d;
  }
  params.partition = a.get("--partition");
  params.telemetry_topic = a.get("--topic", params.telemetry_topic);
  params.control_topic = a.get("--control-topic", params.control_topic);
  if (auto st = params.validate(); !st) return visnav::cli::usage_error("monitor", st.error().message);
  if (a.has("--keystore") != a.has("--identity"))
    return visnav::cli::usage_error("monitor", "--keystore and --identity go together");
  if (a.has("--keystore")) {
    auto st = visnav::dds::set_default_security(visnav::dds::keystore_identity(a.get("--keystore"), a.get("--identity")));
    if (!st) {
      std::cerr << "visnav monitor: " << st.error().message << "\n";
      return 1;
    }
  }
  return a.has("--send") ? send_control(a, params) : listen(a, params);
}

}  // namespace

VISNAV_COMMAND(monitor, "monitor", "print the DDS telemetry of a running mission live; send pause/resume/abort",
               kUsage, &monitor)
