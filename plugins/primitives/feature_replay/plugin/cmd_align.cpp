// `visnav align` (see cmd_align.hpp and docs/feature_replay.md).
#include "cmd_align.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "visnav/feature_replay/align_score.hpp"
#include "visnav/feature_replay/draw.hpp"
#include "visnav/feature_replay/heading.hpp"

namespace visnav::feature_replay {

const char* const kAlignUsage =
    "usage: visnav align A.png B.png [--detector D] [--draw out.png] [options]\n"
    "       visnav align --pairs FILE [--detector D] [--tolerance-px T] [--csv OUT.csv]\n"
    "                    [--gate-curve CURVE.csv [--gate-steps N]] [options]\n"
    "\n"
    "Estimates the horizontal offset of the scene between two images by matching features and\n"
    "voting their horizontal displacements into a histogram (seed 002 Sec. 2.4).\n"
    "OFFSET_PX = horizontal position of the scene in B minus its position in A (positive: the\n"
    "content moved right). Every image is detected by a fresh detector whose adaptive threshold\n"
    "is settled on that image alone, so a result never depends on other pairs or their order.\n"
    "\n"
    "  --detector D       detector type (default star_brief; falls back to orb if not installed)\n"
    "  --param K=V        detector parameter (repeatable), e.g. --param target_keypoints=800;\n"
    "                     without target_keypoints/keypoints_per_mpx, keypoints_per_mpx=7500\n"
    "  --set K=V          matching/histogram parameter (repeatable): ratio, cross_check,\n"
    "                     max_descriptor_distance, max_vertical_px, bin_width_px, bin_count,\n"
    "                     refine_window_px, min_inliers, full_confidence_inliers, min_confidence,\n"
    "                     horizontal_fov_deg (min_confidence default 0.075, align's\n"
    "                     calibrated gate; docs/feature_replay.md section 7)\n"
    "  --draw out.png     write the matches and the histogram (single-pair mode)\n"
    "  --pairs FILE       lines 'IMG_A IMG_B [SHIFT_PX]' ('#' comments and blank lines skipped;\n"
    "                     relative paths are tried as given, then relative to FILE's folder);\n"
    "                     prints one line per pair:\n"
    "                       IMG_A IMG_B OFFSET_PX INLIERS CONFIDENCE AMBIGUITY [ERROR_PX]\n"
    "                     or, when there is no valid estimate,\n"
    "                       IMG_A IMG_B none reason: TEXT\n"
    "                     With a labelled SHIFT_PX, ERROR_PX = OFFSET_PX - SHIFT_PX and a last line\n"
    "                     '# pairs N valid V wrong W error_rate_pct E tolerance_px T refused R\n"
    "                      refusal_rate_pct F answered_wrong AW answered_error_rate_pct AE'\n"
    "                     scores the labelled pairs by the GRIEF protocol (Krajnik et al. 2017):\n"
    "                     wrong = 'none' or |ERROR_PX| > T; refused = 'none' (no estimate, or a\n"
    "                     pair that failed); AE = wrong among the V answered pairs ('nan' if V = 0).\n"
    "  --tolerance-px T   error tolerance of labelled pairs (default 35)\n"
    "  --csv OUT.csv      also write one CSV row per pair (a,b,shift_px,offset_px,inliers,matches,\n"
    "                     confidence,ambiguity,valid,error_px,correct,reason)\n"
    "  --gate-curve C.csv sweep the confidence gate over the labelled pairs: per threshold\n"
    "                     (0, 1/N, ..., 1) the coverage (answered fraction) and the precision\n"
    "                     (correct among answered), as min_confidence would give with --set\n"
    "  --gate-steps N     thresholds of --gate-curve: N + 1 (default 20, i.e. steps of 0.05)\n"
    "\n"
    "Single pair output: 'offset_px O inliers N matches M confidence C ambiguity A', or\n"
    "'offset_px none inliers N matches M confidence C ambiguity A reason: TEXT'.\n"
    "AMBIGUITY = second histogram peak / first (0 clear, 1 two equally supported offsets).\n"
    "Exit status: 0 every estimate valid, 1 a pair failed or had no valid estimate, 2 usage error.\n";

namespace {

struct Options {
  std::string a, b, pairs, draw;
  std::string detector = "star_brief";
  bool detector_given = false;
  double tolerance_px = 35.0;
  std::string csv, gate_curve;
  int gate_steps = 20;
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
    } else if (arg == "--tolerance-px") {
      VISNAV_ASSIGN(const std::string t, value("--tolerance-px"));
      char* end = nullptr;
      o.tolerance_px = std::strtod(t.c_str(), &end);
      if (end == t.c_str() || *end != '\0' || !(o.tolerance_px >= 0.0))
        return fail("--tolerance-px expects a number >= 0, got '" + t + "'");
    } else if (arg == "--csv") {
      VISNAV_ASSIGN(o.csv, value("--csv"));
    } else if (arg == "--gate-curve") {
      VISNAV_ASSIGN(o.gate_curve, value("--gate-curve"));
    } else if (arg == "--gate-steps") {
      VISNAV_ASSIGN(const std::string t, value("--gate-steps"));
      char* end = nullptr;
      const long n = std::strtol(t.c_str(), &end, 10);
      if (end == t.c_str() || *end != '\0' || n < 1 || n > 1000)
        return fail("--gate-steps expects an integer in [1, 1000], got '" + t + "'");
      o.gate_steps = static_cast<int>(n);
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
  if (o.pairs.empty() && (!o.csv.empty() || !o.gate_curve.empty()))
    return fail("--csv and --gate-curve work with --pairs only");
  return o;
}

// Frames of the same image given to a fresh detector so that its adaptive threshold settles on
// that image (the detectors reach their target within 6 frames from the default threshold,
// docs/detectors.md); detection stops early once the keypoint count repeats.
constexpr int kSettleFrames = 8;

// Keypoints per megapixel when the user sets no count: 3000 on a 1024×384 crop. Chosen on the
// appearance-change pair sets (docs/feature_replay.md, "Defaults chosen on appearance change").
constexpr int kAlignKeypointsPerMpx = 7500;

struct Aligner {
  HostServices* host = nullptr;
  std::string detector_type;
  ConfigNode detector_params;
  HeadingEstimator estimator;
  Features fa, fb;
  cv::Mat ia, ib;

