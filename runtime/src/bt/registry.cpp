// NodeRegistry and the TreeNodesModel export.
#include "visnav/bt/registry.hpp"

#include <tinyxml2.h>

#include <algorithm>
#include <map>
#include <set>

#include "visnav/file_io.hpp"

namespace visnav::bt {

namespace {

bool valid_identifier(std::string_view id) {
  if (id.empty()) return false;
  return std::all_of(id.begin(), id.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-' ||
           c == '.' || c == ':';
  });
}

Status check_manifest(const NodeManifest& m, const EnumTables* enums) {
  if (!valid_identifier(m.id))
    return fail("invalid node ID '" + m.id + "' (letters, digits, '_', '-', '.', ':' only)");
  if (m.min_children < 0 || (m.max_children >= 0 && m.max_children < m.min_children))
    return fail("node '" + m.id + "': invalid children range");
  for (std::size_t i = 0; i < m.ports.size(); ++i) {
    const PortInfo& p = m.ports[i];
    if (!valid_identifier(p.name)) return fail("node '" + m.id + "': invalid port name '" + p.name + "'");
    if (p.name == "name" || p.name == "ID" || p.name.front() == '_')
      return fail("node '" + m.id + "': port name '" + p.name + "' is reserved");
    for (std::size_t j = 0; j < i; ++j)
      if (m.ports[j].name == p.name) return fail("node '" + m.id + "': duplicate port '" + p.name + "'");
    if (p.default_value) {
      const bool is_ref = blackboard_key(*p.default_value).has_value();
      if (p.direction == PortDirection::output && !is_ref)
        return fail("node '" + m.id + "': default of output port '" + p.name + "' must be a blackboard reference {key}");
      // Enum defaults are checked at load time (enums may be registered after the node).
      if (!is_ref && p.parse != nullptr && enums != nullptr && !(p.type_name == "enum")) {
        auto parsed = p.parse(*p.default_value, enums);
        if (!parsed)
          return Error{"node '" + m.id + "': default of port '" + p.name + "': " + parsed.error().message,
                       parsed.error().with_default_code(ErrorCode::invalid_value).code, {{}, 0, p.name}};
      }
    }
  }
  return ok();
}

}  // namespace

NodeRegistry::NodeRegistry() : enums_(std::make_shared<const EnumTables>()) {}

Status NodeRegistry::register_manifest(NodeManifest manifest, NodeFactory factory) {
  if (!factory) return fail("node '" + manifest.id + "': no factory");
  VISNAV_TRY(check_manifest(manifest, enums_.get()));
  if (entries_.find(manifest.id) != entries_.end())
    return Error{"node ID '" + manifest.id + "' is already registered", ErrorCode::inconsistent, {{}, 0, manifest.id}};
  manifest.builtin = registering_builtins_;
  std::string id = manifest.id;
  entries_.emplace(std::move(id), Entry{std::make_shared<const NodeManifest>(std::move(manifest)), std::move(factory)});
  return ok();
}

Status NodeRegistry::register_enum_values(std::type_index type, std::string type_name,
                                          std::vector<std::pair<std::string, int>> values) {
  auto copy = std::make_shared<EnumTables>(*enums_);  // trees keep the tables they were built with
  VISNAV_TRY(copy->add(type, std::move(type_name), std::move(values)));
  enums_ = std::move(copy);
  return ok();
}

const NodeManifest* NodeRegistry::find(std::string_view id) const noexcept {
  auto it = entries_.find(id);
  return it == entries_.end() ? nullptr : it->second.manifest.get();
}

std::shared_ptr<const NodeManifest> NodeRegistry::find_shared(std::string_view id) const {
  auto it = entries_.find(id);
  return it == entries_.end() ? nullptr : it->second.manifest;
}

std::vector<const NodeManifest*> NodeRegistry::manifests() const {
  std::vector<const NodeManifest*> out;
  out.reserve(entries_.size());
  for (const auto& [id, e] : entries_) out.push_back(e.manifest.get());
  return out;
}

Result<std::unique_ptr<TreeNode>> NodeRegistry::instantiate(std::string_view id, const std::string& name,
                                                            const NodeConfig& config) const {
  auto it = entries_.find(id);
  if (it == entries_.end()) return fail("unknown node ID '" + std::string(id) + "'");
  return it->second.factory(name, config);
}

std::string write_nodes_model(const NodeRegistry& registry, bool include_builtin) {
  return write_nodes_model(registry, include_builtin, {});
}

