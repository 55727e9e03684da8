// `visnav align` (see cmd_align.hpp and docs/feature_replay.md).
#include "cmd_align.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "visnav/feature_replay/draw.hpp"
#include "visnav/feature_replay/heading.hpp"

namespace visnav::feature_replay {

const char* const kAlignUsage =
    "usage: visnav align A.png B.png [--detector D] [--draw out.png] [options]\n"
    "       visnav align --pairs FILE [--detector D] [options]\n"
    "\n"
    "Estimates the horizontal offset of the scene between two images by matching features and\n"
    "voting their horizontal displacements into a histogram (seed 002 Sec. 2.4).\n"
    "OFFSET_PX = horizontal position of the scene in B minus its position in A (positive: the\n"
    "content moved right).\n"
    "\n"
    "  --detector D       detector type (default star_brief; falls back to orb if not installed)\n"
    "  --param K=V        detector parameter (repeatable), e.g. --param target_keypoints=800\n"
    "  --set K=V          matching/histogram parameter (repeatable): ratio, cross_check,\n"
    "                     max_descriptor_distance, max_vertical_px, bin_width_px, bin_count,\n"
    "                     refine_window_px, min_inliers, full_confidence_inliers, min_confidence,\n"
    "                     horizontal_fov_deg\n"
    "  --draw out.png     write the matches and the histogram (single-pair mode)\n"
    "  --pairs FILE       lines 'IMG_A IMG_B' ('#' comments and blank lines skipped; relative paths\n"
    "                     are tried as given, then relative to FILE's folder); prints one line per\n"
    "                     pair: IMG_A IMG_B OFFSET_PX INLIERS\n"
    "\n"
    "Single pair output: 'offset_px O inliers N matches M confidence C'.\n"
    "Exit status: 0 ok, 1 a pair failed, 2 usage error.\n";

namespace {

struct Options {
  std::string a, b, pairs, draw;
  std::string detector = "star_brief";
  bool detector_given = false;
  ConfigNode detector_params;
  ConfigNode heading_params;
};

bool split_kv(const std::string& text, std::string& k, std::string& v) {
  const auto eq = text.find('=');
  if (eq == std::string::npos || eq == 0) return false;
  k = text.substr(0, eq);
  v = text.substr(eq + 1);
  return true;
}

Result<Options> parse(int argc, char** argv) {
  Options o;
  std::vector<std::string> positional;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto value = [&](const char* name) -> Result<std::string> {
      if (i + 1 >= argc) return fail(std::string(name) + " needs a value");
      return std::string(argv[++i]);
    };
    if (arg == "--detector") {
      VISNAV_ASSIGN(o.detector, value("--detector"));
      o.detector_given = true;
    } else if (arg == "--draw") {
      VISNAV_ASSIGN(o.draw, value("--draw"));
    } else if (arg == "--pairs") {
      VISNAV_ASSIGN(o.pairs, value("--pairs"));
    } else if (arg == "--param" || arg == "--set") {
      VISNAV_ASSIGN(std::string kv, value(arg.c_str()));
      std::string k, v;
      if (!split_kv(kv, k, v)) return fail(arg + " expects KEY=VALUE, got '" + kv + "'");
      (arg == "--param" ? o.detector_params : o.heading_params).set(k, ConfigNode::make_scalar(v, {"command line", 0}));
    } else if (!arg.empty() && arg[0] == '-') {
      return fail("unknown option '" + arg + "'");
    } else {
      positional.push_back(arg);
    }
  }
  if (o.pairs.empty()) {
    if (positional.size() != 2) return fail("expected two images (A.png B.png) or --pairs FILE");
    o.a = positional[0];
    o.b = positional[1];
  } else {
    if (!positional.empty()) return fail("--pairs takes no image arguments");
    if (!o.draw.empty()) return fail("--draw works with a single pair only");
  }
  return o;
}

struct Aligner {
  std::unique_ptr<Detector> detector;
  HeadingEstimator estimator;
  Features fa, fb;
  cv::Mat ia, ib;

