// Tree loading: parse (with includes), validate everything, then instantiate.
#include <tinyxml2.h>

#include <algorithm>
#include <cstdio>
#include <map>
#include <optional>
#include <set>

#include "bounded_stack.hpp"
#include "node_scripts.hpp"
#include "subtree_node.hpp"
#include "visnav/bt/tree.hpp"
#include "visnav/file_io.hpp"

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
  int depth = 0;  // depth of the <SubTree> element in its tree (root node = 1)
};

// Size of one BehaviorTree without expanding its SubTrees.
struct TreeStats {
  std::uint64_t local_nodes = 0;  // elements (a <SubTree> element counts as its SubTree node)
  int local_depth = 0;            // deepest element (root node = 1)
};

// The same for the tree with every SubTree expanded (computed bottom-up over the SubTree DAG).
struct ExpandedStats {
  std::uint64_t nodes = 0;
  int subtree_depth = 0;
  int depth = 0;
  const SubTreeRef* deepest_subtree = nullptr;  // ref on the longest SubTree chain
  const SubTreeRef* deepest_node = nullptr;     // ref on the path to the deepest node
};

// RFC 3629: no overlongs, no surrogates, nothing above U+10FFFF.
bool valid_utf8(std::string_view text) { return first_invalid_utf8(text) == std::string_view::npos; }

