#include "cmd_ipt_roc.hpp"

#include <cstdio>
#include <cstdlib>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include "visnav/ipt_eval/sim_eval.hpp"

namespace visnav::ipt {

const char* const kIptRocUsage =
    "usage: visnav ipt-roc [--world NAME] [--seed N] [--noise-std GREY] [--odom-sd-m M] [--odom-sd-deg DEG]\n"
    "                      [--beta-m M] [--no-band] [--edge-sigma-px S] [--edge-high G] [--ground-reach-px P]\n"
    "                      [--vertical-run-px N] [--support N] [--support-radius-px P]\n"
    "                      [--forward-backward-px P] [--odometry-epipolar-px P] [--tracker klt|sift|orb|fast]\n"
    "                      [--picture FILE.png] [--picture-run K] [--run X,Y,DEG,LEN]...\n"
    "                      [--mount HEIGHT_M,PITCH_DOWN_DEG,HFOV_DEG] [--direction-test]\n"
    "Renders image pairs 2 cm apart along runs past the obstacles of the obstacle_course world\n"
    "(thesis rig: 320x240, FOV 65.5 deg, lens 0.43 m, pitch -9 deg), tracks Shi-Tomasi corners with\n"
    "pyramidal Lucas-Kanade, rejects outliers with RANSAC on F and classifies the inliers with the\n"
    "IPT (beta 21 mm, band 21-50 mm). Truth from the renderer's labels. Prints the counts, precision,\n"
    "recall, fall-out, ROC AUC with and without the D band, and the beta minimising FP + 0.5 FN.\n"
    "--tracker compares the thesis's trackers on the same pairs (spec 11.26): klt (default, the\n"
    "pipeline's), sift, orb (in place of SURF, not in Debian's OpenCV) or fast (FAST corners matched\n"
    "by the SSD of their 16-pixel circle); it prints features per frame, matches per pair, the\n"
    "share RANSAC keeps, the share misclassified and the tracking time per pair.\n"
    "--odometry-epipolar-px P also drops matches more than P px from the epipolar line of the pair's\n"
    "odometry (with the --odom-sd-* noise); 0 (default) = RANSAC alone, as the thesis.\n"
    "--run X,Y,DEG,LEN (repeatable) replaces the obstacle course's runs: pairs from (X, Y) in the\n"
    "world frame along heading DEG (from +x, counter-clockwise) for LEN metres, e.g. a replay's\n"
    "place in --world campus; --mount the camera instead of the thesis rig (the campus robot:\n"
    "0.5,5,60). --direction-test: an OBSTACLE-by-D feature whose ground projection moved with the\n"
    "lens is unclassified (ClassifierParams::signed_discrepancy, off by default; docs/obstacles.md).\n";

namespace {

bool parse_double(const char* text, double& out) {
  char* end = nullptr;
  out = std::strtod(text, &end);
  return end != text && *end == '\0';
}

/// --run X,Y,DEG,LEN: the first replaces the obstacle course's runs, each adds one.
bool parse_run(const char* text, RocOptions& options, bool& custom_runs) {
  double x = 0.0, y = 0.0, deg = 0.0, len = 0.0;
  char tail = 0;
  if (std::sscanf(text, "%lf,%lf,%lf,%lf%c", &x, &y, &deg, &len, &tail) != 4 || !(len > 0.0)) {
    std::fprintf(stderr, "visnav ipt-roc: --run needs X,Y,DEG,LEN with LEN > 0 (got '%s')\n%s", text,
                 kIptRocUsage);
    return false;
  }
  if (!custom_runs) options.runs.clear();
  custom_runs = true;
  options.runs.push_back({Pose2D{x, y, deg * CV_PI / 180.0}, len});
  return true;
}

/// --mount HEIGHT_M,PITCH_DOWN_DEG,HFOV_DEG.
bool parse_mount(const char* text, RocOptions& options) {
  char tail = 0;
  if (std::sscanf(text, "%lf,%lf,%lf%c", &options.mount_height_m, &options.pitch_down_deg,
                  &options.hfov_deg, &tail) != 3) {
    std::fprintf(stderr, "visnav ipt-roc: --mount needs HEIGHT_M,PITCH_DOWN_DEG,HFOV_DEG (got '%s')\n%s",
                 text, kIptRocUsage);
    return false;
  }
  return true;
}

/// Parses the command line into `options` and `picture_path`. Returns -1 to go on, else the exit
/// code: 0 after --help, 2 on a bad argument (with the usage on stderr).
int parse_roc_args(int argc, char** argv, RocOptions& options, std::string& picture_path) {
  bool custom_runs = false;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto value = [&](double& out) {
      if (i + 1 >= argc || !parse_double(argv[i + 1], out)) {
        std::fprintf(stderr, "visnav ipt-roc: %s needs a number\n%s", arg.c_str(), kIptRocUsage);
        return false;
      }
      ++i;
      return true;
    };
    double v = 0.0;
    if (arg == "-h" || arg == "--help") {
      std::fputs(kIptRocUsage, stdout);
      return 0;
    } else if (arg == "--world" && i + 1 < argc) {
      options.world = argv[++i];
    } else if (arg == "--picture" && i + 1 < argc) {
      picture_path = argv[++i];
    } else if (arg == "--picture-run") {
      if (!value(v)) return 2;
      options.picture_run = static_cast<int>(v);
    } else if (arg == "--seed") {
      if (!value(v)) return 2;
      options.seed = static_cast<int>(v);
    } else if (arg == "--noise-std") {
      if (!value(options.noise_std)) return 2;
    } else if (arg == "--odom-sd-m") {
      if (!value(options.odom_position_sd_m)) return 2;
    } else if (arg == "--odom-sd-deg") {
      if (!value(v)) return 2;
      options.odom_heading_sd_rad = v * CV_PI / 180.0;
    } else if (arg == "--beta-m") {
      if (!value(options.classifier.beta_m)) return 2;
    } else if (arg == "--edge-sigma-px") {
      if (!value(options.profiles.sigma_px)) return 2;
    } else if (arg == "--edge-high") {
      if (!value(options.profiles.high_threshold)) return 2;
    } else if (arg == "--vertical-run-px") {
      if (!value(v)) return 2;
      options.profiles.min_vertical_run_px = static_cast<int>(v);
    } else if (arg == "--support") {
      if (!value(v)) return 2;
      options.profiles.min_supporting_features = static_cast<int>(v);
    } else if (arg == "--support-radius-px") {
      if (!value(options.profiles.support_radius_px)) return 2;
    } else if (arg == "--ground-reach-px") {
      if (!value(options.profiles.ground_reach_px)) return 2;
    } else if (arg == "--forward-backward-px") {
      if (!value(options.tracking.forward_backward_px)) return 2;
    } else if (arg == "--odometry-epipolar-px") {
      if (!value(options.tracking.odometry_epipolar_px)) return 2;
    } else if (arg == "--run" && i + 1 < argc) {
      if (!parse_run(argv[i + 1], options, custom_runs)) return 2;
      ++i;
    } else if (arg == "--mount" && i + 1 < argc) {
      if (!parse_mount(argv[i + 1], options)) return 2;
      ++i;
    } else if (arg == "--tracker" && i + 1 < argc) {
      options.tracker = argv[++i];
    } else if (arg == "--direction-test") {
      options.classifier.signed_discrepancy = true;
    } else if (arg == "--no-band") {
      options.classifier.unclassified_bands_m.clear();
    } else {
      std::fprintf(stderr, "visnav ipt-roc: unknown argument '%s'\n%s", arg.c_str(), kIptRocUsage);
      return 2;
    }
  }
  return -1;
}

/// Prints the counts, rates, AUCs, best β, contact points and the tracker comparison line.
void print_roc_report(const RocOptions& options, const RocReport& report) {
  const Counts& c = report.at_operating_point;
  std::printf("pairs %d  features %ld (left out at object borders %ld, RANSAC outliers %ld)\n", report.pairs,
              report.features, c.border, c.ransac_outliers);
  std::printf("operating point beta %.3f m: TP %ld FP %ld TN %ld FN %ld  unclassified: obstacle %ld ground %ld\n",
              options.classifier.beta_m, c.tp, c.fp, c.tn, c.fn, c.unclassified_obstacle, c.unclassified_ground);
  std::printf("precision %.3f  recall %.3f  recall counting unclassified as missed %.3f  fall-out %.3f\n",
              c.precision(), c.recall(), c.recall_all(), c.fallout());
  const Counts& b = report.below_horizon;
  std::printf("below the horizon only (D decides): TP %ld FP %ld TN %ld FN %ld unclassified obstacle %ld ground %ld;"
              " precision %.3f recall %.3f fall-out %.3f\n",
              b.tp, b.fp, b.tn, b.fn, b.unclassified_obstacle, b.unclassified_ground, b.precision(), b.recall(),
              b.fallout());
  std::printf("ROC AUC %.4f without the D band, %.4f with it; beta minimising FP + 0.5 FN: %.3f m\n",
              report.auc_without_band, report.auc_with_band, report.best_beta_m);
  std::printf("contact points %ld, %ld within 3 px of an obstacle pixel\n", report.contact_points,
              report.contact_points_on_obstacle_base);
  const long classified = c.tp + c.fp + c.tn + c.fn;
  std::printf("tracker %s: %.1f features per frame, %.1f matches per pair, inliers %.1f %%, misclassified %.1f %% "
              "(FP + FN of the classified), %.2f ms per pair\n",
              options.tracker.c_str(), report.pairs > 0 ? static_cast<double>(report.detected) / report.pairs : 0.0,
              report.pairs > 0 ? static_cast<double>(report.matched) / report.pairs : 0.0,
              report.matched > 0 ? 100.0 * static_cast<double>(report.inliers) / static_cast<double>(report.matched) : 0.0,
              classified > 0 ? 100.0 * static_cast<double>(c.fp + c.fn) / static_cast<double>(classified) : 0.0,
              report.pairs > 0 ? report.tracking_ms / report.pairs : 0.0);
}

}  // namespace

int run_ipt_roc(int argc, char** argv, HostServices& /*host*/) {
  RocOptions options;
  std::string picture_path;
  if (const int code = parse_roc_args(argc, argv, options, picture_path); code >= 0) return code;
  cv::Mat picture;
  auto report = evaluate_classifier(options, picture_path.empty() ? nullptr : &picture);
  if (!report) {
    std::fprintf(stderr, "visnav ipt-roc: %s\n", report.error().message.c_str());
    return 1;
  }
  print_roc_report(options, *report);
  if (!picture_path.empty()) {
    if (picture.empty() || !cv::imwrite(picture_path, picture)) {
      std::fprintf(stderr, "visnav ipt-roc: cannot write %s\n", picture_path.c_str());
      return 1;
    }
    std::printf("picture: %s\n", picture_path.c_str());
  }
  return 0;
}

}  // namespace visnav::ipt
