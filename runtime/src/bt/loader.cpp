// Tree loading: parse (with includes), validate everything, then instantiate.
#include <tinyxml2.h>

#include <algorithm>
#include <map>
#include <set>

#include "subtree_node.hpp"
#include "visnav/bt/tree.hpp"

namespace visnav::bt {

std::string Diagnostic::str() const {
  std::string out;
  if (!file.empty()) {
    out = file;
    if (line > 0) out += ":" + std::to_string(line);
    out += ": ";
  } else if (line > 0) {
    out = "line " + std::to_string(line) + ": ";
  }
  if (!node_path.empty()) out += node_path + ": ";
  out += message;
  return out;
}

std::string to_string(const std::vector<Diagnostic>& diagnostics) {
  std::string out;
  for (const Diagnostic& d : diagnostics) {
    if (!out.empty()) out += '\n';
    out += d.str();
  }
  return out;
}

namespace detail {

namespace {

using tinyxml2::XMLElement;

struct ParsedFile {
  std::string display;           // name used in diagnostics
  std::filesystem::path dir;     // base for relative includes
  std::filesystem::path key;     // canonical-ish identity for include cycles
  tinyxml2::XMLDocument doc;
};

struct TreeDef {
  std::string id;
  const XMLElement* element = nullptr;
  const ParsedFile* file = nullptr;
};

struct SubTreeRef {
  std::string from_tree;
  std::string to_tree;
  const ParsedFile* file = nullptr;
  int line = 0;
  std::string path;
};

bool is_generic_element(std::string_view name) {
  return name == "Action" || name == "Condition" || name == "Control" || name == "Decorator";
}

std::size_t element_children_count(const XMLElement* el) {
  std::size_t n = 0;
  for (const XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement()) ++n;
  return n;
}

std::string children_rule(const NodeManifest& m) {
  if (m.max_children == 0) return "cannot have children";
  if (m.min_children == m.max_children)
    return "needs exactly " + std::to_string(m.min_children) + (m.min_children == 1 ? " child" : " children");
  if (m.max_children < 0) return "needs at least " + std::to_string(m.min_children) + (m.min_children == 1 ? " child" : " children");
  return "needs " + std::to_string(m.min_children) + " to " + std::to_string(m.max_children) + " children";
}

const char* kind_word(NodeKind k) {
  switch (k) {
    case NodeKind::action: return "action";
    case NodeKind::condition: return "condition";
    case NodeKind::control: return "control node";
    case NodeKind::decorator: return "decorator";
    case NodeKind::subtree: return "subtree";
  }
  return "node";
}

class Loader {
 public:
  Loader(const NodeRegistry& registry, const LoadOptions& options) : registry_(registry), options_(options) {}

  void load_file(const std::filesystem::path& file) {
    auto pf = std::make_unique<ParsedFile>();
    pf->display = file.string();
    pf->dir = file.parent_path();
    pf->key = normalized(file);
    const std::string path_text = file.string();
    if (pf->doc.LoadFile(path_text.c_str()) != tinyxml2::XML_SUCCESS) {
      report_xml_error(*pf);
      return;
    }
    include_stack_.push_back(pf->key);
    process_root(std::move(pf), true);
    include_stack_.pop_back();
  }

  void load_string(std::string_view xml) {
    auto pf = std::make_unique<ParsedFile>();
    pf->display = options_.source_name;
    pf->dir = options_.base_dir;
    pf->key = pf->display;
    if (pf->doc.Parse(xml.data(), xml.size()) != tinyxml2::XML_SUCCESS) {
      report_xml_error(*pf);
      return;
    }
    process_root(std::move(pf), true);
  }

  void validate() {
    if (!root_ok_) return;  // nothing to validate without a parsed main file
    for (const auto& [id, def] : trees_) validate_tree(def);
    check_cycles();
    resolve_main_tree();
  }

  std::vector<Diagnostic>& diagnostics() { return diags_; }

