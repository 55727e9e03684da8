// GRIEF pairs files — see grief.hpp for the format and the error contract.
#include "visnav/detectors/grief.hpp"

#include <charconv>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <system_error>

#include "visnav/config_node.hpp"

namespace visnav::detectors {

namespace {

/// A problem of the pairs file at `node` (its file and line), keyed `key` when one is known.
Error at(const ConfigNode& node, const std::string& message, ErrorCode code = ErrorCode::invalid_value,
         std::string key = {}) {
  return Error{node.where().str() + ": " + message, code, {node.where().file, node.where().line, std::move(key)}};
}

Result<int> integer(const ConfigNode& node, const std::string& what) {
  if (!node.is_scalar()) return at(node, what + ": expected an integer");
  const std::string& s = node.scalar();
  int v = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || end != s.data() + s.size()) return at(node, what + ": '" + s + "' is not an integer");
  return v;
}

}  // namespace

namespace {

/// The checks of a parsed pairs file; `path` labels the errors without a node.
Result<PairsFile> pairs_from(const ConfigNode& root, const std::string& path) {
  if (!root.is_map()) return at(root, "a pairs file is a map with keys patch_size_px, pairs");
  PairsFile out;
  const ConfigNode* pairs = nullptr;
  const ConfigNode* patch = nullptr;
  for (const auto& [key, value] : root.entries()) {
    if (key == "patch_size_px") patch = &value;
    else if (key == "pairs") pairs = &value;
    else if (key == "training") out.training = value;
    else return at(value, "unknown key '" + key + "' (expected patch_size_px, pairs, training)", ErrorCode::unknown_key, key);
  }
  if (patch == nullptr) return fail(ErrorCode::missing, {path, 0, "patch_size_px"}, "missing key 'patch_size_px'");
  if (pairs == nullptr) return fail(ErrorCode::missing, {path, 0, "pairs"}, "missing key 'pairs'");
  VISNAV_ASSIGN(out.patch_size_px, integer(*patch, "key 'patch_size_px'"));
  BriefParams bp;
  bp.patch_size_px = out.patch_size_px;
  if (auto st = bp.validate(); !st)
    return at(*patch, "key 'patch_size_px': " + st.error().message, ErrorCode::out_of_range, "patch_size_px");
  if (!pairs->is_sequence()) return at(*pairs, "key 'pairs': expected a list of [x1, y1, x2, y2]");
  const auto& items = pairs->items();
  if (items.size() != static_cast<std::size_t>(BriefExtractor::kBits))
    return at(*pairs, "key 'pairs': expected exactly " + std::to_string(BriefExtractor::kBits) + " pairs, got " +
                          std::to_string(items.size()),
              ErrorCode::out_of_range, "pairs");
  out.pairs.reserve(items.size());
  for (std::size_t i = 0; i < items.size(); ++i) {
    const ConfigNode& item = items[i];
    const std::string what = "pair " + std::to_string(i);
    if (!item.is_sequence() || item.items().size() != 4) return at(item, what + ": expected [x1, y1, x2, y2]");
    int v[4];
    for (int k = 0; k < 4; ++k) {
      VISNAV_ASSIGN(v[k], integer(item.items()[static_cast<std::size_t>(k)], what));
    }
    out.pairs.push_back(BriefTest{v[0], v[1], v[2], v[3]});
    // Validate each pair where it is written, so the message carries its line.
    std::vector<BriefTest> one(static_cast<std::size_t>(BriefExtractor::kBits), BriefTest{0, 0, 1, 0});
    one[0] = out.pairs.back();
    if (auto st = BriefExtractor::validate_pattern(one, out.patch_size_px); !st) {
      std::string msg = st.error().message;
      if (msg.rfind("pair 0", 0) == 0) msg = what + msg.substr(6);
      return at(item, msg, ErrorCode::out_of_range, "pairs");
    }
  }
  return out;
}

}  // namespace

Result<PairsFile> read_pairs_file(const std::string& path) {
  VISNAV_ASSIGN(const ConfigNode root, parse_yaml_file(path));
  return pairs_from(root, path);
}

Result<PairsFile> parse_pairs_text(std::string_view yaml, const std::string& file_label) {
  VISNAV_ASSIGN(const ConfigNode root, parse_yaml_string(yaml, file_label));
  return pairs_from(root, file_label);
}

Result<PairsFile> seasonal_pairs() {
  static const Result<PairsFile> parsed = parse_pairs_text(seasonal_pairs_yaml(), "grief_seasonal.yaml (built in)");
  return parsed;
}

Status write_pairs_file(const std::string& path, const PairsFile& file,
                        const std::vector<std::pair<std::string, std::string>>& training, const std::string& comment) {
  VISNAV_TRY(BriefExtractor::validate_pattern(file.pairs, file.patch_size_px));
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::trunc);
    if (!out) return fail("cannot write '" + tmp + "'");
    out << "# GRIEF comparison pairs: 256 tests [I(x1, y1) < I(x2, y2)], px relative to the keypoint\n";
    if (!comment.empty()) out << "# " << comment << "\n";
    out << "patch_size_px: " << file.patch_size_px << "\npairs:\n";
    for (const BriefTest& t : file.pairs)
      out << "  - [" << t.x1 << ", " << t.y1 << ", " << t.x2 << ", " << t.y2 << "]\n";
    if (!training.empty()) {
      out << "training:\n";
      for (const auto& [k, v] : training) out << "  " << k << ": " << v << "\n";
    }
    out.flush();
    if (!out) return fail("cannot write '" + tmp + "'");
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) return fail("cannot rename '" + tmp + "' to '" + path + "': " + ec.message());
  return ok();
}

}  // namespace visnav::detectors
