// `visnav security init DIR --robot NAME --operator NAME...`: a DDS Security keystore (issue 17)
// made with the openssl command line: a CA, one identity per role, a governance document that
// encrypts and signs everything, and per-role permissions, each signed by the CA. The layout is
// what dds::keystore_identity() and `--keystore/--identity` of simd and monitor read.
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include "args.hpp"
#include "command.hpp"
#include "visnav/params.hpp"

namespace {

namespace fs = std::filesystem;

constexpr const char* kUsage =
    "usage: visnav security init DIR --robot NAME --operator NAME [--operator NAME]... [--days N] [--force]\n"
    "\n"
    "Creates a DDS Security keystore in DIR with openssl (docs/security.md):\n"
    "  DIR/ca.pem, DIR/ca.key          the CA (keep ca.key offline once the keystore is made)\n"
    "  DIR/governance.xml/.p7s         join access control on; discovery, liveliness and data encrypted,\n"
    "                                  RTPS messages signed; unauthenticated participants refused\n"
    "  DIR/<identity>/cert.pem key.pem permissions.xml permissions.p7s   one folder per identity:\n"
    "    NAME-driver   the robot driver (`visnav simd`, a ROS 2 base): publishes odom, camera images and\n"
    "                  the simulator's ground truth; subscribes cmd_vel and control\n"
    "    NAME-mission  `visnav run`: publishes cmd_vel and telemetry; subscribes odom, images and control\n"
    "    <operator>    `visnav monitor`: publishes control (pause/resume/abort/swap_detector); reads\n"
    "                  telemetry. Only operators may publish control, so the mission obeys only them.\n"
    "  DIR/<identity>/dds.yaml         the `dds: {security: ...}` block for that identity's run config\n"
    "\n"
    "  --robot NAME     robot name (1-32 of A-Z a-z 0-9 _ -)\n"
    "  --operator NAME  an operator identity (repeatable)\n"
    "  --days N         validity of certificates and permissions (default 3650)\n"
    "  --force          write into a DIR that already holds a keystore (replaces it)\n"
    "Exit status: 0 ok, 1 openssl or file error, 2 usage error.\n";

bool valid_name(const std::string& s) {
  if (s.empty() || s.size() > 32) return false;
  for (char c : s)
    if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-'))
      return false;
  return true;
}

/// Runs openssl with `args` (no shell); its output goes to DIR/openssl.log. Returns "" or a message.
std::string openssl(const std::vector<std::string>& args, const fs::path& log) {
  const pid_t pid = ::fork();
  if (pid < 0) return "fork failed";
  if (pid == 0) {
    std::FILE* f = std::fopen(log.c_str(), "a");
    if (f != nullptr) {
      ::dup2(::fileno(f), STDOUT_FILENO);
      ::dup2(::fileno(f), STDERR_FILENO);
    }
    std::vector<char*> argv;
    std::string prog = "openssl";
    argv.push_back(prog.data());
    std::vector<std::string> copy = args;
    for (auto& a : copy) argv.push_back(a.data());
    argv.push_back(nullptr);
    ::execvp("openssl", argv.data());
    ::_exit(127);
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
  if (WIFEXITED(status) && WEXITSTATUS(status) == 127) return "openssl not found (install the Debian package openssl)";
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    std::string cmd = "openssl";
    for (const auto& a : args) cmd += " " + a;
    return "'" + cmd + "' failed (see " + log.string() + ")";
  }
  return {};
}

bool write_text(const fs::path& p, const std::string& text) {
  std::ofstream out(p, std::ios::trunc);
  out << text;
  return static_cast<bool>(out);
}

// Cyclone accepts domain ids up to 230 in governance and permissions documents.
std::string domains_xml() { return "<domains><id_range><min>0</min><max>230</max></id_range></domains>"; }

std::string governance_xml() {
  return R"(<?xml version="1.0" encoding="UTF-8"?>
<!-- visnav DDS Security governance (docs/security.md): only authenticated participants join;
     discovery, liveliness and every topic's data are encrypted, RTPS messages are signed. -->
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_governance.xsd">
  <domain_access_rules>
    <domain_rule>
      )" + domains_xml() + R"(
      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>
      <enable_join_access_control>true</enable_join_access_control>
      <discovery_protection_kind>ENCRYPT</discovery_protection_kind>
      <liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>
      <rtps_protection_kind>SIGN</rtps_protection_kind>
      <topic_access_rules>
        <topic_rule>
          <topic_expression>*</topic_expression>
          <enable_discovery_protection>true</enable_discovery_protection>
          <enable_liveliness_protection>true</enable_liveliness_protection>
          <enable_read_access_control>true</enable_read_access_control>
          <enable_write_access_control>true</enable_write_access_control>
          <metadata_protection_kind>ENCRYPT</metadata_protection_kind>
          <data_protection_kind>ENCRYPT</data_protection_kind>
        </topic_rule>
      </topic_access_rules>
    </domain_rule>
  </domain_access_rules>
</dds>
)";
}

