// `visnav train-descriptor` — evolves GRIEF comparison pairs on the user's aligned image pairs
// (core: visnav/feature_replay/descriptor_training.hpp; docs/detectors.md, "grief").
#include "cmd_train_descriptor.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "cmd_align.hpp"
#include "visnav/detectors/grief.hpp"
#include "visnav/feature_replay/descriptor_training.hpp"

namespace visnav::feature_replay {

const char* const kTrainDescriptorUsage =
    "usage: visnav train-descriptor --pairs FILE.txt -o pairs.yaml [--generations N] [options]\n"
    "\n"
    "Evolves the 256 comparison pairs of a GRIEF descriptor (BRIEF with trained pairs, Krajnik et al.\n"
    "2017) on aligned image pairs, e.g. two recordings of one route in different seasons. Fitness:\n"
    "the number of pairs whose histogram-voting shift is valid and within --tolerance-px of the label\n"
    "(as `visnav align` computes it), then the number of correct matches. Use the result with the\n"
    "detector `type: grief` and `pairs: pairs.yaml`.\n"
    "\n"
    "  --pairs FILE       lines 'IMG_A IMG_B SHIFT_PX' (SHIFT_PX: scene position in B minus in A; '#'\n"
    "                     comments; relative paths as given, then relative to FILE's folder)\n"
    "  -o FILE            output pairs file (YAML; rewritten after every generation, crash-safe)\n"
    "  --generations N    generations in total (default 100)\n"
    "  --seed S           random seed (default 1); the same seed and data give the same pairs\n"
    "  --resume           continue from the generation saved in -o (same seed and pairs file)\n"
    "  --replace N        comparisons replaced per generation (default 12)\n"
    "  --tolerance-px T   a pair is correct within T px of its label (default 35)\n"
    "  --param K=V        star_brief detector parameter for the keypoints (repeatable; default\n"
    "                     target_keypoints=600)\n"
    "  --set K=V          matching/histogram parameter of the fitness (as `visnav align --set`)\n"
    "  --test FILE        also report BRIEF vs the trained pairs on these held-out pairs\n"
    "\n"
    "Progress goes to stderr; the last line on stdout: 'trained generations G correct C/N (BRIEF B/N)'.\n"
    "Exit status: 0 ok, 1 a data or I/O error, 2 usage error.\n";

namespace {

struct Options {
  std::string pairs, out, test;
  int generations = 100;
  std::uint64_t seed = 1;
  bool resume = false;
  DescriptorTrainingParams training;
  ConfigNode detector_params;
  ConfigNode heading_params;
};

Result<long> parse_long(const std::string& name, const std::string& text, long lo, long hi) {
  char* end = nullptr;
  const long v = std::strtol(text.c_str(), &end, 10);
  if (end == text.c_str() || *end != '\0' || v < lo || v > hi)
    return fail(name + " expects an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got '" +
                text + "'");
  return v;
}

Result<Options> parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto value = [&]() -> Result<std::string> {
      if (i + 1 >= argc) return fail(arg + " needs a value");
      return std::string(argv[++i]);
    };
    if (arg == "--pairs") {
      VISNAV_ASSIGN(o.pairs, value());
    } else if (arg == "-o") {
      VISNAV_ASSIGN(o.out, value());
    } else if (arg == "--test") {
      VISNAV_ASSIGN(o.test, value());
    } else if (arg == "--generations") {
      VISNAV_ASSIGN(const std::string v, value());
      VISNAV_ASSIGN(const long n, parse_long(arg, v, 0, 100000));
      o.generations = static_cast<int>(n);
    } else if (arg == "--seed") {
      VISNAV_ASSIGN(const std::string v, value());
      VISNAV_ASSIGN(const long n, parse_long(arg, v, 0, 2147483647L));
      o.seed = static_cast<std::uint64_t>(n);
    } else if (arg == "--replace") {
      VISNAV_ASSIGN(const std::string v, value());
      VISNAV_ASSIGN(const long n, parse_long(arg, v, 1, 256));
      o.training.replace_per_generation = static_cast<int>(n);
    } else if (arg == "--tolerance-px") {
      VISNAV_ASSIGN(const std::string v, value());
      char* end = nullptr;
      o.training.tolerance_px = std::strtod(v.c_str(), &end);
      if (end == v.c_str() || *end != '\0' || !(o.training.tolerance_px > 0.0))
        return fail("--tolerance-px expects a number > 0, got '" + v + "'");
    } else if (arg == "--resume") {
      o.resume = true;
    } else if (arg == "--param" || arg == "--set") {
      VISNAV_ASSIGN(const std::string kv, value());
      const auto eq = kv.find('=');
      if (eq == std::string::npos || eq == 0) return fail(arg + " expects KEY=VALUE, got '" + kv + "'");
      (arg == "--param" ? o.detector_params : o.heading_params)
          .set(kv.substr(0, eq), ConfigNode::make_scalar(kv.substr(eq + 1), {"command line", 0}));
    } else {
      return fail("unknown argument '" + arg + "'");
    }
  }
  if (o.pairs.empty() || o.out.empty()) return fail("--pairs FILE and -o FILE are required");
  if (o.detector_params.find("target_keypoints") == nullptr)
    o.detector_params.set("target_keypoints", ConfigNode::make_scalar("600", {"default", 0}));
  if (const ConfigNode* ps = o.detector_params.find("patch_size_px")) {
    VISNAV_ASSIGN(const long n, parse_long("patch_size_px", ps->scalar(), 16, 96));
    o.training.patch_size_px = static_cast<int>(n);
  }
  if (const ConfigNode* ks = o.detector_params.find("kernel_size_px")) {
    VISNAV_ASSIGN(const long n, parse_long("kernel_size_px", ks->scalar(), 1, 15));
    o.training.kernel_size_px = static_cast<int>(n);
  }
  o.training.seed = o.seed;
  return o;
}