  // A new detector per image: no state (adaptive threshold) carries over between images, so each
  // pair is estimated independently of the others and of their order.
  Status detect(const cv::Mat& image, Features& out, const std::string& name) {
    return detect_settled(*host, detector_type, detector_params, image, out, name);
  }

  Result<HeadingEstimate> align(const std::string& a, const std::string& b) {
    ia = cv::imread(a, cv::IMREAD_GRAYSCALE);
    if (ia.empty()) return fail("cannot read image '" + a + "'");
    ib = cv::imread(b, cv::IMREAD_GRAYSCALE);
    if (ib.empty()) return fail("cannot read image '" + b + "'");
    VISNAV_TRY(detect(ia, fa, a));
    VISNAV_TRY(detect(ib, fb, b));
    return estimator.estimate(fa, fb, static_cast<double>(ib.cols));
  }
};

// Why an estimate is not valid, in one line.
std::string invalid_reason(const HeadingEstimate& e, const HeadingParams& p) {
  char buf[200];
  if (e.matches == 0) return "no matches passed the gates";
  if (e.inliers < p.min_inliers) {
    std::snprintf(buf, sizeof buf, "%d inliers < min_inliers %d (%d matches)", e.inliers, p.min_inliers, e.matches);
    return buf;
  }
  std::snprintf(buf, sizeof buf, "confidence %.3f < min_confidence %.3f (%d inliers, ambiguity %.2f)", e.confidence,
                p.min_confidence, e.inliers, e.ambiguity);
  return buf;
}

// A CSV field: quoted (with doubled quotes) when it holds a comma, a quote or a line break.
std::string csv_field(const std::string& text) {
  if (text.find_first_of(",\"\n\r") == std::string::npos) return text;
  std::string out = "\"";
  for (char c : text) {
    if (c == '"') out += '"';
    out += c;
  }
  out += '"';
  return out;
}

std::string format_number(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.2f", v);
  return buf;
}

std::string percent_or_nan(double fraction) {
  if (std::isnan(fraction)) return "nan";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.1f", 100.0 * fraction);
  return buf;
}

std::string fraction_or_empty(double fraction) {
  if (std::isnan(fraction)) return "";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.4f", fraction);
  return buf;
}

}  // namespace

Status detect_settled(HostServices& host, const std::string& type, const ConfigNode& params, const cv::Mat& image,
                      Features& out, const std::string& name) {
  auto det = host.create_detector(type, params);
  if (!det) return std::move(det).error().with_context(name);
  std::size_t last = static_cast<std::size_t>(-1);
  for (int i = 0; i < kSettleFrames; ++i) {
    auto st = (*det)->detect(image, out);
    if (!st) return st.error().with_context(name);
    if (out.keypoints.size() == last) break;
    last = out.keypoints.size();
  }
  return ok();
}

std::string resolve_pair_path(const std::string& path, const std::filesystem::path& base) {
  std::error_code ec;
  if (std::filesystem::exists(path, ec) || std::filesystem::path(path).is_absolute()) return path;
  const auto alt = base / path;
  if (std::filesystem::exists(alt, ec)) return alt.string();
  return path;
}

bool print_usage_if_help(int argc, char** argv, const char* usage) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "-h" || a == "--help") {
      std::fputs(usage, stdout);
      return true;
    }
  }
  return false;
}