  Result<HeadingEstimate> align(const std::string& a, const std::string& b) {
    ia = cv::imread(a, cv::IMREAD_GRAYSCALE);
    if (ia.empty()) return fail("cannot read image '" + a + "'");
    ib = cv::imread(b, cv::IMREAD_GRAYSCALE);
    if (ib.empty()) return fail("cannot read image '" + b + "'");
    auto st = detector->detect(ia, fa);
    if (!st) return st.error().with_context(a);
    st = detector->detect(ib, fb);
    if (!st) return st.error().with_context(b);
    return estimator.estimate(fa, fb, static_cast<double>(ib.cols));
  }
};

std::string resolve(const std::string& path, const std::filesystem::path& base) {
  std::error_code ec;
  if (std::filesystem::exists(path, ec) || std::filesystem::path(path).is_absolute()) return path;
  const auto alt = base / path;
  if (std::filesystem::exists(alt, ec)) return alt.string();
  return path;
}

}  // namespace

int run_align(int argc, char** argv, HostServices& host) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "-h" || a == "--help") {
      std::fputs(kAlignUsage, stdout);
      return 0;
    }
  }
  auto opts = parse(argc, argv);
  if (!opts) {
    std::fprintf(stderr, "visnav align: %s\n%s", opts.error().message.c_str(), kAlignUsage);
    return 2;
  }
  auto heading = HeadingParams::schema().parse(opts->heading_params.is_null() ? ConfigNode{} : opts->heading_params);
  if (!heading) {
    std::fprintf(stderr, "visnav align: --set: %s\n", heading.error().message.c_str());
    return 2;
  }
  Aligner al{nullptr, HeadingEstimator(*heading), {}, {}, {}, {}};
  auto det = host.create_detector(opts->detector, opts->detector_params);
  if (!det && !opts->detector_given) {
    std::fprintf(stderr, "visnav align: detector '%s' is not available (%s); falling back to orb\n",
                 opts->detector.c_str(), det.error().message.c_str());
    det = host.create_detector("orb", opts->detector_params);
  }
  if (!det) {
    std::fprintf(stderr, "visnav align: cannot create detector: %s\n", det.error().message.c_str());
    return 2;
  }
  al.detector = std::move(det).value();

  if (opts->pairs.empty()) {
    auto est = al.align(opts->a, opts->b);
    if (!est) {
      std::fprintf(stderr, "visnav align: %s\n", est.error().message.c_str());
      return 1;
    }
    std::printf("offset_px %.2f inliers %d matches %d confidence %.3f\n", est->offset_px, est->inliers, est->matches,
                est->confidence);
    std::fflush(stdout);
    if (!opts->draw.empty()) {
      const cv::Mat picture = render_alignment(al.ia, al.ib, al.fa, al.fb, al.estimator.last_matches(),
                                               al.estimator.last_histogram(), *est, al.estimator.params());
      bool written = false;
      try {
        written = cv::imwrite(opts->draw, picture);
      } catch (const cv::Exception& e) {
        std::fprintf(stderr, "visnav align: %s\n", e.what());
      }
      if (!written) {
        std::fprintf(stderr, "visnav align: cannot write '%s'\n", opts->draw.c_str());
        return 1;
      }
    }
    return 0;
  }

  std::ifstream in(opts->pairs);
  if (!in) {
    std::fprintf(stderr, "visnav align: cannot open pairs file '%s'\n", opts->pairs.c_str());
    return 2;
  }
  const auto base = std::filesystem::path(opts->pairs).parent_path();
  int status = 0;
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    const auto hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    std::istringstream ls(line);
    std::string a, b, extra;
    if (!(ls >> a)) continue;
    if (!(ls >> b) || (ls >> extra)) {
      std::fprintf(stderr, "visnav align: %s:%d: expected 'IMG_A IMG_B'\n", opts->pairs.c_str(), line_no);
      status = 1;
      continue;
    }
    auto est = al.align(resolve(a, base), resolve(b, base));
    if (!est) {
      std::fprintf(stderr, "visnav align: %s:%d: %s\n", opts->pairs.c_str(), line_no, est.error().message.c_str());
      std::printf("%s %s nan 0\n", a.c_str(), b.c_str());
      status = 1;
      continue;
    }
    std::printf("%s %s %.2f %d\n", a.c_str(), b.c_str(), est->offset_px, est->inliers);
  }
  std::fflush(stdout);
  return status;
}

}  // namespace visnav::feature_replay