  Result<Tree> build(std::unique_ptr<TreeContext> context, Blackboard::Ptr blackboard);

 private:
  static std::filesystem::path normalized(const std::filesystem::path& p) {
    std::error_code ec;
    auto abs = std::filesystem::weakly_canonical(p, ec);
    return ec ? p.lexically_normal() : abs;
  }

  void add(const ParsedFile* file, int line, std::string path, std::string message) {
    diags_.push_back(Diagnostic{file != nullptr ? file->display : std::string(), line, std::move(path), std::move(message)});
  }

  void report_xml_error(const ParsedFile& pf) {
    const tinyxml2::XMLError err = pf.doc.ErrorID();
    if (err == tinyxml2::XML_ERROR_FILE_NOT_FOUND || err == tinyxml2::XML_ERROR_FILE_COULD_NOT_BE_OPENED ||
        err == tinyxml2::XML_ERROR_FILE_READ_ERROR) {
      add(&pf, 0, {}, "cannot read file");
      return;
    }
    std::string msg = "malformed XML: ";
    msg += pf.doc.ErrorName();
    if (const char* s = pf.doc.ErrorStr()) {
      msg += " (";
      msg += s;
      msg += ")";
    }
    add(&pf, pf.doc.ErrorLineNum(), {}, msg);
  }

  // Checks <root>, registers its BehaviorTrees and follows includes.
  void process_root(std::unique_ptr<ParsedFile> owned, bool is_main) {
    const ParsedFile* pf = owned.get();
    files_.push_back(std::move(owned));
    const XMLElement* root = pf->doc.RootElement();
    if (root == nullptr) {
      add(pf, 1, {}, "no root element");
      return;
    }
    if (std::string_view(root->Name()) != "root") {
      add(pf, root->GetLineNum(), {}, "root element must be <root BTCPP_format=\"4\">, found <" + std::string(root->Name()) + ">");
      return;
    }
    if (is_main) root_ok_ = true;
    const char* format = root->Attribute("BTCPP_format");
    if (format == nullptr) {
      add(pf, root->GetLineNum(), {}, "<root> is missing the attribute BTCPP_format=\"4\"");
    } else if (std::string_view(format) != "4") {
      add(pf, root->GetLineNum(), {}, "unsupported BTCPP_format \"" + std::string(format) + "\" (expected \"4\")");
    }
    for (const tinyxml2::XMLAttribute* a = root->FirstAttribute(); a != nullptr; a = a->Next()) {
      const std::string_view name = a->Name();
      if (name == "BTCPP_format") continue;
      if (name == "main_tree_to_execute") {
        if (is_main) {
          main_tree_attr_ = a->Value();
          main_tree_line_ = root->GetLineNum();
        }
        continue;
      }
      add(pf, root->GetLineNum(), {}, "unknown attribute '" + std::string(name) + "' on <root>");
    }
    if (is_main) root_line_ = root->GetLineNum();

    for (const XMLElement* el = root->FirstChildElement(); el != nullptr; el = el->NextSiblingElement()) {
      const std::string_view name = el->Name();
      if (name == "BehaviorTree") {
        register_tree(pf, el, is_main);
      } else if (name == "include") {
        process_include(pf, el);
      } else if (name == "TreeNodesModel") {
        continue;  // editor metadata
      } else {
        add(pf, el->GetLineNum(), {}, "unexpected element <" + std::string(name) + "> in <root> (expected <BehaviorTree>, <include> or <TreeNodesModel>)");
      }
    }
  }

