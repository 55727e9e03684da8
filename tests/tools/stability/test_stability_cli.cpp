// `visnav stability`, `visnav stability-sim` and `visnav tune` through the real binary and loader.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>

#include "visnav/map.hpp"

namespace fs = std::filesystem;

namespace {

struct CliRun {
  int status = -1;
  std::string out;
};

CliRun run_cli(const std::string& args) {
  const std::string cmd = std::string(VISNAV_TEST_CLI) + " " + args + " 2>&1";
  FILE* pipe = popen(cmd.c_str(), "r");
  CliRun r;
  if (pipe == nullptr) return r;
  char buf[512];
  while (std::fgets(buf, sizeof buf, pipe) != nullptr) r.out += buf;
  const int st = pclose(pipe);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

fs::path out_dir(const std::string& name) {
  const fs::path d = fs::path(VISNAV_TEST_BINARY_DIR) / "test_output" / "stability" / name;
  fs::remove_all(d);
  fs::create_directories(d.parent_path());
  return d;
}

// A map whose nodes sit at `corners` (closed loop, one edge per side, kinds cycling through `kinds`).
void make_map(const fs::path& dir, const std::vector<std::pair<double, double>>& corners, const std::vector<std::string>& kinds,
              bool close = true) {
  auto map = visnav::MapStore::create(dir.string(), "test");
  ASSERT_TRUE(map.ok()) << map.error().message;
  map->set_sync(false);
  std::vector<std::string> ids;
  for (const auto& [x, y] : corners) {
    visnav::NodeRecord n;
    n.position_hint = visnav::Pose2D{x, y, 0.0};
    ids.push_back(*map->add_node(n));
  }
  const std::size_t n_edges = close ? corners.size() : corners.size() - 1;
  for (std::size_t i = 0; i < n_edges; ++i) {
    visnav::EdgeRecord e;
    e.from = ids[i];
    e.to = ids[(i + 1) % ids.size()];
    e.kind = kinds[i % kinds.size()];
    const auto [ax, ay] = corners[i];
    const auto [bx, by] = corners[(i + 1) % corners.size()];
    e.length_m = std::hypot(bx - ax, by - ay);
    e.azimuth_rad = std::atan2(by - ay, bx - ax);
    ASSERT_TRUE(map->add_edge(e, std::vector<std::uint8_t>{7}).ok());
  }
}

}  // namespace

TEST(StabilityCli, SquareConvergesAndOutAndBackDoesNot) {
  const fs::path sq = out_dir("square_map");
  make_map(sq, {{0, 0}, {8, 0}, {8, 8}, {0, 8}}, {"path_following", "feature_segment"});
  CliRun r = run_cli("stability " + sq.string());
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("verdict: converges"), std::string::npos) << r.out;
  // y corrected by the two path edges (k 0.366, 16 m), x by the two feature edges (0.055, 16 m).
  EXPECT_NE(r.out.find("along-track error kept 0.4148"), std::string::npos) << r.out;
  // Only the feature edges (e1, e3; ids count from e0) correct the along-track error that limits the loop.
  const auto lim = r.out.find("limiting edges (largest drop of rho when their k doubles):");
  ASSERT_NE(lim, std::string::npos) << r.out;
  const std::string lim_line = r.out.substr(lim, r.out.find('\n', lim) - lim);
  EXPECT_TRUE(lim_line.ends_with(" e1 e3") || lim_line.ends_with(" e3 e1")) << lim_line;

  const fs::path ob = out_dir("out_and_back_map");
  make_map(ob, {{0, 0}, {12, 0}}, {"feature_segment"});
  r = run_cli("stability " + ob.string());
  EXPECT_EQ(r.status, 4) << r.out;
  EXPECT_NE(r.out.find("verdict: does not converge"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("collinear"), std::string::npos) << r.out;

  // --k overrides a default: a stronger feature primitive converges faster.
  r = run_cli("stability " + sq.string() + " --k feature_segment=0.2");
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("along-track error kept 0.0408"), std::string::npos) << r.out;
}

