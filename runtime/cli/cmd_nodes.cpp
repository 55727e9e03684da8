// `visnav nodes`: list the registered behaviour-tree node types, or write a TreeNodesModel.
#include <fstream>
#include <iostream>

#include "args.hpp"
#include "command.hpp"
#include "visnav/bt/registry.hpp"
#include "visnav/runner.hpp"

namespace {

constexpr const char* kUsage =
    "usage: visnav nodes [--xml [--tree T]] [--output F] [--no-builtin] [--config C] [--plugin-path DIR]...\n"
    "\n"
    "Lists every registered node type (built-in BehaviorTree.CPP nodes and those of the nodes\n"
    "plugins found on the search path) with its kind, description and ports.\n"
    "  --xml          write a <TreeNodesModel> (loadable as a Groot2 palette) instead\n"
    "  --tree T       with --xml: add a <SubTree> model (its remapped ports) for every\n"
    "                 BehaviorTree of T and its includes, so Groot2 keeps SubTree ports on save\n"
    "  --output F     write to F instead of stdout\n"
    "  --no-builtin   leave out the built-in nodes\n"
    "  --config C     use C's plugin_path and nodes selection\n"
    "  --plugin-path  extra plugin directory\n";

const char* kind_name(visnav::bt::NodeKind k) {
  switch (k) {
    case visnav::bt::NodeKind::action: return "Action";
    case visnav::bt::NodeKind::condition: return "Condition";
    case visnav::bt::NodeKind::control: return "Control";
    case visnav::bt::NodeKind::decorator: return "Decorator";
    case visnav::bt::NodeKind::subtree: return "SubTree";
  }
  return "?";
}

const char* direction_name(visnav::bt::PortDirection d) {
  switch (d) {
    case visnav::bt::PortDirection::input: return "in";
    case visnav::bt::PortDirection::output: return "out";
    case visnav::bt::PortDirection::inout: return "inout";
  }
  return "?";
}

int run(const std::vector<std::string>& args) {
  using visnav::cli::Opt;
  visnav::cli::Args a;
  if (auto st = a.parse(args, {{"--xml", Opt::flag}, {"--tree", Opt::value}, {"--output", Opt::value}, {"--no-builtin", Opt::flag},
                               {"--config", Opt::value}, {"--plugin-path", Opt::repeated}});
      !st)
    return visnav::cli::usage_error("nodes", st.error().message);

  std::vector<std::string> dirs = a.all("--plugin-path");
  std::optional<std::vector<std::string>> only;
  if (a.has("--config")) {
    auto config = visnav::load_run_config(a.get("--config"));
    if (!config) {
      std::cerr << "visnav nodes: " << config.error().message << "\n";
      return 1;
    }
    dirs.insert(dirs.begin(), config->plugin_path.begin(), config->plugin_path.end());
    only = config->nodes;
  }
  visnav::StderrLogger logger(visnav::LogLevel::warn);
  visnav::WallClock clock;
  auto loader = visnav::PluginLoader::with_default_path(dirs);
  if (auto st = loader.scan(); !st) {
    std::cerr << "visnav nodes: " << st.error().message << "\n";
    return 1;
  }
  visnav::RuntimeHost host(loader, logger, clock);
  visnav::bt::NodeRegistry registry;
  if (auto st = visnav::register_all_nodes(registry, loader, host, only); !st) {
    std::cerr << "visnav nodes: " << st.error().message << "\n";
    return 1;
  }
  const bool builtin = !a.has("--no-builtin");

  std::ofstream file;
  std::ostream* out = &std::cout;
  if (a.has("--output")) {
    file.open(a.get("--output"));
    if (!file) {
      std::cerr << "visnav nodes: cannot write " << a.get("--output") << "\n";
      return 1;
    }
    out = &file;
  }
  if (a.has("--xml")) {
    std::vector<visnav::bt::SubTreeModel> subtrees;
    if (a.has("--tree")) {
      auto models = visnav::bt::subtree_models(a.get("--tree"));
      if (!models) {
        std::cerr << "visnav nodes: " << models.error().message << "\n";
        return 1;
      }
      subtrees = std::move(*models);
    }
    *out << visnav::bt::write_nodes_model(registry, builtin, subtrees);
    return out->good() ? 0 : 1;
  }
  for (const auto* m : registry.manifests()) {
    if (m->builtin && !builtin) continue;
    *out << m->id << "  (" << kind_name(m->kind) << (m->builtin ? ", built-in" : "") << ")";
    if (!m->description.empty()) *out << "  " << m->description;
    *out << "\n";
    for (const auto& p : m->ports) {
      *out << "    " << direction_name(p.direction) << " " << p.name << " : " << p.type_name;
      if (p.default_value) *out << " = " << *p.default_value;
      else if (p.required()) *out << " (required)";
      if (!p.constraint.empty()) *out << "  " << p.constraint;  // what a literal must satisfy
      if (!p.description.empty()) *out << "  — " << p.description;
      *out << "\n";
    }
  }
  return out->good() ? 0 : 1;
}

}  // namespace

VISNAV_COMMAND(nodes, "nodes", "list behaviour-tree node types with their ports (--xml: TreeNodesModel)", kUsage, &run)