  void register_tree(const ParsedFile* pf, const XMLElement* el, bool is_main) {
    const char* id = el->Attribute("ID");
    if (id == nullptr || *id == '\0') {
      add(pf, el->GetLineNum(), {}, "<BehaviorTree> is missing the attribute ID");
      return;
    }
    for (const tinyxml2::XMLAttribute* a = el->FirstAttribute(); a != nullptr; a = a->Next()) {
      const std::string_view name = a->Name();
      if (name != "ID" && name.front() != '_')
        add(pf, el->GetLineNum(), id, "unknown attribute '" + std::string(name) + "' on <BehaviorTree>");
    }
    if (auto it = trees_.find(id); it != trees_.end()) {
      add(pf, el->GetLineNum(), id,
          "BehaviorTree '" + std::string(id) + "' is defined twice (first at " + it->second.file->display + ":" +
              std::to_string(it->second.element->GetLineNum()) + ")");
      return;
    }
    trees_.emplace(id, TreeDef{id, el, pf});
    if (is_main) main_file_trees_.emplace_back(id);
  }

  void process_include(const ParsedFile* pf, const XMLElement* el) {
    const char* path = el->Attribute("path");
    for (const tinyxml2::XMLAttribute* a = el->FirstAttribute(); a != nullptr; a = a->Next()) {
      if (std::string_view(a->Name()) != "path")
        add(pf, el->GetLineNum(), {}, "unsupported attribute '" + std::string(a->Name()) + "' on <include>");
    }
    if (path == nullptr || *path == '\0') {
      add(pf, el->GetLineNum(), {}, "<include> is missing the attribute path");
      return;
    }
    std::filesystem::path target(path);
    if (target.is_relative()) target = pf->dir / target;
    const std::filesystem::path key = normalized(target);
    if (std::find(include_stack_.begin(), include_stack_.end(), key) != include_stack_.end()) {
      add(pf, el->GetLineNum(), {}, "cyclic <include> of '" + std::string(path) + "'");
      return;
    }
    for (const auto& f : files_)
      if (f->key == key) return;  // already included (diamond): its trees are registered
    auto inc = std::make_unique<ParsedFile>();
    inc->display = target.lexically_normal().string();
    inc->dir = target.parent_path();
    inc->key = key;
    const std::string target_text = target.string();
    if (inc->doc.LoadFile(target_text.c_str()) != tinyxml2::XML_SUCCESS) {
      const tinyxml2::XMLError err = inc->doc.ErrorID();
      if (err == tinyxml2::XML_ERROR_FILE_NOT_FOUND || err == tinyxml2::XML_ERROR_FILE_COULD_NOT_BE_OPENED ||
          err == tinyxml2::XML_ERROR_FILE_READ_ERROR) {
        add(pf, el->GetLineNum(), {}, "cannot read included file '" + inc->display + "'");
      } else {
        report_xml_error(*inc);
      }
      files_.push_back(std::move(inc));
      return;
    }
    include_stack_.push_back(key);
    process_root(std::move(inc), false);
    include_stack_.pop_back();
  }

  // ---- validation ------------------------------------------------------------------------

  void validate_tree(const TreeDef& def) {
    const std::size_t n = element_children_count(def.element);
    if (n != 1) {
      add(def.file, def.element->GetLineNum(), def.id,
          "BehaviorTree '" + def.id + "' must have exactly one root node, has " + std::to_string(n));
      if (n == 0) return;
    }
    std::size_t index = 0;
    for (const XMLElement* c = def.element->FirstChildElement(); c != nullptr; c = c->NextSiblingElement())
      validate_node(def, c, def.id, index++);
  }

  static std::string component(const XMLElement* el, std::string_view id, std::size_t index) {
    if (const char* name = el->Attribute("name"); name != nullptr && *name != '\0') return name;
    return std::string(id) + "[" + std::to_string(index) + "]";
  }

  void validate_port_value(const TreeDef& def, int line, const std::string& path, const PortInfo& port,
                           std::string_view value, bool is_default) {
    const std::string what = is_default ? "default of port '" + port.name + "'" : "port '" + port.name + "'";
    const std::string_view t = detail::trim(value);
    if (!t.empty() && t.front() == '{' && t.back() == '}') {
      if (!blackboard_key(t)) add(def.file, line, path, what + ": empty blackboard reference '" + std::string(value) + "'");
      return;
    }
    if (port.direction == PortDirection::output) {
      add(def.file, line, path, what + " is an output port; its value must be a blackboard reference like {key}, not '" + std::string(value) + "'");
      return;
    }
    if (port.parse == nullptr) return;
    auto parsed = port.parse(value, registry_.enums().get());
    if (!parsed)
      add(def.file, line, path, what + ": bad value for type " + port.type_name + ": " + parsed.error().message);
  }