// Reads 'A B SHIFT' lines and detects the keypoints of every image (settled threshold).
Result<std::vector<TrainingPair>> load_pairs(const std::string& file, HostServices& host, const ConfigNode& params) {
  std::ifstream in(file);
  if (!in) return fail("cannot open pairs file '" + file + "'");
  const auto base = std::filesystem::path(file).parent_path();
  std::vector<TrainingPair> pairs;
  std::string line;
  int line_no = 0;
  Features f;
  while (std::getline(in, line)) {
    ++line_no;
    const auto hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    std::istringstream ls(line);
    std::string a, b, shift_text, extra;
    if (!(ls >> a)) continue;
    const std::string where = file + ":" + std::to_string(line_no);
    if (!(ls >> b >> shift_text) || (ls >> extra)) return fail(where + ": expected 'IMG_A IMG_B SHIFT_PX'");
    char* end = nullptr;
    const double shift = std::strtod(shift_text.c_str(), &end);
    if (end == shift_text.c_str() || *end != '\0' || !std::isfinite(shift))
      return fail(where + ": SHIFT_PX '" + shift_text + "' is not a number");
    TrainingPair p;
    p.shift_px = shift;
    const std::string pa = resolve_pair_path(a, base), pb = resolve_pair_path(b, base);
    p.grey_a = cv::imread(pa, cv::IMREAD_GRAYSCALE);
    p.grey_b = cv::imread(pb, cv::IMREAD_GRAYSCALE);
    if (p.grey_a.empty()) return fail(where + ": cannot read image '" + pa + "'");
    if (p.grey_b.empty()) return fail(where + ": cannot read image '" + pb + "'");
    VISNAV_TRY(detect_settled(host, "star_brief", params, p.grey_a, f, where + ": " + pa));
    p.keypoints_a = f.keypoints;
    VISNAV_TRY(detect_settled(host, "star_brief", params, p.grey_b, f, where + ": " + pb));
    p.keypoints_b = f.keypoints;
    pairs.push_back(std::move(p));
  }
  if (pairs.empty()) return fail(file + ": no pairs");
  return pairs;
}

// One bar line per tenth when stderr is not a terminal (logs), a redrawn bar when it is.
class Progress {
 public:
  Progress(int start, int total) : start_(start), total_(total), tty_(::isatty(STDERR_FILENO) != 0) {}
  void update(int done, const TrainingFitness& f) {
    const int span = std::max(1, total_ - start_);
    const int tenth = (done - start_) * 10 / span;
    if (!tty_ && tenth == last_tenth_ && done != total_) return;
    last_tenth_ = tenth;
    const int width = 30;
    const int fill = total_ > 0 ? done * width / total_ : width;
    std::string bar(static_cast<std::size_t>(fill), '#');
    bar.resize(static_cast<std::size_t>(width), '.');
    std::fprintf(stderr, "%s[%s] generation %d/%d  correct %d/%d  matches %d%s", tty_ ? "\r" : "", bar.c_str(), done,
                 total_, f.correct_pairs, f.pairs, f.correct_matches, tty_ ? "" : "\n");
    if (tty_ && done == total_) std::fputc('\n', stderr);
    std::fflush(stderr);
  }

 private:
  int start_, total_;
  bool tty_;
  int last_tenth_ = -1;
};

std::string fitness_text(const TrainingFitness& f) {
  return std::to_string(f.correct_pairs) + "/" + std::to_string(f.pairs);
}

}  // namespace

