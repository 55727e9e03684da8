#include "cmd_calibrate_ipt.hpp"

#include <cstdio>
#include <cstdlib>
#include <string>

#include "visnav/ipt_eval/sim_eval.hpp"

namespace visnav::ipt {

const char* const kCalibrateIptUsage =
    "usage: visnav calibrate-ipt [--world NAME] [--true-height-m M] [--true-pitch-down-deg DEG]\n"
    "                            [--guess-height-m M] [--guess-pitch-down-deg DEG] [--pairs N]\n"
    "                            [--baseline-m M] [--noise-std GREY] [--seed N]\n"
    "Renders pairs of flat-ground frames (facing open grass in obstacle_course) with the true mount,\n"
    "tracks Shi-Tomasi corners with Lucas-Kanade, rejects outliers with RANSAC on F and estimates the\n"
    "camera height and pitch with NLopt from the guess (least squares on the ground-plane consistency\n"
    "of the IPT, in pixels). Prints the estimate, the truth and the RMS discrepancy before and after.\n";

int run_calibrate_ipt(int argc, char** argv, HostServices& /*host*/) {
  CalibrationRunOptions o;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "-h" || arg == "--help") {
      std::fputs(kCalibrateIptUsage, stdout);
      return 0;
    }
    if (i + 1 >= argc) {
      std::fprintf(stderr, "visnav calibrate-ipt: %s needs a value\n%s", arg.c_str(), kCalibrateIptUsage);
      return 2;
    }
    const char* text = argv[++i];
    if (arg == "--world") {
      o.world = text;
      continue;
    }
    char* end = nullptr;
    const double v = std::strtod(text, &end);
    if (end == text || *end != '\0') {
      std::fprintf(stderr, "visnav calibrate-ipt: %s needs a number, got '%s'\n", arg.c_str(), text);
      return 2;
    }
    if (arg == "--true-height-m") o.true_height_m = v;
    else if (arg == "--true-pitch-down-deg") o.true_pitch_down_deg = v;
    else if (arg == "--guess-height-m") o.guess_height_m = v;
    else if (arg == "--guess-pitch-down-deg") o.guess_pitch_down_deg = v;
    else if (arg == "--pairs") o.pairs = static_cast<int>(v);
    else if (arg == "--baseline-m") o.baseline_m = v;
    else if (arg == "--noise-std") o.noise_std = v;
    else if (arg == "--seed") o.seed = static_cast<int>(v);
    else {
      std::fprintf(stderr, "visnav calibrate-ipt: unknown argument '%s'\n%s", arg.c_str(), kCalibrateIptUsage);
      return 2;
    }
  }
  auto r = calibrate_on_rendered_frames(o);
  if (!r) {
    std::fprintf(stderr, "visnav calibrate-ipt: %s\n", r.error().message.c_str());
    return 1;
  }
  std::printf("tracks %d, %d evaluations\n", r->tracks, r->evaluations);
  std::printf("height  %.4f m   (true %.4f m, guess %.4f m)\n", r->height_m, o.true_height_m, o.guess_height_m);
  std::printf("pitch   %.3f deg down (true %.3f, guess %.3f)\n", -r->pitch_rad * 180.0 / CV_PI, o.true_pitch_down_deg,
              o.guess_pitch_down_deg);
  std::printf("RMS ground discrepancy D: %.4f m at the guess, %.4f m at the estimate\n", r->initial_rms_discrepancy_m,
              r->rms_discrepancy_m);
  return 0;
}

}  // namespace visnav::ipt