  void validate_node(const TreeDef& def, const XMLElement* el, const std::string& parent_path, std::size_t index) {
    const int line = el->GetLineNum();
    std::string id = el->Name();
    if (is_generic_element(id)) {
      const char* attr = el->Attribute("ID");
      if (attr == nullptr) {
        add(def.file, line, parent_path + "/" + component(el, id, index), "<" + id + "> is missing the attribute ID");
        return;
      }
      id = attr;
    }
    if (id == "SubTree") {
      validate_subtree(def, el, parent_path, index);
      return;
    }
    const std::string path = parent_path + "/" + component(el, id, index);
    const NodeManifest* m = registry_.find(id);
    const std::size_t n_children = element_children_count(el);
    if (m == nullptr) {
      add(def.file, line, path, "unknown node ID '" + id + "'");
    } else {
      for (const tinyxml2::XMLAttribute* a = el->FirstAttribute(); a != nullptr; a = a->Next()) {
        const std::string_view name = a->Name();
        if (name == "name") continue;
        if (name == "ID" && is_generic_element(el->Name())) continue;
        const PortInfo* p = m->find_port(name);
        if (p == nullptr) {
          std::string known;
          for (const PortInfo& q : m->ports) known += (known.empty() ? "" : ", ") + q.name;
          if (!name.empty() && name.front() == '_') {
            add(def.file, line, path, "unsupported attribute '" + std::string(name) + "' (scripting pre/post conditions are not supported)");
          } else {
            add(def.file, line, path, "unknown port '" + std::string(name) + "' for " + id +
                                          (known.empty() ? " (it has no ports)" : " (ports: " + known + ")"));
          }
          continue;
        }
        validate_port_value(def, line, path, *p, a->Value(), false);
      }
      for (const PortInfo& p : m->ports) {
        if (el->Attribute(p.name.c_str()) != nullptr) continue;
        if (p.required()) {
          add(def.file, line, path, "missing required port '" + p.name + "' (" + p.type_name + ")");
        } else if (p.default_value) {
          validate_port_value(def, line, path, p, *p.default_value, true);
        }
      }
      const int n = static_cast<int>(n_children);
      if (n < m->min_children || (m->max_children >= 0 && n > m->max_children)) {
        add(def.file, line, path,
            std::string(kind_word(m->kind)) + " " + id + " " + children_rule(*m) + ", has " + std::to_string(n));
      }
    }
    std::size_t i = 0;
    for (const XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement())
      validate_node(def, c, path, i++);
  }

  void validate_subtree(const TreeDef& def, const XMLElement* el, const std::string& parent_path, std::size_t index) {
    const int line = el->GetLineNum();
    const char* target = el->Attribute("ID");
    const std::string path = parent_path + "/" + component(el, target != nullptr ? target : "SubTree", index);
    if (target == nullptr || *target == '\0') {
      add(def.file, line, path, "<SubTree> is missing the attribute ID");
    } else if (trees_.find(target) == trees_.end()) {
      add(def.file, line, path, "undefined SubTree '" + std::string(target) + "'");
    } else {
      refs_.push_back(SubTreeRef{def.id, target, def.file, line, path});
    }
    for (const tinyxml2::XMLAttribute* a = el->FirstAttribute(); a != nullptr; a = a->Next()) {
      const std::string_view name = a->Name();
      if (name == "ID" || name == "name") continue;
      if (name == "_autoremap") {
        if (!detail::parse_bool(a->Value()))
          add(def.file, line, path, "_autoremap: '" + std::string(a->Value()) + "' is not a boolean (true/false)");
        continue;
      }
      if (!name.empty() && name.front() == '_') {
        add(def.file, line, path, "unsupported attribute '" + std::string(name) + "' on <SubTree>");
        continue;
      }
      const std::string_view v = detail::trim(a->Value());
      if (!v.empty() && v.front() == '{' && v.back() == '}' && !blackboard_key(v))
        add(def.file, line, path, "port '" + std::string(name) + "': empty blackboard reference '" + std::string(a->Value()) + "'");
    }
    if (element_children_count(el) != 0) add(def.file, line, path, "<SubTree> cannot have children");
  }