int run_train_descriptor(int argc, char** argv, HostServices& host) {
  if (print_usage_if_help(argc, argv, kTrainDescriptorUsage)) return 0;
  auto opts = parse(argc, argv);
  if (!opts) {
    std::fprintf(stderr, "visnav train-descriptor: %s\n%s", opts.error().message.c_str(), kTrainDescriptorUsage);
    return 2;
  }
  const auto heading = heading_params_or_report(opts->heading_params, "train-descriptor", HeadingParams{});
  if (!heading) return 2;
  opts->training.heading = *heading;
  auto fail_with = [](const std::string& m) {
    std::fprintf(stderr, "visnav train-descriptor: %s\n", m.c_str());
    return 1;
  };

  // Resume: the saved pattern and the number of generations it has seen.
  int start = 0;
  std::vector<detectors::BriefTest> resumed;
  if (opts->resume && std::filesystem::exists(opts->out)) {
    auto saved = detectors::read_pairs_file(opts->out);
    if (!saved) return fail_with("--resume: " + saved.error().message);
    const ConfigNode* g = saved->training.is_map() ? saved->training.find("generation") : nullptr;
    const ConfigNode* s = saved->training.is_map() ? saved->training.find("seed") : nullptr;
    if (g == nullptr || s == nullptr || !g->is_scalar() || !s->is_scalar())
      return fail_with("--resume: " + opts->out + " has no training.generation / training.seed (not written by train-descriptor?)");
    if (s->scalar() != std::to_string(opts->seed))
      return fail_with("--resume: " + s->where().str() + ": seed " + s->scalar() + " differs from --seed " +
                       std::to_string(opts->seed));
    if (saved->patch_size_px != opts->training.patch_size_px)
      return fail_with("--resume: " + opts->out + " has patch_size_px " + std::to_string(saved->patch_size_px));
    start = std::atoi(g->scalar().c_str());
    resumed = std::move(saved->pairs);
  }

  std::fprintf(stderr, "visnav train-descriptor: detecting keypoints of %s ...\n", opts->pairs.c_str());
  auto pairs = load_pairs(opts->pairs, host, opts->detector_params);
  if (!pairs) return fail_with(pairs.error().message);
  auto trainer = DescriptorTrainer::create(opts->training, std::move(pairs).value());
  if (!trainer) return fail_with(trainer.error().message);
  const TrainingFitness brief = trainer->fitness();  // the BRIEF pattern
  if (!resumed.empty()) {
    if (auto st = trainer->set_pattern(resumed); !st) return fail_with(opts->out + ": " + st.error().message);
  }

  auto save = [&](int generation) -> Status {
    detectors::PairsFile f;
    f.patch_size_px = opts->training.patch_size_px;
    f.pairs = trainer->pattern();
    const TrainingFitness& fit = trainer->fitness();
    return detectors::write_pairs_file(
        opts->out, f,
        {{"generation", std::to_string(generation)},
         {"generations", std::to_string(opts->generations)},
         {"seed", std::to_string(opts->seed)},
         {"replace_per_generation", std::to_string(opts->training.replace_per_generation)},
         {"tolerance_px", std::to_string(opts->training.tolerance_px)},
         {"pairs_file", "\"" + opts->pairs + "\""},
         {"correct_pairs", std::to_string(fit.correct_pairs)},
         {"training_pairs", std::to_string(fit.pairs)},
         {"correct_matches", std::to_string(fit.correct_matches)},
         {"brief_correct_pairs", std::to_string(brief.correct_pairs)}},
        "trained by visnav train-descriptor; use with detector type grief, pairs: <this file>");
  };

  Progress progress(start, opts->generations);
  progress.update(start, trainer->fitness());
  for (int g = start; g < opts->generations; ++g) {
    trainer->run_generation(g);
    if (auto st = save(g + 1); !st) return fail_with(st.error().message);
    progress.update(g + 1, trainer->fitness());
  }
  if (start >= opts->generations) {
    if (auto st = save(start); !st) return fail_with(st.error().message);
  }
  std::printf("trained generations %d correct %s (BRIEF %s) matches %d (BRIEF %d) -> %s\n",
              std::max(start, opts->generations), fitness_text(trainer->fitness()).c_str(),
              fitness_text(brief).c_str(), trainer->fitness().correct_matches, brief.correct_matches,
              opts->out.c_str());
  if (!opts->test.empty()) {
    auto test_pairs = load_pairs(opts->test, host, opts->detector_params);
    if (!test_pairs) return fail_with(test_pairs.error().message);
    auto tester = DescriptorTrainer::create(opts->training, std::move(test_pairs).value());
    if (!tester) return fail_with(tester.error().message);
    const TrainingFitness test_brief = tester->fitness();
    const TrainingFitness test_trained = tester->evaluate(trainer->pattern());
    std::printf("held-out %s: correct %s (BRIEF %s) matches %d (BRIEF %d)\n", opts->test.c_str(),
                fitness_text(test_trained).c_str(), fitness_text(test_brief).c_str(), test_trained.correct_matches,
                test_brief.correct_matches);
  }
  std::fflush(stdout);
  return 0;
}

}  // namespace visnav::feature_replay