// Editor metadata written by Groot2 and BehaviorTree.CPP: accepted and ignored.
bool is_metadata_attribute(std::string_view name) {
  return name == "_description" || name == "_uid" || name == "_fullpath";
}

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
    include_root_ = options_.include_root.empty() ? pf->dir : options_.include_root;
    include_root_ = normalized(std::filesystem::absolute(include_root_.empty() ? std::filesystem::path(".") : include_root_));
    const std::string path_text = file.string();
    if (!read_tree_file(*pf, path_text, nullptr, 0)) return;
    include_stack_.push_back(pf->key);
    process_root(std::move(pf), true);
    include_stack_.pop_back();
  }

  void load_string(std::string_view xml) {
    auto pf = std::make_unique<ParsedFile>();
    pf->display = options_.source_name;
    pf->dir = options_.base_dir;
    pf->key = pf->display;
    include_root_ = options_.include_root.empty() ? options_.base_dir : options_.include_root;
    include_root_ = normalized(std::filesystem::absolute(include_root_.empty() ? std::filesystem::path(".") : include_root_));
    if (pf->doc.Parse(xml.data(), xml.size()) != tinyxml2::XML_SUCCESS) {
      report_xml_error(*pf);
      return;
    }
    process_root(std::move(pf), true);
  }

  void validate() {
    if (!root_ok_) return;  // nothing to validate without a parsed main file
    for (std::size_t i = 0; i < options_.port_overrides.size(); ++i) {
      if (override_hits_.size() > i && override_hits_[i] > 0) continue;
      const PortOverride& o = options_.port_overrides[i];
      add(ErrorCode::not_found, files_.empty() ? nullptr : files_.front().get(), 0, o.node + "." + o.port,
          "port override '" + o.node + "." + o.port + "=" + o.value + "': no node '" + o.node + "' in the tree");
    }
    for (const auto& [id, def] : trees_) validate_tree(def);
    const bool acyclic = check_cycles();
    resolve_main_tree();
    if (acyclic && trees_.find(main_tree_) != trees_.end()) check_limits();
    if (diags_.empty()) check_types();
  }

  std::vector<Diagnostic>& diagnostics() { return diags_; }

  Result<Tree> build(std::unique_ptr<TreeContext> context, Blackboard::Ptr blackboard);

 private:
  static std::filesystem::path normalized(const std::filesystem::path& p) {
    std::error_code ec;
    auto abs = std::filesystem::weakly_canonical(p, ec);
    return ec ? p.lexically_normal() : abs;
  }

  // Sets each override's attribute on every element of its node type (iteratively: the loader
  // never recurses over the document, whatever its depth).
  void apply_port_overrides(tinyxml2::XMLDocument& doc) {
    if (options_.port_overrides.empty()) return;
    override_hits_.resize(options_.port_overrides.size(), 0);
    std::vector<XMLElement*> stack;
    if (XMLElement* root = doc.RootElement()) stack.push_back(root);
    while (!stack.empty()) {
      XMLElement* el = stack.back();
      stack.pop_back();
      if (std::string_view(el->Name()) == "TreeNodesModel") continue;  // editor metadata, not nodes
      const char* generic_id = is_generic_element(el->Name()) ? el->Attribute("ID") : nullptr;
      const std::string_view type = generic_id != nullptr ? std::string_view(generic_id) : std::string_view(el->Name());
      for (std::size_t i = 0; i < options_.port_overrides.size(); ++i) {
        const PortOverride& o = options_.port_overrides[i];
        if (type != o.node) continue;
        el->SetAttribute(o.port.c_str(), o.value.c_str());
        ++override_hits_[i];
      }
      for (XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement()) stack.push_back(c);
    }
  }

  // Records a diagnostic; `code` says what kind of problem it is (every call site names one).
  void add(ErrorCode code, const ParsedFile* file, int line, std::string path, std::string message) {
    diags_.push_back(
        Diagnostic{file != nullptr ? file->display : std::string(), line, std::move(path), std::move(message), code});
  }

  /// Reads and parses one tree file into `pf`: the size and file-type checks come before any
  /// byte is read (a device or a 200 MB file costs nothing), and a tree that is not UTF-8 is
  /// refused with the line of the first bad byte (tinyxml2 would take any bytes). On failure
  /// the problem is reported against `pf` (or, for an unreadable include, against the including
  /// element) and false is returned.
  bool read_tree_file(ParsedFile& pf, const std::string& path, const ParsedFile* includer, int include_line) {
    auto text = read_text_file(path, kMaxTreeFileBytes, "tree");
    if (!text) {
      std::string msg = text.error().message;
      if (msg.starts_with(path + ": ")) msg.erase(0, path.size() + 2);
      if (includer != nullptr)
        add(text.error().code, includer, include_line, {}, "cannot read included file '" + pf.display + "': " + msg);
      else
        add(text.error().code, &pf, 0, {}, msg);
      return false;
    }
    if (const std::size_t bad = first_invalid_utf8(*text); bad != std::string_view::npos) {
      const int line = 1 + static_cast<int>(std::count(text->begin(), text->begin() + static_cast<std::ptrdiff_t>(bad), '\n'));
      char byte[8];
      std::snprintf(byte, sizeof byte, "0x%02X", static_cast<unsigned>(static_cast<unsigned char>((*text)[bad])));
      add(ErrorCode::parse_error, &pf, line, {},
          std::string("not UTF-8: byte ") + byte + " at offset " + std::to_string(bad) +
              " does not start a valid UTF-8 sequence (trees are UTF-8 XML)");
      return false;
    }
    if (pf.doc.Parse(text->data(), text->size()) != tinyxml2::XML_SUCCESS) {
      report_xml_error(pf);
      return false;
    }
    return true;
  }

  void report_xml_error(const ParsedFile& pf) {
    const tinyxml2::XMLError err = pf.doc.ErrorID();
    if (err == tinyxml2::XML_ERROR_FILE_NOT_FOUND || err == tinyxml2::XML_ERROR_FILE_COULD_NOT_BE_OPENED ||
        err == tinyxml2::XML_ERROR_FILE_READ_ERROR) {
      add(ErrorCode::io, &pf, 0, {}, "cannot read file");
      return;
    }
    std::string msg = "malformed XML: ";
    msg += pf.doc.ErrorName();
    if (const char* s = pf.doc.ErrorStr()) {
      msg += " (";
      msg += s;
      msg += ")";
    }
    add(ErrorCode::parse_error, &pf, pf.doc.ErrorLineNum(), {}, msg);
  }

  // Checks <root>, registers its BehaviorTrees and follows includes.
  void process_root(std::unique_ptr<ParsedFile> owned, bool is_main) {
    apply_port_overrides(owned->doc);
    const ParsedFile* pf = owned.get();
    files_.push_back(std::move(owned));
    const XMLElement* root = pf->doc.RootElement();
    if (root == nullptr) {
      add(ErrorCode::parse_error, pf, 1, {}, "no root element");
      return;
    }
    if (std::string_view(root->Name()) != "root") {
      add(ErrorCode::parse_error, pf, root->GetLineNum(), {}, "root element must be <root BTCPP_format=\"4\">, found <" + std::string(root->Name()) + ">");
      return;
    }
    if (is_main) root_ok_ = true;
    const char* format = root->Attribute("BTCPP_format");
    // A missing BTCPP_format is accepted (BehaviorTree.CPP only warns); a wrong one is an error.
    if (format != nullptr && std::string_view(format) != "4") {
      add(ErrorCode::parse_error, pf, root->GetLineNum(), {}, "unsupported BTCPP_format \"" + std::string(format) + "\" (expected \"4\")");
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
      add(ErrorCode::unknown_key, pf, root->GetLineNum(), {}, "unknown attribute '" + std::string(name) + "' on <root>");
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
        add(ErrorCode::parse_error, pf, el->GetLineNum(), {}, "unexpected element <" + std::string(name) + "> in <root> (expected <BehaviorTree>, <include> or <TreeNodesModel>)");
      }
    }
  }

  void register_tree(const ParsedFile* pf, const XMLElement* el, bool is_main) {
    const char* id = el->Attribute("ID");
    if (id == nullptr || *id == '\0') {
      add(ErrorCode::missing, pf, el->GetLineNum(), {}, "<BehaviorTree> is missing the attribute ID");
      return;
    }
    for (const tinyxml2::XMLAttribute* a = el->FirstAttribute(); a != nullptr; a = a->Next()) {
      const std::string_view name = a->Name();
      if (name != "ID" && name.front() != '_')
        add(ErrorCode::unknown_key, pf, el->GetLineNum(), id, "unknown attribute '" + std::string(name) + "' on <BehaviorTree>");
    }
    if (auto it = trees_.find(id); it != trees_.end()) {
      add(ErrorCode::inconsistent, pf, el->GetLineNum(), id,
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
        add(ErrorCode::unknown_key, pf, el->GetLineNum(), {}, "unsupported attribute '" + std::string(a->Name()) + "' on <include>");
    }
    if (path == nullptr || *path == '\0') {
      add(ErrorCode::missing, pf, el->GetLineNum(), {}, "<include> is missing the attribute path");
      return;
    }
    if (!valid_utf8(path)) {
      add(ErrorCode::invalid_value, pf, el->GetLineNum(), {}, "<include> path is not valid UTF-8");
      return;
    }
    std::filesystem::path target(path);
    if (!target.is_relative() || target.has_root_name()) {
      add(ErrorCode::invalid_value, pf, el->GetLineNum(), {}, "<include path=\"" + std::string(path) + "\">: absolute paths are not allowed (give a path relative to the including file)");
      return;
    }
    target = pf->dir / target;
    const std::filesystem::path key = normalized(target);
    const std::filesystem::path rel = normalized(std::filesystem::absolute(target)).lexically_relative(include_root_);
    if (rel.empty() || *rel.begin() == "..") {
      add(ErrorCode::invalid_value, pf, el->GetLineNum(), {}, "<include path=\"" + std::string(path) + "\"> resolves outside the tree folder '" + include_root_.string() + "'");
      return;
    }
    if (std::find(include_stack_.begin(), include_stack_.end(), key) != include_stack_.end()) {
      add(ErrorCode::invalid_value, pf, el->GetLineNum(), {}, "cyclic <include> of '" + std::string(path) + "'");
      return;
    }
    for (const auto& f : files_)
      if (f->key == key) return;  // already included (diamond): its trees are registered
    auto inc = std::make_unique<ParsedFile>();
    inc->display = target.lexically_normal().string();
    inc->dir = target.parent_path();
    inc->key = key;
    const std::string target_text = target.string();
    if (!read_tree_file(*inc, target_text, pf, el->GetLineNum())) {
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
      add(ErrorCode::invalid_value, def.file, def.element->GetLineNum(), def.id,
          "BehaviorTree '" + def.id + "' must have exactly one root node, has " + std::to_string(n));
      if (n == 0) return;
    }
    // Explicit stack (no recursion): frames are pushed in reverse so elements are visited in
    // document order, parents first.
    TreeStats& stats = stats_[def.id];
    struct Frame {
      const XMLElement* el;
      std::shared_ptr<const NodePath> parent;
      std::size_t index;
      int depth;
    };
    std::vector<Frame> stack;
    const auto top = NodePath::make(nullptr, def.id);
    push_children(stack, def.element, top, 1);
    while (!stack.empty()) {
      const Frame f = std::move(stack.back());
      stack.pop_back();
      ++stats.local_nodes;
      stats.local_depth = std::max(stats.local_depth, f.depth);
      auto path = validate_node(def, f.el, f.parent, f.index, f.depth);
      if (path) push_children(stack, f.el, path, f.depth + 1);
    }
  }

  template <typename Stack>
  static void push_children(Stack& stack, const XMLElement* el, const std::shared_ptr<const NodePath>& path, int depth) {
    const std::size_t first = stack.size();
    std::size_t i = 0;
    for (const XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement())
      stack.push_back({c, path, i++, depth});
    std::reverse(stack.begin() + static_cast<std::ptrdiff_t>(first), stack.end());
  }

  // Attribute names and values must be UTF-8 (tinyxml2 passes bytes through unchecked).
  bool check_utf8(const TreeDef& def, const XMLElement* el, const std::string& path) {
    bool ok = true;
    for (const tinyxml2::XMLAttribute* a = el->FirstAttribute(); a != nullptr; a = a->Next()) {
      if (!valid_utf8(a->Name()) || !valid_utf8(a->Value())) {
        add(ErrorCode::invalid_value, def.file, el->GetLineNum(), path,
            "attribute '" + std::string(valid_utf8(a->Name()) ? a->Name() : "?") + "' is not valid UTF-8");
        ok = false;
      }
    }
    return ok;
  }

  // A '_'-attribute on a node element: metadata (ignored), a pre/post-condition script, or an error.
  void validate_underscore_attribute(const TreeDef& def, const XMLElement* el, int line, const std::string& path,
                                     std::string_view name, std::string_view value) {
    if (is_metadata_attribute(name)) return;
    if (auto slot = script_slot(name)) {
      check_script(def, line, path, *slot, el, value);
      return;
    }
    add(ErrorCode::unknown_key, def.file, line, path,
        "unknown attribute '" + std::string(name) +
            "' (pre/post conditions: _skipIf _successIf _failureIf _while _onSuccess _onFailure _onHalted _post; "
            "metadata: _description _uid _fullpath)");
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
      if (!blackboard_key(t)) add(ErrorCode::invalid_value, def.file, line, path, what + ": empty blackboard reference '" + std::string(value) + "'");
      return;
    }
    if (port.direction == PortDirection::output) {
      add(ErrorCode::invalid_value, def.file, line, path, what + " is an output port; its value must be a blackboard reference like {key}, not '" + std::string(value) + "'");
      return;
    }
    if (port.parse == nullptr) return;
    auto parsed = port.parse(value, registry_.enums().get());
    if (!parsed) {
      add(ErrorCode::invalid_value, def.file, line, path, what + ": bad value for type " + port.type_name + ": " + parsed.error().message);
    } else if (port.check) {
      if (auto st = port.check(value); !st)
        add(st.error().with_default_code(ErrorCode::out_of_range).code, def.file, line, path,
            what + ": " + st.error().message);
    }
  }

  // Validates one element (not its children). Returns its path, or nullptr when its children
  // must not be visited (SubTree, generic element without ID).
  std::shared_ptr<const NodePath> validate_node(const TreeDef& def, const XMLElement* el,
                                                const std::shared_ptr<const NodePath>& parent, std::size_t index,
                                                int depth) {
    const int line = el->GetLineNum();
    std::string id = el->Name();
    if (is_generic_element(id)) {
      const char* attr = el->Attribute("ID");
      if (attr == nullptr) {
        add(ErrorCode::missing, def.file, line, NodePath::make(parent, component(el, id, index))->str(), "<" + id + "> is missing the attribute ID");
        return nullptr;
      }
      id = attr;
    }
    if (id == "SubTree") {
      validate_subtree(def, el, parent, index, depth);
      return nullptr;
    }
    auto node_path = NodePath::make(parent, component(el, id, index));
    const std::string path = node_path->str();
    if (!check_utf8(def, el, path)) return node_path;
    const NodeManifest* m = registry_.find(id);
    const std::size_t n_children = element_children_count(el);
    if (m == nullptr) {
      add(ErrorCode::not_found, def.file, line, path, "unknown node ID '" + id + "'");
    } else {
      const std::size_t diags_before = diags_.size();
      for (const tinyxml2::XMLAttribute* a = el->FirstAttribute(); a != nullptr; a = a->Next()) {
        const std::string_view name = a->Name();
        if (name == "name") continue;
        if (name == "ID" && is_generic_element(el->Name())) continue;
        if (!name.empty() && name.front() == '_') {
          validate_underscore_attribute(def, el, line, path, name, a->Value());
          continue;
        }
        const PortInfo* p = m->find_port(name);
        if (p == nullptr) {
          std::string known;
          for (const PortInfo& q : m->ports) known += (known.empty() ? "" : ", ") + q.name;
          add(ErrorCode::unknown_key, def.file, line, path, "unknown port '" + std::string(name) + "' for " + id +
                                        (known.empty() ? " (it has no ports)" : " (ports: " + known + ")"));
          continue;
        }
        validate_port_value(def, line, path, *p, a->Value(), false);
      }
      for (const PortInfo& p : m->ports) {
        if (el->Attribute(p.name.c_str()) != nullptr) continue;
        if (p.required()) {
          add(ErrorCode::missing, def.file, line, path, "missing required port '" + p.name + "' (" + p.type_name + ")");
        } else if (p.default_value) {
          validate_port_value(def, line, path, p, *p.default_value, true);
        }
      }
      // The cross-port rules assume every port parsed: after a port's own problem, not again.
      if (m->check_literals && diags_.size() == diags_before) {
        LiteralPorts literal;
        for (const PortInfo& p : m->ports) {
          if (p.direction == PortDirection::output) continue;
          const char* given = el->Attribute(p.name.c_str());
          if (given == nullptr && !p.default_value) continue;
          const std::string text = given != nullptr ? std::string(given) : *p.default_value;
          const std::string_view t = detail::trim(text);
          if (!t.empty() && t.front() == '{' && t.back() == '}') literal.bound.push_back(p.name);
          else literal.values.emplace(p.name, text);
        }
        if (auto st = m->check_literals(literal); !st)
          add(st.error().with_default_code(ErrorCode::inconsistent).code, def.file, line, path, st.error().message);
      }
      const int n = static_cast<int>(n_children);
      if (n < m->min_children || (m->max_children >= 0 && n > m->max_children)) {
        add(ErrorCode::invalid_value, def.file, line, path,
            std::string(kind_word(m->kind)) + " " + id + " " + children_rule(*m) + ", has " + std::to_string(n));
      }
    }
    return node_path;
  }

  void validate_subtree(const TreeDef& def, const XMLElement* el, const std::shared_ptr<const NodePath>& parent,
                        std::size_t index, int depth) {
    const int line = el->GetLineNum();
    const char* target = el->Attribute("ID");
    const std::string path = NodePath::make(parent, component(el, target != nullptr ? target : "SubTree", index))->str();
    if (!check_utf8(def, el, path)) return;
    if (target == nullptr || *target == '\0') {
      add(ErrorCode::missing, def.file, line, path, "<SubTree> is missing the attribute ID");
    } else if (trees_.find(target) == trees_.end()) {
      add(ErrorCode::not_found, def.file, line, path, "undefined SubTree '" + std::string(target) + "'");
    } else {
      refs_.push_back(SubTreeRef{def.id, target, def.file, line, path, depth});
    }
    for (const tinyxml2::XMLAttribute* a = el->FirstAttribute(); a != nullptr; a = a->Next()) {
      const std::string_view name = a->Name();
      if (name == "ID" || name == "name") continue;
      if (name == "_autoremap") {
        if (!detail::parse_bool(a->Value()))
          add(ErrorCode::invalid_value, def.file, line, path, "_autoremap: '" + std::string(a->Value()) + "' is not a boolean (true/false)");
        continue;
      }
      if (!name.empty() && name.front() == '_') {
        validate_underscore_attribute(def, el, line, path, name, a->Value());
        continue;
      }
      const std::string_view v = detail::trim(a->Value());
      if (!v.empty() && v.front() == '{' && v.back() == '}' && !blackboard_key(v))
        add(ErrorCode::invalid_value, def.file, line, path, "port '" + std::string(name) + "': empty blackboard reference '" + std::string(a->Value()) + "'");
    }
    if (element_children_count(el) != 0) add(ErrorCode::invalid_value, def.file, line, path, "<SubTree> cannot have children");
  }

  // Iterative DFS over the SubTree graph (a chain of 50,000 SubTrees must not exhaust the C++
  // stack). Reports every cycle edge once; on success fills postorder_ (callees first).
  bool check_cycles() {
    std::map<std::string, std::vector<const SubTreeRef*>, std::less<>> edges;
    for (const SubTreeRef& r : refs_) edges[r.from_tree].push_back(&r);
    std::map<std::string, int, std::less<>> state;  // 0 unvisited, 1 on stack, 2 done
    std::set<const SubTreeRef*> reported;
    struct Frame {
      const std::string* tree;
      const std::vector<const SubTreeRef*>* out;
      std::size_t next;
    };
    static const std::vector<const SubTreeRef*> none;
    std::vector<Frame> stack;
    auto push = [&](const std::string& tree) {
      state[tree] = 1;
      auto it = edges.find(tree);
      stack.push_back(Frame{&tree, it != edges.end() ? &it->second : &none, 0});
    };
    bool acyclic = true;
    for (const auto& [id, def] : trees_) {
      if (state[id] != 0) continue;
      push(id);
      while (!stack.empty()) {
        Frame& f = stack.back();
        if (f.next == f.out->size()) {
          state[*f.tree] = 2;
          postorder_.push_back(f.tree);
          stack.pop_back();
          continue;
        }
        const SubTreeRef* r = (*f.out)[f.next++];
        const int st = state[r->to_tree];
        if (st == 1) {
          acyclic = false;
          if (reported.insert(r).second) {
            std::string cycle;
            auto it = std::find_if(stack.begin(), stack.end(), [&](const Frame& x) { return *x.tree == r->to_tree; });
            std::size_t shown = 0;
            for (; it != stack.end(); ++it, ++shown) {
              if (shown == 8 && stack.end() - it > 4) {  // keep the message short for long cycles
                cycle += "... -> ";
                it = stack.end() - 4;
              }
              cycle += *it->tree + " -> ";
            }
            cycle += r->to_tree;
            add(ErrorCode::invalid_value, r->file, r->line, r->path, "cyclic SubTree: " + cycle);
          }
        } else if (st == 0) {
          push(trees_.find(r->to_tree)->first);
        }
      }
    }
    return acyclic;
  }

  // Expanded size of the main tree, bottom-up over the (acyclic) SubTree graph.
  void check_limits() {
    std::map<std::string, std::vector<const SubTreeRef*>, std::less<>> edges;
    for (const SubTreeRef& r : refs_) edges[r.from_tree].push_back(&r);
    constexpr std::uint64_t cap = std::uint64_t{1} << 62;  // saturate: 2 SubTrees per level overflow fast
    std::map<std::string, ExpandedStats, std::less<>> expanded;
    for (const std::string* tree : postorder_) {
      const TreeStats& local = stats_[*tree];
      ExpandedStats e;
      e.nodes = local.local_nodes;
      e.depth = local.local_depth;
      for (const SubTreeRef* r : edges[*tree]) {
        const ExpandedStats& sub = expanded[r->to_tree];
        e.nodes = std::min(cap, e.nodes + sub.nodes);
        if (sub.subtree_depth + 1 > e.subtree_depth) {
          e.subtree_depth = sub.subtree_depth + 1;
          e.deepest_subtree = r;
        }
        if (r->depth + sub.depth > e.depth) {
          e.depth = r->depth + sub.depth;
          e.deepest_node = r;
        }
      }
      expanded[*tree] = e;
    }
    const ExpandedStats& m = expanded[main_tree_];
    const TreeDef& def = trees_.at(main_tree_);
    auto chain = [&](const SubTreeRef* ExpandedStats::*next) {
      std::string out = main_tree_;
      std::size_t n = 0;
      for (const SubTreeRef* r = m.*next; r != nullptr; r = expanded[r->to_tree].*next, ++n) {
        if (n == 6) {
          out += " -> ...";
          break;
        }
        out += " -> " + r->to_tree;
      }
      return out;
    };
    if (m.subtree_depth > options_.max_subtree_depth) {
      const SubTreeRef* r = m.deepest_subtree;
      add(ErrorCode::limit, r->file, r->line, r->path,
          "SubTrees nest " + std::to_string(m.subtree_depth) + " deep, more than the limit " +
              std::to_string(options_.max_subtree_depth) + " (run.bt_max_subtree_depth): " + chain(&ExpandedStats::deepest_subtree));
    }
    if (m.nodes > options_.max_nodes) {
      add(ErrorCode::limit, def.file, def.element->GetLineNum(), main_tree_,
          "the expanded tree would have " + (m.nodes >= cap ? std::string("more than 4e18") : std::to_string(m.nodes)) +
              " nodes, more than the limit " + std::to_string(options_.max_nodes) + " (run.bt_max_nodes)");
    }
    if (m.depth > options_.max_tree_depth) {
      const SubTreeRef* r = m.deepest_node;
      add(ErrorCode::limit, r != nullptr ? r->file : def.file, r != nullptr ? r->line : def.element->GetLineNum(), r != nullptr ? r->path : main_tree_,
          "the expanded tree is " + std::to_string(m.depth) + " nodes deep, more than the limit " +
              std::to_string(options_.max_tree_depth) + " (run.bt_max_tree_depth): " + chain(&ExpandedStats::deepest_node));
    }
  }

  void resolve_main_tree() {
    const ParsedFile* main_file = files_.empty() ? nullptr : files_.front().get();
    if (!options_.main_tree.empty()) {
      main_tree_ = options_.main_tree;
      if (trees_.find(main_tree_) == trees_.end())
        add(ErrorCode::not_found, main_file, root_line_, {}, "main tree '" + main_tree_ + "' (from the load options) is not defined");
      return;
    }
    if (!main_tree_attr_.empty()) {
      main_tree_ = main_tree_attr_;
      if (trees_.find(main_tree_) == trees_.end())
        add(ErrorCode::not_found, main_file, main_tree_line_, {}, "main_tree_to_execute '" + main_tree_ + "' is not defined");
      return;
    }
    if (main_file_trees_.size() == 1) {
      main_tree_ = main_file_trees_.front();
      return;
    }
    if (main_file_trees_.empty()) {
      add(ErrorCode::not_found, main_file, root_line_, {}, "no <BehaviorTree> in the file");
    } else {
      add(ErrorCode::missing, main_file, root_line_, {}, "several <BehaviorTree> and no main_tree_to_execute attribute on <root>");
    }
  }

  // ---- typed blackboard ------------------------------------------------------------------

  // The child blackboard of a <SubTree> element: remapped ports, literals, _autoremap.
  static Blackboard::Ptr subtree_blackboard(const XMLElement* el, const Blackboard::Ptr& parent) {
    Blackboard::Ptr child_bb = Blackboard::create(parent);
    for (const tinyxml2::XMLAttribute* a = el->FirstAttribute(); a != nullptr; a = a->Next()) {
      const std::string_view name = a->Name();
      if (name == "ID" || name == "name") continue;
      if (name == "_autoremap") {
        child_bb->enable_auto_remapping(*detail::parse_bool(a->Value()));
        continue;
      }
      if (!name.empty() && name.front() == '_') continue;  // conditions and metadata
      if (auto key = blackboard_key(a->Value())) {
        child_bb->add_subtree_remapping(std::string(name), *key == "=" ? std::string(name) : std::string(*key));
      } else {
        child_bb->set(name, std::string(a->Value()));
      }
    }
    return child_bb;
  }

  // The blackboard key a port of element `el` references, or nullopt (literal / not given).
  static std::optional<std::string> port_key(const XMLElement* el, const PortInfo& p) {
    const char* attr = el->Attribute(p.name.c_str());
    const std::string_view text = attr != nullptr ? std::string_view(attr) : p.default_value ? std::string_view(*p.default_value) : std::string_view();
    auto key = blackboard_key(text);
    if (!key) return std::nullopt;
    return *key == "=" ? p.name : std::string(*key);
  }

  // Declares the type of the entry `key` by port `p` (first declaration wins). Returns the
  // entry when it was already declared with another type.
  static Blackboard::Entry* declare(Blackboard& bb, const std::string& key, const PortInfo& p) {
    if (!p.strongly_typed) return nullptr;
    Blackboard::Entry& e = bb.get_or_create_entry(key);
    if (e.type == std::type_index(typeid(void))) {
      e.type = p.type;
      e.type_name = p.type_name;
      e.parse = p.parse;
      return nullptr;
    }
    return e.type == p.type ? nullptr : &e;
  }

  // A port that reads `{key}` where the host set `key` to a text before loading: that text must
  // parse as the port's type and pass its check, as a literal would. Returns true when it
  // reported a problem.
  bool check_host_value(const TreeDef& def, const XMLElement* el, const std::string& path, const PortInfo& p,
                        const std::string& key, const Blackboard& bb) {
    if (p.direction == PortDirection::output || p.parse == nullptr) return false;
    const Blackboard::Entry* e = bb.find_entry(key);
    const auto* text = e != nullptr ? std::any_cast<std::string>(&e->value) : nullptr;
    if (text == nullptr) return false;
    const std::string what = "port '" + p.name + "' reads {" + key + "} = '" + *text + "' from the blackboard";
    auto parsed = p.parse(*text, registry_.enums().get());
    if (!parsed) {
      add(ErrorCode::invalid_value, def.file, el->GetLineNum(), path, what + ": bad value for type " + p.type_name + ": " + parsed.error().message);
      return true;
    }
    if (!p.check) return false;
    auto st = p.check(*text);
    if (st) return false;
    add(st.error().with_default_code(ErrorCode::out_of_range).code, def.file, el->GetLineNum(), path,
        what + ": " + st.error().message);
    return true;
  }

  // Walks the expanded main tree (bounded by check_limits) with scratch blackboards and reports
  // every blackboard key used with two different port types, as BehaviorTree.CPP does at load.
  void check_types() {
    struct Item {
      const TreeDef* def;
      const XMLElement* el;
      std::shared_ptr<const NodePath> parent;
      std::size_t index;
      Blackboard::Ptr bb;
    };
    std::map<const Blackboard::Entry*, std::string> first;  // where each entry was declared
    std::set<std::pair<const XMLElement*, std::string>> reported;
    const TreeDef& main = trees_.at(main_tree_);
    Blackboard::Ptr root = Blackboard::create();
    // Text values the host put on the root blackboard before loading (`--bb key=value`) are
    // checked like literals by every port that reads them (check_host_value).
    if (options_.blackboard)
      for (const std::string& k : options_.blackboard->keys())
        if (const auto* text = std::any_cast<std::string>(options_.blackboard->get_any(k))) root->set(k, *text);
    std::vector<Item> stack{Item{&main, main.element->FirstChildElement(), NodePath::make(nullptr, main.id), 0, root}};
    while (!stack.empty()) {
      Item it = std::move(stack.back());
      stack.pop_back();
      std::string id = it.el->Name();
      if (is_generic_element(id)) id = it.el->Attribute("ID");
      if (id == "SubTree") {
        const std::string target = it.el->Attribute("ID");
        auto path = NodePath::make(it.parent, component(it.el, target, it.index));
        const TreeDef& sub = trees_.at(target);
        stack.push_back(Item{&sub, sub.element->FirstChildElement(), std::move(path), 0, subtree_blackboard(it.el, it.bb)});
        continue;
      }
      auto path = NodePath::make(it.parent, component(it.el, id, it.index));
      if (const NodeManifest* m = registry_.find(id)) {
        for (const PortInfo& p : m->ports) {
          auto key = port_key(it.el, p);
          if (!key) continue;
          if (Blackboard::Entry* e = declare(*it.bb, *key, p)) {
            if (!reported.insert({it.el, p.name}).second) continue;
            add(ErrorCode::inconsistent, it.def->file, it.el->GetLineNum(), path->str(),
                "port '" + p.name + "' uses blackboard key '" + *key + "' as " + p.type_name + ", but it was declared " +
                    e->type_name + " by " + first[e]);
          } else if (reported.count({it.el, p.name}) == 0 && check_host_value(*it.def, it.el, path->str(), p, *key, *it.bb)) {
            reported.insert({it.el, p.name});
          } else if (p.strongly_typed) {
            Blackboard::Entry* declared = it.bb->find_entry(*key);
            if (declared != nullptr && first.find(declared) == first.end())
              first[declared] = "port '" + p.name + "' of " + path->str() + " (" + it.def->file->display + ":" +
                         std::to_string(it.el->GetLineNum()) + ")";
          }
        }
      }
      const std::size_t base = stack.size();
      std::size_t i = 0;
      for (const XMLElement* c = it.el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement())
        stack.push_back(Item{it.def, c, path, i++, it.bb});
      std::reverse(stack.begin() + static_cast<std::ptrdiff_t>(base), stack.end());
    }
  }

  // ---- instantiation ---------------------------------------------------------------------

  // One element to instantiate: its tree, its parent node (nullptr for the root) and scope.
  struct Work {
    const TreeDef* def;
    const XMLElement* el;
    TreeNode* parent;
    std::shared_ptr<const NodePath> parent_path;
    std::size_t index;
    Blackboard::Ptr blackboard;
    int depth;  // level in the expanded tree, root = 0
  };
  Result<TreeNode*> instantiate_main();
  Status instantiate_one(Work& w, std::vector<Work>& stack);
  Status attach(const Work& w, TreeNode* node);

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

  // Parses a condition script once; instances of the element share the parsed scripts.
  void check_script(const TreeDef& def, int line, const std::string& path, ScriptSlot slot, const XMLElement* el,
                    std::string_view text) {
    auto script = Script::parse(text);
    if (!script) {
      add(ErrorCode::parse_error, def.file, line, path, std::string(script_attribute(slot)) + ": script error at " + script.error().message +
                                    " in '" + std::string(text) + "'");
      return;
    }
    auto& entry = scripts_[el];
    if (!entry) entry = std::make_shared<NodeScripts>();
    entry->slots[static_cast<std::size_t>(slot)] = std::make_shared<const Script>(std::move(*script));
  }
  // The element's condition scripts; on a stack checkpoint level (bounded_stack.hpp) a copy
  // marked as checkpoint (the same element may be instantiated at other depths).
  std::shared_ptr<const NodeScripts> node_scripts(const XMLElement* el, int depth) const {
    auto it = scripts_.find(el);
    std::shared_ptr<const NodeScripts> scripts = it == scripts_.end() ? nullptr : it->second;
    if (depth % StackSegments::kCheckpointInterval != 0) return scripts;
    auto marked = scripts ? std::make_shared<NodeScripts>(*scripts) : std::make_shared<NodeScripts>();
    marked->checkpoint = true;
    return marked;
  }

  const NodeRegistry& registry_;
  const LoadOptions& options_;
  std::vector<int> override_hits_;  // per options_.port_overrides: elements it was set on
  std::vector<Diagnostic> diags_;
  std::vector<std::unique_ptr<ParsedFile>> files_;
  std::vector<std::filesystem::path> include_stack_;
  std::map<std::string, TreeDef, std::less<>> trees_;
  std::vector<std::string> main_file_trees_;
  std::vector<SubTreeRef> refs_;
  std::map<std::string, TreeStats, std::less<>> stats_;
  std::vector<const std::string*> postorder_;  // trees, SubTree callees before callers
  std::filesystem::path include_root_;
  std::map<const XMLElement*, std::shared_ptr<NodeScripts>> scripts_;
  std::string main_tree_attr_;
  int main_tree_line_ = 0;
  int root_line_ = 0;
  bool root_ok_ = false;
  std::string main_tree_;

  // build state
  TreeContext* context_ = nullptr;
  std::vector<std::unique_ptr<TreeNode>>* nodes_ = nullptr;
  Blackboard::Ptr root_blackboard_;
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