  void check_cycles() {
    std::map<std::string, std::vector<const SubTreeRef*>, std::less<>> edges;
    for (const SubTreeRef& r : refs_) edges[r.from_tree].push_back(&r);
    std::map<std::string, int, std::less<>> state;  // 0 unvisited, 1 on stack, 2 done
    std::vector<std::string> stack;
    std::set<const SubTreeRef*> reported;
    std::function<void(const std::string&)> dfs = [&](const std::string& tree) {
      state[tree] = 1;
      stack.push_back(tree);
      for (const SubTreeRef* r : edges[tree]) {
        const int s = state[r->to_tree];
        if (s == 1) {
          if (reported.insert(r).second) {
            std::string cycle;
            auto it = std::find(stack.begin(), stack.end(), r->to_tree);
            for (; it != stack.end(); ++it) cycle += *it + " -> ";
            cycle += r->to_tree;
            add(r->file, r->line, r->path, "cyclic SubTree: " + cycle);
          }
        } else if (s == 0) {
          dfs(r->to_tree);
        }
      }
      stack.pop_back();
      state[tree] = 2;
    };
    for (const auto& [id, def] : trees_)
      if (state[id] == 0) dfs(id);
  }

  void resolve_main_tree() {
    const ParsedFile* main_file = files_.empty() ? nullptr : files_.front().get();
    if (!options_.main_tree.empty()) {
      main_tree_ = options_.main_tree;
      if (trees_.find(main_tree_) == trees_.end())
        add(main_file, root_line_, {}, "main tree '" + main_tree_ + "' (from the load options) is not defined");
      return;
    }
    if (!main_tree_attr_.empty()) {
      main_tree_ = main_tree_attr_;
      if (trees_.find(main_tree_) == trees_.end())
        add(main_file, main_tree_line_, {}, "main_tree_to_execute '" + main_tree_ + "' is not defined");
      return;
    }
    if (main_file_trees_.size() == 1) {
      main_tree_ = main_file_trees_.front();
      return;
    }
    if (main_file_trees_.empty()) {
      add(main_file, root_line_, {}, "no <BehaviorTree> in the file");
    } else {
      add(main_file, root_line_, {}, "several <BehaviorTree> and no main_tree_to_execute attribute on <root>");
    }
  }

  // ---- instantiation ---------------------------------------------------------------------

  Result<TreeNode*> instantiate(const TreeDef& def, const XMLElement* el, const std::string& parent_path,
                                std::size_t index, const Blackboard::Ptr& blackboard);
  Result<TreeNode*> instantiate_subtree(const TreeDef& def, const XMLElement* el, const std::string& parent_path,
                                        std::size_t index, const Blackboard::Ptr& blackboard);

  std::vector<PortBinding> bindings(const NodeManifest& m, const XMLElement* el) const {
    std::vector<PortBinding> out;
    out.reserve(m.ports.size());
    for (const PortInfo& p : m.ports) {
      PortBinding b;
      b.name = p.name;
      b.direction = p.direction;
      const char* attr = el->Attribute(p.name.c_str());
      if (attr != nullptr) {
        b.text = attr;
      } else if (p.default_value) {
        b.text = *p.default_value;
        b.from_default = true;
      } else {
        out.push_back(std::move(b));
        continue;
      }
      if (auto key = blackboard_key(b.text)) {
        b.source = PortBinding::Source::blackboard;
        b.key = *key == "=" ? p.name : std::string(*key);
      } else {
        b.source = PortBinding::Source::literal;
        if (p.parse != nullptr) {
          auto parsed = p.parse(b.text, registry_.enums().get());
          if (parsed) b.literal = std::move(*parsed);
        }
      }
      out.push_back(std::move(b));
    }
    return out;
  }