std::string topics_xml(const std::vector<std::string>& topics) {
  std::string out = "<topics>";
  for (const auto& t : topics) out += "<topic>" + t + "</topic>";
  return out + "</topics><partitions><partition>*</partition></partitions>";
}

/// ISO-8601 UTC date `days` from now (permissions validity).
std::string utc_in_days(long days) {
  const std::time_t t = std::time(nullptr) + days * 86400L;
  std::tm tm{};
  ::gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%S", &tm);
  return buf;
}

std::string permissions_xml(const std::string& identity, const std::vector<std::string>& publish,
                            const std::vector<std::string>& subscribe, long days) {
  return R"(<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_permissions.xsd">
  <permissions>
    <grant name=")" + identity + R"(_grant">
      <subject_name>CN=)" + identity + R"(</subject_name>
      <validity><not_before>)" + utc_in_days(-1) + "</not_before><not_after>" + utc_in_days(days) + R"(</not_after></validity>
      <allow_rule>
        )" + domains_xml() + R"(
        <publish>)" + topics_xml(publish) + R"(</publish>
        <subscribe>)" + topics_xml(subscribe) + R"(</subscribe>
      </allow_rule>
      <default>DENY</default>
    </grant>
  </permissions>
</dds>
)";
}

struct Role {
  std::string identity;
  std::vector<std::string> publish;
  std::vector<std::string> subscribe;
};