Status Loader::attach(const Work& w, TreeNode* node) {
  if (w.parent == nullptr) return ok();
  if (auto* control = dynamic_cast<ControlNode*>(w.parent)) {
    control->add_child(node);
  } else if (auto* decorator = dynamic_cast<DecoratorNode*>(w.parent)) {
    decorator->set_child(node);
  } else {
    return fail(w.parent->where().str() + ": " + w.parent->path() + ": node type " + w.parent->registration_id() +
                " is registered with children but its class cannot hold children");
  }
  return ok();
}

// Creates the node of one element, attaches it to its parent and pushes its children (or, for
// a SubTree, the root of the called tree) onto `stack`.
Status Loader::instantiate_one(Work& w, std::vector<Work>& stack) {
  if (nodes_->size() >= options_.max_nodes)  // validation bounds this; keep the guard cheap
    return fail("the tree has more than " + std::to_string(options_.max_nodes) + " nodes (run.bt_max_nodes)");
  const XMLElement* el = w.el;
  const TreeDef& def = *w.def;
  std::string id = el->Name();
  if (is_generic_element(id)) id = el->Attribute("ID");
  const bool is_subtree = id == "SubTree";
  const std::string target = is_subtree ? std::string(el->Attribute("ID")) : std::string();
  auto path = NodePath::make(w.parent_path, component(el, is_subtree ? target : id, w.index));
  NodeConfig config;
  config.id = id;
  config.path = path;
  config.where = SourceLocation{def.file->display, el->GetLineNum()};
  config.context = context_;
  config.scripts = node_scripts(el, w.depth);
  const char* name_attr = el->Attribute("name");
  if (is_subtree) {
    Blackboard::Ptr child_bb = subtree_blackboard(el, w.blackboard);
    // The SubTree node belongs to the calling tree: its own conditions (_skipIf, ...) see the
    // caller's blackboard; the called tree's nodes get child_bb.
    config.blackboard = w.blackboard;
    const std::string name = name_attr != nullptr && *name_attr != '\0' ? std::string(name_attr) : target;
    auto node = std::make_unique<SubTreeNode>(name, config, target);
    TreeNode* raw = node.get();
    nodes_->push_back(std::move(node));
    VISNAV_TRY(attach(w, raw));
    const TreeDef& sub = trees_.at(target);
    stack.push_back(Work{&sub, sub.element->FirstChildElement(), raw, std::move(path), 0, std::move(child_bb), w.depth + 1});
    return ok();
  }
  std::shared_ptr<const NodeManifest> m = registry_.find_shared(id);
  config.blackboard = w.blackboard;
  config.ports = bindings(*m, el);
  for (const PortInfo& p : m->ports)  // typed blackboard (conflicts were validation errors)
    if (auto key = port_key(el, p)) (void)declare(*w.blackboard, *key, p);
  config.manifest = m;
  const std::string name = name_attr != nullptr && *name_attr != '\0' ? std::string(name_attr) : id;
  auto made = registry_.instantiate(id, name, config);
  if (!made) return made.error().with_context(def.file->display + ":" + std::to_string(el->GetLineNum()) + ": " + path->str());
  TreeNode* node = made->get();
  nodes_->push_back(std::move(*made));
  VISNAV_TRY(attach(w, node));
  if (el->FirstChildElement() != nullptr && dynamic_cast<ControlNode*>(node) == nullptr &&
      dynamic_cast<DecoratorNode*>(node) == nullptr) {
    return fail(def.file->display + ":" + std::to_string(el->GetLineNum()) + ": " + path->str() + ": node type " + id +
                " is registered as a " + kind_word(m->kind) + " but its class cannot hold children");
  }
  const std::size_t first = stack.size();
  std::size_t i = 0;
  for (const XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement())
    stack.push_back(Work{w.def, c, node, path, i++, w.blackboard, w.depth + 1});
  std::reverse(stack.begin() + static_cast<std::ptrdiff_t>(first), stack.end());  // document order
  return ok();
}