  const NodeRegistry& registry_;
  const LoadOptions& options_;
  std::vector<Diagnostic> diags_;
  std::vector<std::unique_ptr<ParsedFile>> files_;
  std::vector<std::filesystem::path> include_stack_;
  std::map<std::string, TreeDef, std::less<>> trees_;
  std::vector<std::string> main_file_trees_;
  std::vector<SubTreeRef> refs_;
  std::string main_tree_attr_;
  int main_tree_line_ = 0;
  int root_line_ = 0;
  bool root_ok_ = false;
  std::string main_tree_;

  // build state
  TreeContext* context_ = nullptr;
  std::vector<std::unique_ptr<TreeNode>>* nodes_ = nullptr;
};

}  // namespace

struct TreeBuilder {
  static Tree make() { return Tree(); }
  static void assign(Tree& tree, std::unique_ptr<TreeContext> context, std::vector<std::unique_ptr<TreeNode>> nodes,
                     TreeNode* root, Blackboard::Ptr blackboard, std::string main_id) {
    tree.context_ = std::move(context);
    tree.nodes_ = std::move(nodes);
    tree.root_ = root;
    tree.blackboard_ = std::move(blackboard);
    tree.main_tree_id_ = std::move(main_id);
  }
};

namespace {

Result<TreeNode*> Loader::instantiate(const TreeDef& def, const XMLElement* el, const std::string& parent_path,
                                      std::size_t index, const Blackboard::Ptr& blackboard) {
  std::string id = el->Name();
  if (is_generic_element(id)) id = el->Attribute("ID");
  if (id == "SubTree") return instantiate_subtree(def, el, parent_path, index, blackboard);
  std::shared_ptr<const NodeManifest> m = registry_.find_shared(id);
  const std::string path = parent_path + "/" + component(el, id, index);
  NodeConfig config;
  config.id = id;
  config.path = path;
  config.where = SourceLocation{def.file->display, el->GetLineNum()};
  config.blackboard = blackboard;
  config.ports = bindings(*m, el);
  config.manifest = m;
  config.context = context_;
  const char* name_attr = el->Attribute("name");
  const std::string name = name_attr != nullptr && *name_attr != '\0' ? std::string(name_attr) : id;
  auto made = registry_.instantiate(id, name, config);
  if (!made) return made.error().with_context(def.file->display + ":" + std::to_string(el->GetLineNum()) + ": " + path);
  TreeNode* node = made->get();
  nodes_->push_back(std::move(*made));
  std::size_t i = 0;
  for (const XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement()) {
    VISNAV_ASSIGN(TreeNode * child, instantiate(def, c, path, i++, blackboard));
    if (auto* control = dynamic_cast<ControlNode*>(node)) {
      control->add_child(child);
    } else if (auto* decorator = dynamic_cast<DecoratorNode*>(node)) {
      decorator->set_child(child);
    } else {
      return fail(def.file->display + ":" + std::to_string(el->GetLineNum()) + ": " + path + ": node type " + id +
                  " is registered as a " + kind_word(m->kind) + " but its class cannot hold children");
    }
  }
  return node;
}

Result<TreeNode*> Loader::instantiate_subtree(const TreeDef& def, const XMLElement* el, const std::string& parent_path,
                                              std::size_t index, const Blackboard::Ptr& blackboard) {
  const std::string target = el->Attribute("ID");
  const std::string path = parent_path + "/" + component(el, target, index);
  const TreeDef& sub = trees_.at(target);
  Blackboard::Ptr child_bb = Blackboard::create(blackboard);
  for (const tinyxml2::XMLAttribute* a = el->FirstAttribute(); a != nullptr; a = a->Next()) {
    const std::string_view name = a->Name();
    if (name == "ID" || name == "name") continue;
    if (name == "_autoremap") {
      child_bb->enable_auto_remapping(*detail::parse_bool(a->Value()));
      continue;
    }
    if (auto key = blackboard_key(a->Value())) {
      child_bb->add_subtree_remapping(std::string(name), *key == "=" ? std::string(name) : std::string(*key));
    } else {
      child_bb->set(name, std::string(a->Value()));
    }
  }
  NodeConfig config;
  config.id = "SubTree";
  config.path = path;
  config.where = SourceLocation{def.file->display, el->GetLineNum()};
  config.blackboard = child_bb;
  config.context = context_;
  const char* name_attr = el->Attribute("name");
  const std::string name = name_attr != nullptr && *name_attr != '\0' ? std::string(name_attr) : target;
  auto node = std::make_unique<SubTreeNode>(name, config, target);
  SubTreeNode* raw = node.get();
  nodes_->push_back(std::move(node));
  VISNAV_ASSIGN(TreeNode * child, instantiate(sub, sub.element->FirstChildElement(), path, 0, child_bb));
  raw->set_child(child);
  return static_cast<TreeNode*>(raw);
}

Result<Tree> Loader::build(std::unique_ptr<TreeContext> context, Blackboard::Ptr blackboard) {
  std::vector<std::unique_ptr<TreeNode>> nodes;
  context_ = context.get();
  nodes_ = &nodes;
  const TreeDef& def = trees_.at(main_tree_);
  VISNAV_ASSIGN(TreeNode * root, instantiate(def, def.element->FirstChildElement(), def.id, 0, blackboard));
  Tree tree = TreeBuilder::make();
  TreeBuilder::assign(tree, std::move(context), std::move(nodes), root, std::move(blackboard), main_tree_);
  return tree;
}

template <typename LoadFn>
std::vector<Diagnostic> run_validation(Loader& loader, LoadFn&& load) {
  load();
  loader.validate();
  return std::move(loader.diagnostics());
}

template <typename LoadFn>
Result<Tree> run_load(const NodeRegistry& registry, const LoadOptions& options, LoadFn&& load) {
  Loader loader(registry, options);
  load(loader);
  loader.validate();
  if (!loader.diagnostics().empty()) return fail(to_string(loader.diagnostics()));
  auto context = std::make_unique<TreeContext>();
  context->clock = options.clock;
  context->enums = registry.enums();
  Blackboard::Ptr bb = options.blackboard ? options.blackboard : Blackboard::create();
  bb->set_enum_tables(registry.enums());
  return loader.build(std::move(context), std::move(bb));
}

}  // namespace
}  // namespace detail

Result<Tree> load_tree_file(const std::filesystem::path& file, const NodeRegistry& registry, const LoadOptions& options) {
  return detail::run_load(registry, options, [&](detail::Loader& l) { l.load_file(file); });
}

Result<Tree> load_tree_string(std::string_view xml, const NodeRegistry& registry, const LoadOptions& options) {
  return detail::run_load(registry, options, [&](detail::Loader& l) { l.load_string(xml); });
}

std::vector<Diagnostic> validate_tree_file(const std::filesystem::path& file, const NodeRegistry& registry,
                                           const LoadOptions& options) {
  detail::Loader loader(registry, options);
  return detail::run_validation(loader, [&] { loader.load_file(file); });
}

std::vector<Diagnostic> validate_tree_string(std::string_view xml, const NodeRegistry& registry,
                                             const LoadOptions& options) {
  detail::Loader loader(registry, options);
  return detail::run_validation(loader, [&] { loader.load_string(xml); });
}

}  // namespace visnav::bt