std::optional<HeadingParams> heading_params_or_report(const ConfigNode& sets, const char* command,
                                                     const HeadingParams& base) {
  auto heading = HeadingParams::schema().parse(sets.is_null() ? ConfigNode{} : sets, base);
  if (!heading) {
    std::fprintf(stderr, "visnav %s: --set: %s\n", command, heading.error().message.c_str());
    return std::nullopt;
  }
  return *heading;
}

namespace {

/// Creates the detector `visnav align` uses (the align keypoint density unless the user set one;
/// orb when the default detector is not available). False, after printing why, when none can be made.
bool prepare_detector(Options& opts, Aligner& al, HostServices& host) {
  // Default keypoint density (issue 13): the target follows the image area, unless the user set
  // it. A detector type without the key (a third-party plugin) gets the params as given.
  if (opts.detector_params.find("target_keypoints") == nullptr &&
      opts.detector_params.find("keypoints_per_mpx") == nullptr) {
    ConfigNode with = opts.detector_params.is_null() ? ConfigNode::make_map() : opts.detector_params;
    with.set("keypoints_per_mpx", ConfigNode::make_scalar(std::to_string(kAlignKeypointsPerMpx), {"align default", 0}));
    if (host.create_detector(opts.detector, with)) {
      opts.detector_params = with;
      al.detector_params = with;
    }
  }
  auto det = host.create_detector(opts.detector, opts.detector_params);
  if (!det && !opts.detector_given) {
    std::fprintf(stderr, "visnav align: detector '%s' is not available (%s); falling back to orb\n",
                 opts.detector.c_str(), det.error().message.c_str());
    al.detector_type = "orb";
    det = host.create_detector("orb", opts.detector_params);
  }
  if (!det) {
    std::fprintf(stderr, "visnav align: cannot create detector: %s\n", det.error().message.c_str());
    return false;
  }
  return true;
}

/// `visnav align A B [--draw F]`: one estimate printed; exit 0 when it is valid.
int align_single(const Options& opts, Aligner& al) {
  auto est = al.align(opts.a, opts.b);
  if (!est) {
    std::fprintf(stderr, "visnav align: %s\n", est.error().message.c_str());
    return 1;
  }
  if (est->valid)
    std::printf("offset_px %.2f inliers %d matches %d confidence %.3f ambiguity %.3f\n", est->offset_px, est->inliers,
                est->matches, est->confidence, est->ambiguity);
  else
    std::printf("offset_px none inliers %d matches %d confidence %.3f ambiguity %.3f reason: %s\n", est->inliers,
                est->matches, est->confidence, est->ambiguity, invalid_reason(*est, al.estimator.params()).c_str());
  std::fflush(stdout);
  if (!opts.draw.empty()) {
    const cv::Mat picture = render_alignment(al.ia, al.ib, al.fa, al.fb, al.estimator.last_matches(),
                                             al.estimator.last_histogram(), *est, al.estimator.params());
    bool written = false;
    try {
      written = cv::imwrite(opts.draw, picture);
    } catch (const cv::Exception& e) {
      std::fprintf(stderr, "visnav align: %s\n", e.what());
    }
    if (!written) {
      std::fprintf(stderr, "visnav align: cannot write '%s'\n", opts.draw.c_str());
      return 1;
    }
  }
  return est->valid ? 0 : 1;
}

/// One line of a pairs file: IMG_A IMG_B [SHIFT_PX], '#' starts a comment.
struct PairLine {
  std::string a, b;
  bool has_shift = false;
  double shift_px = 0.0;
};
enum class PairLineKind { blank, pair, malformed };

/// Parses `line` (line `line_no` of `file`); a malformed line is reported on stderr.
PairLineKind parse_pair_line(std::string line, const std::string& file, int line_no, PairLine& out) {
  const auto hash = line.find('#');
  if (hash != std::string::npos) line.resize(hash);
  std::istringstream ls(line);
  std::string shift_text, extra;
  out = PairLine{};
  if (!(ls >> out.a)) return PairLineKind::blank;
  if (!(ls >> out.b) || ((ls >> shift_text) && (ls >> extra))) {
    std::fprintf(stderr, "visnav align: %s:%d: expected 'IMG_A IMG_B [SHIFT_PX]'\n", file.c_str(), line_no);
    return PairLineKind::malformed;
  }
  if (!shift_text.empty()) {
    char* end = nullptr;
    out.shift_px = std::strtod(shift_text.c_str(), &end);
    if (end == shift_text.c_str() || *end != '\0' || !std::isfinite(out.shift_px)) {
      std::fprintf(stderr, "visnav align: %s:%d: SHIFT_PX '%s' is not a number\n", file.c_str(), line_no,
                   shift_text.c_str());
      return PairLineKind::malformed;
    }
    out.has_shift = true;
  }
  return PairLineKind::pair;
}

/// One --csv row: the pair, its estimate (or the error), the error against the label, the reason.
void write_csv_row(std::ofstream& csv, const PairLine& pair, const Result<HeadingEstimate>& est, double error_px,
                   double tolerance_px, const std::string& reason) {
  const bool valid = est && est->valid;
  char buf[256];
  csv << csv_field(pair.a) << ',' << csv_field(pair.b) << ',';
  if (pair.has_shift) csv << format_number(pair.shift_px);
  csv << ',';
  if (est) {
    std::snprintf(buf, sizeof buf, "%s,%d,%d,%.4f,%.4f,%d", est->matches > 0 ? format_number(est->offset_px).c_str() : "",
                  est->inliers, est->matches, est->confidence, est->ambiguity, est->valid ? 1 : 0);
    csv << buf;
  } else {
    csv << ",0,0,0,1,0";
  }
  csv << ',';
  if (pair.has_shift && valid) csv << format_number(error_px);
  csv << ',';
  if (pair.has_shift) csv << ((valid && std::abs(error_px) <= tolerance_px) ? 1 : 0);
  csv << ',' << csv_field(reason) << '\n';
}

/// The --gate-curve file: the pairs' score for each gate value.
void write_gate_curve(std::ofstream& curve, const std::vector<PairOutcome>& outcomes, int steps, double tolerance_px) {
  curve << "min_confidence,pairs,answered,coverage,correct,precision,wrong,error_rate,refusal_rate,"
           "answered_error_rate\n";
  for (const AlignScore& pt : gate_curve(outcomes, steps, tolerance_px)) {
    char buf[256];
    std::snprintf(buf, sizeof buf, "%.4f,%d,%d,%.4f,%d,%s,%d,%.4f,%.4f,%s\n", pt.min_confidence, pt.pairs,
                  pt.answered, pt.coverage, pt.answered - pt.wrong_answered, fraction_or_empty(pt.precision).c_str(),
                  pt.wrong, pt.error_rate, pt.refusal_rate, fraction_or_empty(pt.answered_error_rate).c_str());
    curve << buf;
  }
}

/// Opens `path` for writing (nothing when empty); false, after printing, when it cannot be.
bool open_output(std::ofstream& file, const std::string& path, const char* option) {
  if (path.empty()) return true;
  file.open(path);
  if (!file) {
    std::fprintf(stderr, "visnav align: %s: cannot write '%s'\n", option, path.c_str());
    return false;
  }
  return true;
}

/// `visnav align --pairs FILE`: every pair estimated and printed, the GRIEF-protocol score of the
/// labelled ones, --csv rows and the --gate-curve. Exit 0 when every pair got a valid estimate.
int align_pairs(const Options& opts, Aligner& al) {
  std::ifstream in(opts.pairs);
  if (!in) {
    std::fprintf(stderr, "visnav align: cannot open pairs file '%s'\n", opts.pairs.c_str());
    return 2;
  }
  // Output files are opened before the first pair, so a bad path fails at once.
  std::ofstream csv, curve;
  if (!open_output(csv, opts.csv, "--csv")) return 2;
  if (csv.is_open()) csv << "a,b,shift_px,offset_px,inliers,matches,confidence,ambiguity,valid,error_px,correct,reason\n";
  if (!open_output(curve, opts.gate_curve, "--gate-curve")) return 2;
  const auto base = std::filesystem::path(opts.pairs).parent_path();
  const HeadingParams& hp = al.estimator.params();
  int status = 0;
  std::vector<PairOutcome> outcomes;
  std::string line;
  int line_no = 0;
  PairLine pair;
  while (std::getline(in, line)) {
    ++line_no;
    const PairLineKind kind = parse_pair_line(line, opts.pairs, line_no, pair);
    if (kind == PairLineKind::blank) continue;
    if (kind == PairLineKind::malformed) {
      status = 1;
      continue;
    }
    auto est = al.align(resolve_pair_path(pair.a, base), resolve_pair_path(pair.b, base));
    PairOutcome outcome;
    outcome.shift_px = pair.shift_px;
    std::string reason;
    if (!est) {
      std::fprintf(stderr, "visnav align: %s:%d: %s\n", opts.pairs.c_str(), line_no, est.error().message.c_str());
      reason = est.error().message;
    } else {
      outcome.estimated = est->matches > 0;
      outcome.offset_px = est->offset_px;
      outcome.confidence = est->confidence;
      if (!est->valid) reason = invalid_reason(*est, hp);
    }
    const bool valid = est && est->valid;
    const double error_px = valid ? est->offset_px - pair.shift_px : 0.0;
    if (pair.has_shift) outcomes.push_back(outcome);
    if (!valid) {
      std::printf("%s %s none reason: %s\n", pair.a.c_str(), pair.b.c_str(), reason.c_str());
      status = 1;
    } else {
      std::printf("%s %s %.2f %d %.3f %.3f", pair.a.c_str(), pair.b.c_str(), est->offset_px, est->inliers,
                  est->confidence, est->ambiguity);
      if (pair.has_shift) std::printf(" %.2f", error_px);
      std::printf("\n");
    }
    if (csv.is_open()) write_csv_row(csv, pair, est, error_px, opts.tolerance_px, reason);
  }
  if (!outcomes.empty()) {
    const AlignScore sc = score_pairs(outcomes, hp.min_confidence, opts.tolerance_px);
    std::printf("# pairs %d valid %d wrong %d error_rate_pct %.1f tolerance_px %.1f refused %d refusal_rate_pct %.1f "
                "answered_wrong %d answered_error_rate_pct %s\n",
                sc.pairs, sc.answered, sc.wrong, 100.0 * sc.error_rate, opts.tolerance_px, sc.refused,
                100.0 * sc.refusal_rate, sc.wrong_answered, percent_or_nan(sc.answered_error_rate).c_str());
  }
  if (curve.is_open()) write_gate_curve(curve, outcomes, opts.gate_steps, opts.tolerance_px);
  std::fflush(stdout);
  for (auto* f : {&csv, &curve}) {
    if (!f->is_open()) continue;
    f->flush();
    if (!*f) {
      std::fprintf(stderr, "visnav align: cannot write '%s'\n", (f == &csv ? opts.csv : opts.gate_curve).c_str());
      status = 1;
    }
  }
  return status;
}

}  // namespace

int run_align(int argc, char** argv, HostServices& host) {
  if (print_usage_if_help(argc, argv, kAlignUsage)) return 0;
  auto opts = parse(argc, argv);
  if (!opts) {
    std::fprintf(stderr, "visnav align: %s\n%s", opts.error().message.c_str(), kAlignUsage);
    return 2;
  }
  const auto heading = heading_params_or_report(opts->heading_params, "align", calibrated_heading_params());
  if (!heading) return 2;
  Aligner al{&host, opts->detector, opts->detector_params, HeadingEstimator(*heading), {}, {}, {}, {}};
  if (!prepare_detector(*opts, al, host)) return 2;
  return opts->pairs.empty() ? align_single(*opts, al) : align_pairs(*opts, al);
}

}  // namespace visnav::feature_replay