Result<TreeNode*> Loader::instantiate_main() {
  const TreeDef& def = trees_.at(main_tree_);
  std::vector<Work> stack;
  stack.push_back(Work{&def, def.element->FirstChildElement(), nullptr, NodePath::make(nullptr, def.id), 0, root_blackboard_, 0});
  while (!stack.empty()) {
    Work w = std::move(stack.back());
    stack.pop_back();
    VISNAV_TRY(instantiate_one(w, stack));
  }
  return nodes_->empty() ? nullptr : nodes_->front().get();
}

Result<Tree> Loader::build(std::unique_ptr<TreeContext> context, Blackboard::Ptr blackboard) {
  std::vector<std::unique_ptr<TreeNode>> nodes;
  struct ReverseDestroy {  // on failure too: children before parents (see Tree::~Tree)
    std::vector<std::unique_ptr<TreeNode>>& n;
    ~ReverseDestroy() {
      while (!n.empty()) n.pop_back();
    }
  } guard{nodes};
  context_ = context.get();
  nodes_ = &nodes;
  root_blackboard_ = blackboard;
  VISNAV_ASSIGN(TreeNode * root, instantiate_main());
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
  if (!loader.diagnostics().empty()) {
    // Every diagnostic is in the message; the first one gives the code and location.
    const Diagnostic& first = loader.diagnostics().front();
    return Error{to_string(loader.diagnostics()), first.code, {first.file, first.line, first.node_path}};
  }
  auto context = std::make_unique<TreeContext>();
  context->clock = options.clock;
  context->enums = registry.enums();
  context->stacks = std::make_shared<StackSegments>();
  Blackboard::Ptr bb = options.blackboard ? options.blackboard : Blackboard::create();
  bb->set_enum_tables(registry.enums());
  return loader.build(std::move(context), std::move(bb));
}

}  // namespace
}  // namespace detail

Result<PortOverride> parse_port_override(const std::string& text) {
  const auto eq = text.find('=');
  const auto dot = text.find('.');
  if (eq == std::string::npos || dot == std::string::npos || dot == 0 || dot + 1 >= eq) {
    return fail(ErrorCode::parse_error, {{}, 0, text},
                "port override '" + text + "': expected Node.port=value (e.g. ReplayFeatureEdge.gain=0.5)");
  }
  return PortOverride{text.substr(0, dot), text.substr(dot + 1, eq - dot - 1), text.substr(eq + 1)};
}

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