int init(const std::vector<std::string>& args) {
  using visnav::cli::Opt;
  visnav::cli::Args a;
  if (args.empty() || args[0].rfind("--", 0) == 0) return visnav::cli::usage_error("security", "init needs a folder DIR first");
  if (auto st = a.parse(std::vector<std::string>(args.begin() + 1, args.end()),
                        {{"--robot", Opt::value}, {"--operator", Opt::repeated}, {"--days", Opt::value},
                         {"--force", Opt::flag}});
      !st)
    return visnav::cli::usage_error("security", st.error().message);
  if (auto st = a.require({"--robot", "--operator"}); !st) return visnav::cli::usage_error("security", st.error().message);
  const fs::path dir = args[0];
  const std::string robot = a.get("--robot");
  const std::vector<std::string> operators = a.all("--operator");
  long days = 3650;
  if (a.has("--days")) {
    auto d = visnav::detail::parse_int(a.get("--days"));
    if (!d || *d < 1 || *d > 36500) return visnav::cli::usage_error("security", "--days: expected 1..36500");
    days = *d;
  }
  for (const auto& n : operators)
    if (!valid_name(n)) return visnav::cli::usage_error("security", "--operator '" + n + "': expected 1-32 of A-Z a-z 0-9 _ -");
  if (!valid_name(robot)) return visnav::cli::usage_error("security", "--robot '" + robot + "': expected 1-32 of A-Z a-z 0-9 _ -");

  std::error_code ec;
  if (fs::exists(dir / "ca.pem", ec) && !a.has("--force")) {
    std::cerr << "visnav security: " << dir.string() << ": already holds a keystore (give --force to replace it)\n";
    return 1;
  }
  fs::create_directories(dir, ec);
  if (ec) {
    std::cerr << "visnav security: " << dir.string() << ": " << ec.message() << "\n";
    return 1;
  }
  ::chmod(dir.c_str(), 0700);
  const fs::path log = dir / "openssl.log";
  fs::remove(log, ec);
  auto failed = [&](const std::string& message) {
    std::cerr << "visnav security: " << message << "\n";
    return 1;
  };
  const std::string d = std::to_string(days);
  const std::string ca_pem = (dir / "ca.pem").string(), ca_key = (dir / "ca.key").string();
  // EC P-256: supported by Cyclone's builtin authentication plugin (and by SROS2).
  if (auto e = openssl({"req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes", "-keyout",
                        ca_key, "-out", ca_pem, "-days", d, "-subj", "/CN=visnav " + robot + " CA"},
                       log);
      !e.empty())
    return failed(e);
  ::chmod(ca_key.c_str(), 0600);

  if (!write_text(dir / "governance.xml", governance_xml())) return failed((dir / "governance.xml").string() + ": cannot write");
  auto sign = [&](const fs::path& in, const fs::path& out) {
    return openssl({"smime", "-sign", "-in", in.string(), "-text", "-out", out.string(), "-signer", ca_pem, "-inkey",
                    ca_key},
                   log);
  };
  if (auto e = sign(dir / "governance.xml", dir / "governance.p7s"); !e.empty()) return failed(e);

  std::vector<Role> roles;
  roles.push_back({robot + "-driver", {"rt/odom", "rt/camera/*", "rt/visnav/sim/*"}, {"rt/cmd_vel", "rt/visnav/control"}});
  roles.push_back({robot + "-mission",
                   {"rt/cmd_vel", "rt/visnav/telemetry"},
                   {"rt/odom", "rt/camera/*", "rt/visnav/control"}});
  for (const auto& op : operators) roles.push_back({op, {"rt/visnav/control"}, {"rt/visnav/telemetry"}});

  for (const auto& role : roles) {
    const fs::path id_dir = dir / role.identity;
    fs::create_directories(id_dir, ec);
    if (ec) return failed(id_dir.string() + ": " + ec.message());
    const std::string key = (id_dir / "key.pem").string(), csr = (id_dir / "cert.csr").string(),
                      cert = (id_dir / "cert.pem").string();
    if (auto e = openssl({"req", "-new", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes", "-keyout",
                          key, "-out", csr, "-subj", "/CN=" + role.identity},
                         log);
        !e.empty())
      return failed(e);
    ::chmod(key.c_str(), 0600);
    if (auto e = openssl({"x509", "-req", "-in", csr, "-CA", ca_pem, "-CAkey", ca_key, "-CAcreateserial", "-out", cert,
                          "-days", d},
                         log);
        !e.empty())
      return failed(e);
    fs::remove(csr, ec);
    if (!write_text(id_dir / "permissions.xml", permissions_xml(role.identity, role.publish, role.subscribe, days)))
      return failed((id_dir / "permissions.xml").string() + ": cannot write");
    if (auto e = sign(id_dir / "permissions.xml", id_dir / "permissions.p7s"); !e.empty()) return failed(e);
    const fs::path abs = fs::absolute(dir, ec).lexically_normal();
    write_text(id_dir / "dds.yaml", "# dds block of a run config for identity " + role.identity +
                                        " (docs/security.md)\ndds:\n  security:\n    ca: " + (abs / "ca.pem").string() +
                                        "\n    identity_cert: " + (abs / role.identity / "cert.pem").string() +
                                        "\n    private_key: " + (abs / role.identity / "key.pem").string() +
                                        "\n    governance: " + (abs / "governance.p7s").string() +
                                        "\n    permissions: " + (abs / role.identity / "permissions.p7s").string() + "\n");
  }
  fs::remove(dir / "ca.srl", ec);
  std::cout << "keystore " << dir.string() << ": CA, governance (encrypt + sign), identities";
  for (const auto& role : roles) std::cout << " " << role.identity;
  std::cout << "\nrun config: dds: {security: " << (dir / (robot + "-mission")).string()
            << "} (or the block in " << (dir / (robot + "-mission") / "dds.yaml").string() << "); simd: --keystore " << dir.string() << " --identity " << robot
            << "-driver; monitor: --keystore " << dir.string() << " --identity " << operators.front() << "\n";
  return 0;
}

int run_security(const std::vector<std::string>& args) {
  if (args.empty()) return visnav::cli::usage_error("security", "missing subcommand (init)");
  if (args[0] != "init") return visnav::cli::usage_error("security", "unknown subcommand '" + args[0] + "'");
  return init(std::vector<std::string>(args.begin() + 1, args.end()));
}

}  // namespace

VISNAV_COMMAND(security, "security", "create a DDS Security keystore: CA, identities, governance, permissions",
               kUsage, &run_security)