TEST(StabilityCli, BadMapsGetAClearAnswer) {
  const fs::path one = out_dir("one_edge_map");
  make_map(one, {{0, 0}, {5, 0}}, {"path_following"}, /*close=*/false);
  CliRun r = run_cli("stability " + one.string());
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("not closed"), std::string::npos) << r.out;

  const fs::path vm = out_dir("unknown_kind_map");
  make_map(vm, {{0, 0}, {5, 0}, {5, 5}}, {"path_following", "visual_memory"});
  r = run_cli("stability " + vm.string());
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("edge 'e1': primitive 'visual_memory' has no convergence model"), std::string::npos) << r.out;
  r = run_cli("stability " + vm.string() + " --k visual_memory=0.3");
  EXPECT_EQ(r.status, 0) << r.out;

  r = run_cli("stability " + vm.string() + " --edges e0");
  EXPECT_EQ(r.status, 1) << r.out;
  r = run_cli("stability");
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("no map folder given"), std::string::npos) << r.out;
  r = run_cli("stability " + vm.string() + " --k visual_memory");
  EXPECT_EQ(r.status, 2) << r.out;
}

TEST(StabilitySimCli, RunsTheScenariosAndComparesWithThePaper) {
  CliRun r = run_cli("stability-sim --scenarios 2000 --threads 2 --odom-error-max 0 --heading-error-max-deg 0");
  ASSERT_EQ(r.status, 0) << r.out;
  // Without disturbances every scenario within the model's assumption (l > initial error) converges.
  EXPECT_NE(r.out.find("seed 002 Sec. 3.8 reports that all 1000000 scenarios converged; here"), std::string::npos) << r.out;
  const auto at = r.out.find("(landmark distance l > initial error): ");
  ASSERT_NE(at, std::string::npos) << r.out;
  const std::string line = r.out.substr(at, r.out.find('\n', at) - at);
  EXPECT_NE(line.find("(100.000 %) converged"), std::string::npos) << line;
  r = run_cli("stability-sim --only 81");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("error at the end of each loop"), std::string::npos) << r.out;
  r = run_cli("stability-sim --landmark-min 3 --landmark-max 2");
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("landmark distance range"), std::string::npos) << r.out;
}

TEST(TuneCli, TunesAgainstAFakeExperimentAndResumes) {
  const fs::path dir = out_dir("tune");
  fs::create_directories(dir);
  // A stand-in for `visnav experiment`: eps_acc = (gain - 0.6)^2 + 0.1, eps_rep = 0.01; above
  // gain 1.5 five of the 25 loops fail. It counts its runs in DIR/count.
  const fs::path script = dir / "fake_experiment.sh";
  {
    std::ofstream s(script);
    s << "#!/bin/sh\nout=''; g=''\n"
         "while [ $# -gt 0 ]; do case \"$1\" in --out) out=\"$2\"; shift;; --set) case \"$2\" in "
         "fake.gain=*) g=\"${2#fake.gain=}\";; esac; shift;; esac; shift; done\n"
         "echo run >> \"$(dirname \"$(dirname \"$out\")\")/count\"\n"
         "awk -v g=\"$g\" 'BEGIN { c = (g > 1.5) ? 20 : 25; "
         "printf \"{\\\"styles\\\":[{\\\"style\\\":\\\"feature\\\",\\\"attempted\\\":25,\\\"completed\\\":%d,"
         "\\\"eps_acc_m\\\":{\\\"mean\\\":%.9f},\\\"eps_rep_m\\\":{\\\"mean\\\":0.01},\\\"collisions\\\":0,"
         "\\\"lost\\\":0}]}\\n\", c, (g - 0.6) * (g - 0.6) + 0.1 }' > \"$out/summary.json\"\n";
  }
  const std::string args = "tune --world campus --route campus --params fake.gain=0:2:1.8 --max-evals 20 --out " +
                           dir.string() + " --child 'sh " + script.string() + "'";
  CliRun r = run_cli(args);
  ASSERT_EQ(r.status, 0) << r.out;
  std::ifstream tuned(dir / "tuned.yaml");
  std::stringstream t;
  t << tuned.rdbuf();
  const auto at = t.str().find("fake:\n  gain: ");
  ASSERT_NE(at, std::string::npos) << t.str();
  EXPECT_NEAR(std::stod(t.str().substr(at + 14)), 0.6, 0.02) << t.str();
  EXPECT_TRUE(fs::exists(dir / "convergence.png"));
  EXPECT_TRUE(fs::exists(dir / "convergence.csv"));
  auto count_runs = [&] {
    std::ifstream c(dir / "count");
    int n = 0;
    for (std::string l; std::getline(c, l);) ++n;
    return n;
  };
  const int first_runs = count_runs();
  EXPECT_GT(first_runs, 3);
  EXPECT_LE(first_runs, 20);
  // The start (gain 1.8) had 5 failed loops: 1.44 + 0.1 + 0.01 + 5 * 5/25 = 2.55.
  EXPECT_NE(r.out.find("objective: start 2.5500 m"), std::string::npos) << r.out;

  // Same command again: everything comes from evals.csv, no experiment runs.
  r = run_cli(args);
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_EQ(count_runs(), first_runs);
  EXPECT_NE(r.out.find("known from evals.csv"), std::string::npos) << r.out;

  // Other parameters with the same --out are refused; a missing bound is a usage error.
  r = run_cli("tune --world w --route r --params other=0:1 --out " + dir.string() + " --child 'sh " + script.string() + "'");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("made for other parameters"), std::string::npos) << r.out;
  r = run_cli("tune --world w --route r --params fake.gain");
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("needs bounds"), std::string::npos) << r.out;
}

