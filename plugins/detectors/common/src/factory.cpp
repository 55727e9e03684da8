// Factory over all detector types (for code that does not go through the plugin loader).
#include <string>

#include "visnav/detectors/detector_types.hpp"

namespace visnav::detectors {

namespace {

template <typename Impl>
Result<std::unique_ptr<DetectorBase>> make(const ConfigNode& params) {
  auto made = Impl::create(params);
  if (!made) return std::move(made).error();
  return std::unique_ptr<DetectorBase>(std::move(made).value());
}

struct Entry {
  const char* name;
  Result<std::unique_ptr<DetectorBase>> (*create)(const ConfigNode&);
  std::vector<ParamDoc> (*docs)();
};

template <typename Impl>
std::vector<ParamDoc> docs_of() {
  return Impl::Params::schema().docs();
}

const Entry kEntries[] = {
    {StarBriefDetector::kTypeName, &make<StarBriefDetector>, &docs_of<StarBriefDetector>},
    {GriefDetector::kTypeName, &make<GriefDetector>, &docs_of<GriefDetector>},
    {OrbDetector::kTypeName, &make<OrbDetector>, &docs_of<OrbDetector>},
    {AgastBriefDetector::kTypeName, &make<AgastBriefDetector>, &docs_of<AgastBriefDetector>},
    {FastBriefDetector::kTypeName, &make<FastBriefDetector>, &docs_of<FastBriefDetector>},
    {GfttBriefDetector::kTypeName, &make<GfttBriefDetector>, &docs_of<GfttBriefDetector>},
    {SiftDetector::kTypeName, &make<SiftDetector>, &docs_of<SiftDetector>},
    {AkazeDetector::kTypeName, &make<AkazeDetector>, &docs_of<AkazeDetector>},
    {BriskDetector::kTypeName, &make<BriskDetector>, &docs_of<BriskDetector>},
};

const Entry* find(std::string_view type) {
  for (const auto& e : kEntries)
    if (type == e.name) return &e;
  return nullptr;
}

std::string known_types() {
  std::string s;
  for (const auto& e : kEntries) s += (s.empty() ? "" : ", ") + std::string(e.name);
  return s;
}

}  // namespace

const std::vector<std::string>& detector_type_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> v;
    for (const auto& e : kEntries) v.emplace_back(e.name);
    return v;
  }();
  return names;
}

Result<std::unique_ptr<DetectorBase>> create_detector(std::string_view type, const ConfigNode& params) {
  const Entry* e = find(type);
  if (e == nullptr) return fail(ErrorCode::not_found, "unknown detector type '" + std::string(type) + "' (known: " + known_types() + ")");
  try {
    return e->create(params);
  } catch (const std::exception& ex) {
    return fail("detector '" + std::string(type) + "': " + ex.what());
  }
}

Result<std::vector<ParamDoc>> detector_param_docs(std::string_view type) {
  const Entry* e = find(type);
  if (e == nullptr) return fail(ErrorCode::not_found, "unknown detector type '" + std::string(type) + "' (known: " + known_types() + ")");
  return e->docs();
}

ConfigNode make_params(std::initializer_list<std::pair<std::string, std::string>> entries) {
  ConfigNode node = ConfigNode::make_map();
  for (const auto& [key, value] : entries) node.set(key, ConfigNode::make_scalar(value));
  return node;
}

}  // namespace visnav::detectors