Result<std::vector<SubTreeModel>> subtree_models(const std::filesystem::path& tree_file) {
  std::map<std::string, std::set<std::string>, std::less<>> ports;  // SubTree ID -> attribute names
  std::set<std::string, std::less<>> defined;
  std::vector<std::filesystem::path> work{tree_file};
  std::set<std::filesystem::path> seen;
  while (!work.empty()) {  // files, breadth first; includes are followed once each
    const std::filesystem::path file = work.back();
    work.pop_back();
    std::error_code ec;
    const auto key = std::filesystem::weakly_canonical(file, ec);
    if (!seen.insert(ec ? file : key).second) continue;
    tinyxml2::XMLDocument doc;
    VISNAV_ASSIGN(const std::string text, read_text_file(file.string(), kMaxTreeFileBytes, "tree"));
    if (doc.Parse(text.data(), text.size()) != tinyxml2::XML_SUCCESS)
      return fail(ErrorCode::parse_error, file.string() + ": cannot read the tree (" + std::string(doc.ErrorName()) + ")");
    const tinyxml2::XMLElement* root = doc.RootElement();
    if (root == nullptr) return fail(file.string() + ": no root element");
    std::vector<const tinyxml2::XMLElement*> stack;
    for (const auto* el = root->FirstChildElement(); el != nullptr; el = el->NextSiblingElement()) {
      const std::string_view name = el->Name();
      if (name == "include") {
        if (const char* path = el->Attribute("path")) work.push_back(file.parent_path() / path);
      } else if (name == "BehaviorTree") {
        if (const char* id = el->Attribute("ID")) defined.insert(id);
        stack.push_back(el);
      }
    }
    while (!stack.empty()) {
      const tinyxml2::XMLElement* el = stack.back();
      stack.pop_back();
      if (std::string_view(el->Name()) == "SubTree") {
        if (const char* id = el->Attribute("ID")) {
          auto& set = ports[id];
          for (const auto* a = el->FirstAttribute(); a != nullptr; a = a->Next()) {
            const std::string_view n = a->Name();
            if (n != "ID" && n != "name" && !n.empty() && n.front() != '_') set.emplace(n);
          }
        }
      }
      for (const auto* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement()) stack.push_back(c);
    }
  }
  std::vector<SubTreeModel> out;
  for (const std::string& id : defined) {
    SubTreeModel m{id, {}};
    if (auto it = ports.find(id); it != ports.end()) m.ports.assign(it->second.begin(), it->second.end());
    out.push_back(std::move(m));
  }
  return out;
}

std::string write_nodes_model(const NodeRegistry& registry, bool include_builtin,
                              const std::vector<SubTreeModel>& subtrees) {
  tinyxml2::XMLDocument doc;
  doc.InsertEndChild(doc.NewDeclaration());
  tinyxml2::XMLElement* root = doc.NewElement("root");
  root->SetAttribute("BTCPP_format", "4");
  doc.InsertEndChild(root);
  tinyxml2::XMLElement* model = doc.NewElement("TreeNodesModel");
  root->InsertEndChild(model);
  const EnumTables* enums = registry.enums().get();
  for (const NodeManifest* m : registry.manifests()) {
    if (m->builtin && !include_builtin) continue;
    tinyxml2::XMLElement* el = doc.NewElement(to_string(m->kind));
    el->SetAttribute("ID", m->id.c_str());
    for (const PortInfo& p : m->ports) {
      tinyxml2::XMLElement* pe = doc.NewElement(to_string(p.direction));
      pe->SetAttribute("name", p.name.c_str());
      std::string type = p.type_name;
      if (type == "enum" && enums != nullptr) {
        if (const EnumTables::Table* t = enums->find(p.type)) type = t->type_name;
      }
      pe->SetAttribute("type", type.c_str());
      if (p.default_value) pe->SetAttribute("default", p.default_value->c_str());
      if (!p.description.empty()) pe->SetText(p.description.c_str());
      el->InsertEndChild(pe);
    }
    if (!m->description.empty()) {
      tinyxml2::XMLElement* d = doc.NewElement("description");
      d->SetText(m->description.c_str());
      el->InsertEndChild(d);
    }
    model->InsertEndChild(el);
  }
  for (const SubTreeModel& st : subtrees) {
    tinyxml2::XMLElement* el = doc.NewElement("SubTree");
    el->SetAttribute("ID", st.id.c_str());
    for (const std::string& port : st.ports) {
      tinyxml2::XMLElement* pe = doc.NewElement("inout_port");
      pe->SetAttribute("name", port.c_str());
      el->InsertEndChild(pe);
    }
    model->InsertEndChild(el);
  }
  tinyxml2::XMLPrinter printer;
  doc.Print(&printer);
  return std::string(printer.CStr(), static_cast<std::size_t>(printer.CStrSize() > 0 ? printer.CStrSize() - 1 : 0));
}

}  // namespace visnav::bt