TEST(PlatformsCli, RunsOneExperimentPerRowAndTabulatesIt) {
  const fs::path dir = out_dir("platforms");
  fs::create_directories(dir);
  // Stand-in experiment: the 5 Hz camera row fails two loops (and exits 1, as visnav experiment
  // does; the row is still tabulated), every other row completes all.
  const fs::path script = dir / "fake_experiment.sh";
  {
    std::ofstream s(script);
    s << "#!/bin/sh\nout=''; c=25\n"
         "while [ $# -gt 0 ]; do case \"$1\" in --out) out=\"$2\"; shift;; --set) case \"$2\" in "
         "camera.params.frame_rate_hz=5) c=23;; esac; shift;; esac; shift; done\n"
         "printf '{\"styles\":[{\"style\":\"feature\",\"attempted\":25,\"completed\":%d,"
         "\"eps_acc_m\":{\"mean\":0.1,\"sd\":0.02,\"worst\":0.2},\"eps_rep_m\":{\"mean\":0.05,\"sd\":0.01,"
         "\"worst\":0.08},\"collisions\":0,\"lost\":0}]}\\n' $c > \"$out/summary.json\"\n"
         "[ $c -lt 25 ] && exit 1; exit 0\n";  // as visnav experiment: 1 when a loop failed
  }
  CliRun r = run_cli("platforms --rows diff_drive,camera_5hz,freeze_1_3s,car_like --out " + dir.string() + " --child 'sh " +
                     script.string() + "'");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("| differential drive (reference) | `robot.params.kinematics=diff_drive` | 25/25 | 0.100 ± 0.020 | "
                       "0.050 ± 0.010 | 0.200 | yes |"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("| 5 Hz camera | `camera.params.frame_rate_hz=5`, `run.max_frame_age_s=1` | 23/25 |"), std::string::npos)
      << r.out;  // exit 1 with a summary is tabulated
  EXPECT_NE(r.out.find("| no |"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("| 1-3 s compute freezes, 2 per minute | `robot.params.freeze_rate_per_min=2`"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("| car-like (Ackermann, 1 m turning radius) | `robot.params.kinematics=car_like` | 25/25 |"),
            std::string::npos)
      << r.out;
  EXPECT_TRUE(fs::exists(dir / "platforms.md"));
  r = run_cli("platforms --rows nope");
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("no row 'nope'"), std::string::npos) << r.out;
}
