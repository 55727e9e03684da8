// visnav SDK — behaviour-tree ports generated from a params schema (visnav/params.hpp).
//
// A node whose parameters are a typed struct with a ParamSchema declares them once, in the
// schema, and gets its input ports from it; this is what the runtime's primitive adapter does
// for every navigation primitive, and hand-written nodes use the same helper:
//
//   static visnav::bt::PortsList provided_ports() {
//     visnav::bt::PortsList p = {/* the node's other ports */};
//     visnav::bt::append_param_ports(p, MyParams::schema());
//     return p;
//   }
//   visnav::bt::NodeStatus on_start() override {
//     auto params = visnav::bt::parse_param_ports(*this, MyParams::schema());  // Result<MyParams>
//     if (!params) return visnav::bt::NodeStatus::failure;  // after logging params.error().message
//     ...
//   }
//
// Ports: one input port per schema field, in declaration order, named as the key; port type from
// the field type (int, double, bool, std::string, std::vector<double>, std::vector<std::string>);
// default = the struct's default as the schema renders it; description = the field's, followed by
// its constraint text when it has one ("... [0, 180]", "... one of: a b"), which is also the
// port's `constraint` for the nodes model.
// Literal check: each port's `check` parses the literal with the schema's check_field (type and
// range/choice of that one field, not validate()'s cross-field rules), so the tree loader and
// `visnav validate` refuse a bad literal before the first tick, at the element's file:line,
// naming the port ("port 'frames': value 0 is out of range [1, 100]"). Cross-field rules go in the
// node manifest's check_literals (visnav/bt/registry.hpp).
// Reading back: the ports' current values (literals as written, blackboard entries rendered in
// full precision) as the `params` map the schema parses, located at the node's file:line; a port
// whose blackboard entry is missing or of another type is an error naming the port.
// Thread-safety: as the node (tick thread); the generated checks are immutable and shareable.
#pragma once

#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "visnav/bt/node.hpp"
#include "visnav/bt/ports.hpp"
#include "visnav/config_node.hpp"
#include "visnav/params.hpp"
#include "visnav/result.hpp"

