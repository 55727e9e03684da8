// Edge payload file format: encoding, verification, CRC-32. Self-contained (no I/O) so the
// fuzzer (fuzz/fuzz_payload_reader.cpp) compiles this file directly.
//
// Layout (little-endian), see docs/map_format.md:
//   0  char[8]  magic "VNAVEDGE"
//   8  u32      format version (1)
//  12  u16      kind length K (1..64)
//  14  u16      edge id length I (1..64)
//  16  u64      body length B
//  24  u32      CRC-32 of the body
//  28  u32      CRC-32 of bytes 0..27 followed by the kind and id bytes
//  32  K bytes  kind, then I bytes edge id, then B bytes body; the file ends there.
#include <array>
#include <cstdio>

#include "visnav/map.hpp"

namespace visnav::map_format {

namespace {

constexpr std::array<std::array<std::uint32_t, 256>, 8> make_crc_tables() {
  std::array<std::array<std::uint32_t, 256>, 8> t{};
  for (std::uint32_t i = 0; i < 256; ++i) {
    std::uint32_t c = i;
    for (int k = 0; k < 8; ++k) c = (c & 1U) ? (0xEDB88320U ^ (c >> 1)) : (c >> 1);
    t[0][i] = c;
  }
  for (std::uint32_t i = 0; i < 256; ++i) {
    for (std::size_t s = 1; s < 8; ++s) t[s][i] = (t[s - 1][i] >> 8) ^ t[0][t[s - 1][i] & 0xFFU];
  }
  return t;
}
constexpr auto kCrcTables = make_crc_tables();

void put_le(std::uint8_t* p, std::uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}
std::uint64_t get_le(const std::uint8_t* p, int bytes) {
  std::uint64_t v = 0;
  for (int i = bytes - 1; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}
std::string hex32(std::uint32_t v) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%08x", v);
  return buf;
}
bool id_char(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
}
std::string printable(std::span<const std::uint8_t> bytes) {
  std::string s;
  for (auto b : bytes) s += (b >= 0x20 && b < 0x7f) ? static_cast<char>(b) : '.';
  return s;
}

}  // namespace

std::uint32_t crc32(std::span<const std::uint8_t> bytes, std::uint32_t seed) {
  std::uint32_t c = ~seed;
  const std::uint8_t* p = bytes.data();
  std::size_t n = bytes.size();
  while (n >= 8) {
    const std::uint32_t lo = c ^ (static_cast<std::uint32_t>(p[0]) | static_cast<std::uint32_t>(p[1]) << 8 |
                                  static_cast<std::uint32_t>(p[2]) << 16 | static_cast<std::uint32_t>(p[3]) << 24);
    c = kCrcTables[7][lo & 0xFFU] ^ kCrcTables[6][(lo >> 8) & 0xFFU] ^ kCrcTables[5][(lo >> 16) & 0xFFU] ^
        kCrcTables[4][lo >> 24] ^ kCrcTables[3][p[4]] ^ kCrcTables[2][p[5]] ^ kCrcTables[1][p[6]] ^
        kCrcTables[0][p[7]];
    p += 8;
    n -= 8;
  }
  while (n-- > 0) c = kCrcTables[0][(c ^ *p++) & 0xFFU] ^ (c >> 8);
  return ~c;
}

bool valid_id(std::string_view id) {
  if (id.empty() || id.size() > 64) return false;
  for (char c : id) if (!id_char(c)) return false;
  return true;
}

bool valid_kind(std::string_view kind) {
  if (kind.empty() || kind.size() > 64 || kind.front() == '.') return false;
  for (char c : kind) if (!id_char(c) && c != '.') return false;
  return true;
}

std::vector<std::uint8_t> encode_payload(std::string_view kind, std::string_view edge_id,
                                         std::span<const std::uint8_t> body) {
  const std::size_t strings = kind.size() + edge_id.size();
  std::vector<std::uint8_t> out(kPayloadFixedHeaderBytes + strings + body.size());
  std::uint8_t* p = out.data();
  std::memcpy(p, kPayloadMagic, 8);
  put_le(p + 8, kPayloadVersion, 4);
  put_le(p + 12, kind.size(), 2);
  put_le(p + 14, edge_id.size(), 2);
  put_le(p + 16, body.size(), 8);
  put_le(p + 24, crc32(body), 4);
  if (!kind.empty()) std::memcpy(p + kPayloadFixedHeaderBytes, kind.data(), kind.size());
  if (!edge_id.empty()) std::memcpy(p + kPayloadFixedHeaderBytes + kind.size(), edge_id.data(), edge_id.size());
  std::uint32_t header_crc = crc32({p, 28});
  header_crc = crc32({p + kPayloadFixedHeaderBytes, strings}, header_crc);
  put_le(p + 28, header_crc, 4);
  if (!body.empty()) std::memcpy(p + kPayloadFixedHeaderBytes + strings, body.data(), body.size());
  return out;
}

Result<PayloadView> parse_payload(std::span<const std::uint8_t> file, std::string_view file_name) {
  const std::string where(file_name);
  auto bad = [&](const std::string& what) { return fail(where + ": " + what); };
  const std::size_t size = file.size();
  if (size == 0) return bad("empty file (not a visnav edge payload)");
  const std::size_t magic_len = size < 8 ? size : 8;
  if (std::memcmp(file.data(), kPayloadMagic, magic_len) != 0) {
    return bad("not a visnav edge payload (starts with '" + printable(file.first(magic_len)) +
               "', expected magic 'VNAVEDGE')");
  }
  if (size < kPayloadFixedHeaderBytes) {
    return bad("truncated: " + std::to_string(size) + " bytes, the header alone needs " +
               std::to_string(kPayloadFixedHeaderBytes));
  }
  const std::uint8_t* p = file.data();
  const auto version = static_cast<std::uint32_t>(get_le(p + 8, 4));
  const auto kind_len = static_cast<std::size_t>(get_le(p + 12, 2));
  const auto id_len = static_cast<std::size_t>(get_le(p + 14, 2));
  const std::uint64_t body_len = get_le(p + 16, 8);
  const auto body_crc = static_cast<std::uint32_t>(get_le(p + 24, 4));
  const auto stored_header_crc = static_cast<std::uint32_t>(get_le(p + 28, 4));

  const std::size_t strings_end = kPayloadFixedHeaderBytes + kind_len + id_len;
  if (strings_end > size) {
    return bad("truncated or damaged header: it declares " + std::to_string(kind_len + id_len) +
               " bytes of kind and id but the file has " + std::to_string(size) + " bytes");
  }
  std::uint32_t header_crc = crc32(file.first(28));
  header_crc = crc32(file.subspan(kPayloadFixedHeaderBytes, kind_len + id_len), header_crc);
  if (header_crc != stored_header_crc) {
    return bad("damaged header: header checksum mismatch (stored " + hex32(stored_header_crc) + ", computed " +
               hex32(header_crc) + ")");
  }
  if (version != kPayloadVersion) {
    return bad("unsupported payload format version " + std::to_string(version) + " (this build reads version " +
               std::to_string(kPayloadVersion) + ")");
  }
  PayloadView view;
  view.version = version;
  view.kind.assign(reinterpret_cast<const char*>(p + kPayloadFixedHeaderBytes), kind_len);
  view.edge_id.assign(reinterpret_cast<const char*>(p + kPayloadFixedHeaderBytes + kind_len), id_len);
  if (!valid_kind(view.kind)) return bad("invalid primitive kind '" + printable(file.subspan(32, kind_len)) + "' in header");
  if (!valid_id(view.edge_id)) {
    return bad("invalid edge id '" + printable(file.subspan(32 + kind_len, id_len)) + "' in header");
  }
  const std::uint64_t available = size - strings_end;
  if (body_len > available) {
    return bad("truncated: header declares a body of " + std::to_string(body_len) + " bytes but only " +
               std::to_string(available) + " follow");
  }
  if (body_len < available) {
    return bad("trailing data: header declares a body of " + std::to_string(body_len) + " bytes but " +
               std::to_string(available) + " follow");
  }
  view.body = file.subspan(strings_end, static_cast<std::size_t>(body_len));
  const std::uint32_t computed = crc32(view.body);
  if (computed != body_crc) {
    return bad("damaged body: checksum mismatch (stored " + hex32(body_crc) + ", computed " + hex32(computed) + ")");
  }
  return view;
}

}  // namespace visnav::map_format