namespace visnav::bt {

/// A set of parameter ports, type-erased: the fields' docs (ParamSchema::docs()) and the check of
/// one field's value (ParamSchema::check_field, or a PrimitiveType's check_param).
struct ParamPorts {
  std::vector<ParamDoc> docs;
  std::function<Status(std::string_view key, const ConfigNode& value)> check;
};

/// Appends one input port per entry of `params.docs` to `ports` (see the header comment).
/// Error: a doc with a type other than the six schema types (nothing is appended for it; the
/// ports before it are). A ParamSchema never produces one.
[[nodiscard]] Status append_param_ports(PortsList& ports, const ParamPorts& params);

/// The current values of the ports named by `docs` (read from `node`) as a ConfigNode map located
/// at the node's file:line, for ParamSchema::parse. Error: a port that cannot be read (unset
/// blackboard entry, entry of another type), naming the port.
[[nodiscard]] Result<ConfigNode> read_param_ports(const TreeNode& node, const std::vector<ParamDoc>& docs);

/// The ports of a schema: its docs and its check_field. Keeps a copy of the schema, so the
/// checks stay valid whatever the lifetime of `schema`.
template <typename P>
[[nodiscard]] ParamPorts param_ports(const ParamSchema<P>& schema) {
  auto shared = std::make_shared<const ParamSchema<P>>(schema);
  return {shared->docs(),
          [shared](std::string_view key, const ConfigNode& value) { return shared->check_field(key, value); }};
}

/// The same with the defaults of `defaults` (a node whose tuned values differ from the struct's
/// own initialisers).
template <typename P>
[[nodiscard]] ParamPorts param_ports(const ParamSchema<P>& schema, const P& defaults) {
  ParamPorts ports = param_ports(schema);
  ports.docs = schema.docs(defaults);
  return ports;
}

/// Appends the ports of `schema` (one per field). Cannot fail: every field type a ParamSchema
/// accepts has a port type (a failure would be a bug here: std::logic_error).
template <typename P>
void append_param_ports(PortsList& ports, const ParamSchema<P>& schema) {
  if (auto st = append_param_ports(ports, param_ports(schema)); !st) throw std::logic_error(st.error().message);
}

/// The same with the defaults of `defaults` (see param_ports(schema, defaults)).
template <typename P>
void append_param_ports(PortsList& ports, const ParamSchema<P>& schema, const P& defaults) {
  if (auto st = append_param_ports(ports, param_ports(schema, defaults)); !st) throw std::logic_error(st.error().message);
}

/// Reads the ports of `schema` from `node` and parses them: the validated params struct, or the
/// first problem (a port that cannot be read, a value out of range, validate()'s verdict), with
/// the node's file:line and the key.
template <typename P>
[[nodiscard]] Result<P> parse_param_ports(const TreeNode& node, const ParamSchema<P>& schema) {
  auto map = read_param_ports(node, schema.docs());
  if (!map) return std::move(map).error();
  return schema.parse(*map);
}

// ---------------------------------------------------------------------------- group ports
//
// A node with many parameters in a few mechanisms gives each mechanism ONE port whose value
// sets any of that mechanism's params struct's keys, the rest keeping their defaults:
//
//   <ReplayAvoiding corridor="lookahead_m=3; confirm_views=4" lane="clearance_m=0.4"> ...
//
// Text: entries `key=value` separated by ';' (blanks around keys and values are ignored, so a
// value may contain spaces, not ';'); empty = every default. The port is a std::string port
// (a blackboard reference "{key}" holding such text works too). Its description lists every key
// with type, default and constraint, so `visnav nodes` documents the keys. Literal check: the
// whole text is parsed as the schema parses a params map, validate() included, so the loader
// and `visnav validate` refuse an unknown key, a bad value and a cross-key rule at the element's
// file:line, naming the port and the key ("port 'corridor': key 'confirm_views': value 0 is out
// of range [1, 100]").

/// The text of a group port as a params map located at `where`. Error: an entry without '=', an
/// empty key, a key given twice (naming it).
[[nodiscard]] Result<ConfigNode> parse_param_group_text(std::string_view text, const SourceLocation& where);

/// `what`, then "Keys: name (type, default d[, constraint]): description; ..." for `docs`.
[[nodiscard]] std::string param_group_description(std::string_view what, const std::vector<ParamDoc>& docs);

/// The problems of a group port's literal `text` for `schema` on top of `defaults`, without a
/// location (the tree loader adds the element's): each entry's own check, then validate().
template <typename P>
[[nodiscard]] Status check_param_group(std::string_view text, const ParamSchema<P>& schema, const P& defaults) {
  VISNAV_ASSIGN(ConfigNode map, parse_param_group_text(text, {}));
  for (const auto& [key, value] : map.entries()) {
    if (auto st = schema.check_field(key, value); !st) {
      if (st.error().code == ErrorCode::unknown_key) {
        std::string known;
        for (const auto& d : schema.docs()) known += (known.empty() ? "" : ", ") + d.name;
        return Error{"unknown key '" + key + "' (known keys: " + known + ")", ErrorCode::unknown_key};
      }
      return Error{"key '" + key + "': " + st.error().message, st.error().with_default_code(ErrorCode::invalid_value).code};
    }
  }
  auto whole = schema.parse(map, defaults);
  if (whole) return ok();
  // validate()'s verdict, without the "<built-in>: " of a map made in code.
  std::string message = whole.error().message;
  const std::string builtin = SourceLocation{}.str() + ": ";
  if (message.starts_with(builtin)) message.erase(0, builtin.size());
  return Error{message, whole.error().code};
}

/// One std::string input port `name` for `schema`'s keys on top of `defaults` (see above).
template <typename P>
[[nodiscard]] PortInfo param_group_port(std::string name, const ParamSchema<P>& schema, const P& defaults,
                                        std::string_view what) {
  auto shared = std::make_shared<const ParamSchema<P>>(schema);
  PortInfo port = input_port<std::string>(std::move(name), "", param_group_description(what, shared->docs(defaults)));
  port.check = [shared, defaults](std::string_view text) { return check_param_group(text, *shared, defaults); };
  return port;
}

/// The params of group port `port` of `node`: `defaults` with the port's keys applied, validated.
/// Error: the port unreadable, a bad entry, key or value, validate()'s verdict; located at the
/// node's file:line and naming the port.
template <typename P>
[[nodiscard]] Result<P> parse_param_group(const TreeNode& node, const std::string& port, const ParamSchema<P>& schema,
                                          const P& defaults) {
  auto text = node.get_input<std::string>(port);
  if (!text) return text.error().with_context("port '" + port + "'");
  auto map = parse_param_group_text(*text, node.where());
  if (!map) return map.error().with_context("port '" + port + "'");
  auto parsed = schema.parse(*map, defaults);
  if (!parsed) return parsed.error().with_context("port '" + port + "'");
  return parsed;
}

}  // namespace visnav::bt
