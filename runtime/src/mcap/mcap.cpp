// MCAP writer and reader (see visnav/mcap.hpp). Record layouts follow the MCAP specification,
// format version 0: little-endian integers, String = u32 length + bytes, Map = u32 byte length +
// entries, records = u8 opcode + u64 content length + content.
#include "visnav/mcap.hpp"

#include <algorithm>
#include <array>
#include <cstring>
#include <filesystem>

#ifdef VISNAV_HAVE_ZSTD
#include <zstd.h>
#endif
#ifdef VISNAV_HAVE_LZ4
#include <lz4frame.h>
#endif

#include "visnav/file_io.hpp"

namespace visnav::mcap {
namespace {

constexpr char kMagic[8] = {'\x89', 'M', 'C', 'A', 'P', '0', '\r', '\n'};
enum Op : std::uint8_t {
  kHeader = 0x01, kFooter = 0x02, kSchema = 0x03, kChannel = 0x04, kMessage = 0x05, kChunk = 0x06,
  kMessageIndex = 0x07, kChunkIndex = 0x08, kAttachment = 0x09, kAttachmentIndex = 0x0A,
  kStatistics = 0x0B, kMetadata = 0x0C, kMetadataIndex = 0x0D, kSummaryOffset = 0x0E, kDataEnd = 0x0F
};

// ---- encoding ----------------------------------------------------------------------------

template <typename T>
void put_le(std::string& out, T value) {
  for (std::size_t i = 0; i < sizeof(T); ++i) out.push_back(static_cast<char>((static_cast<std::uint64_t>(value) >> (8 * i)) & 0xFF));
}
void put_str(std::string& out, std::string_view s) {
  put_le<std::uint32_t>(out, static_cast<std::uint32_t>(s.size()));
  out.append(s);
}
std::string record(std::uint8_t op, const std::string& content) {
  std::string r;
  r.reserve(content.size() + 9);
  r.push_back(static_cast<char>(op));
  put_le<std::uint64_t>(r, content.size());
  r += content;
  return r;
}
std::string schema_record(const Schema& s) {
  std::string c;
  put_le<std::uint16_t>(c, s.id);
  put_str(c, s.name);
  put_str(c, s.encoding);
  put_str(c, s.data);
  return record(kSchema, c);
}
std::string channel_record(const Channel& ch) {
  std::string c;
  put_le<std::uint16_t>(c, ch.id);
  put_le<std::uint16_t>(c, ch.schema_id);
  put_str(c, ch.topic);
  put_str(c, ch.message_encoding);
  std::string map;
  for (const auto& [k, v] : ch.metadata) {
    put_str(map, k);
    put_str(map, v);
  }
  put_str(c, map);
  return record(kChannel, c);
}

// ---- decoding ----------------------------------------------------------------------------

/// Bounds-checked little-endian reader over a byte range.
class Cursor {
 public:
  Cursor(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  template <typename T>
  bool get(T& v) {
    if (size_ - pos_ < sizeof(T)) return false;
    std::uint64_t x = 0;
    for (std::size_t i = 0; i < sizeof(T); ++i) x |= static_cast<std::uint64_t>(data_[pos_ + i]) << (8 * i);
    v = static_cast<T>(x);
    pos_ += sizeof(T);
    return true;
  }
  bool str(std::string& s) {
    std::uint32_t n = 0;
    if (!get(n) || size_ - pos_ < n) return false;
    s.assign(reinterpret_cast<const char*>(data_ + pos_), n);
    pos_ += n;
    return true;
  }
  bool bytes64(std::string& s) {
    std::uint64_t n = 0;
    if (!get(n) || size_ - pos_ < n) return false;
    s.assign(reinterpret_cast<const char*>(data_ + pos_), n);
    pos_ += n;
    return true;
  }
  [[nodiscard]] std::size_t pos() const { return pos_; }
  [[nodiscard]] std::size_t left() const { return size_ - pos_; }
  [[nodiscard]] const std::uint8_t* here() const { return data_ + pos_; }
  void skip(std::size_t n) { pos_ += std::min(n, left()); }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
};

}  // namespace

std::uint32_t crc32(const void* data, std::size_t size, std::uint32_t crc) {
  static const auto table = [] {
    std::array<std::uint32_t, 256> t{};
    for (std::uint32_t i = 0; i < 256; ++i) {
      std::uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1U) != 0 ? 0xEDB88320U ^ (c >> 1) : c >> 1;
      t[i] = c;
    }
    return t;
  }();
  const auto* p = static_cast<const std::uint8_t*>(data);
  crc = ~crc;
  for (std::size_t i = 0; i < size; ++i) crc = table[(crc ^ p[i]) & 0xFFU] ^ (crc >> 8);
  return ~crc;
}

bool zstd_available() {
#ifdef VISNAV_HAVE_ZSTD
  return true;
#else
  return false;
#endif
}

bool lz4_available() {
#ifdef VISNAV_HAVE_LZ4
  return true;
#else
  return false;
#endif
}

namespace {

/// MCAP's "lz4" is the LZ4 frame format (not the raw block format).
Result<std::string> lz4_compress(const std::string& plain) {
#ifdef VISNAV_HAVE_LZ4
  LZ4F_preferences_t prefs{};
  prefs.frameInfo.contentSize = plain.size();  // lets a reader size its buffer
  std::string out(LZ4F_compressFrameBound(plain.size(), &prefs), '\0');
  const std::size_t n = LZ4F_compressFrame(out.data(), out.size(), plain.data(), plain.size(), &prefs);
  if (LZ4F_isError(n) != 0U) return fail(std::string("lz4: ") + LZ4F_getErrorName(n));
  out.resize(n);
  return out;
#else
  (void)plain;
  return fail(ErrorCode::out_of_range, "lz4 chunks, but visnav was built without liblz4 (install liblz4-dev)");
#endif
}

Result<std::string> lz4_decompress(const std::string& frame, std::uint64_t uncompressed_size) {
#ifdef VISNAV_HAVE_LZ4
  LZ4F_dctx* dctx = nullptr;
  if (LZ4F_isError(LZ4F_createDecompressionContext(&dctx, LZ4F_VERSION)) != 0U) return fail("lz4: no context");
  std::string plain(uncompressed_size, '\0');
  std::size_t in_pos = 0, out_pos = 0;
  std::size_t hint = 1;
  // A frame may hold several blocks (and the spec allows concatenated frames): decode until the
  // input is used up or the decoder says the frame is done with nothing left.
  while (in_pos < frame.size() && hint != 0) {
    std::size_t out_n = plain.size() - out_pos;
    std::size_t in_n = frame.size() - in_pos;
    hint = LZ4F_decompress(dctx, plain.data() + out_pos, &out_n, frame.data() + in_pos, &in_n, nullptr);
    if (LZ4F_isError(hint) != 0U) {
      LZ4F_freeDecompressionContext(dctx);
      return fail(ErrorCode::parse_error, std::string("lz4: ") + LZ4F_getErrorName(hint));
    }
    in_pos += in_n;
    out_pos += out_n;
    if (in_n == 0 && out_n == 0) break;  // no progress: output full or input malformed
    if (hint == 0 && in_pos < frame.size()) hint = 1;  // another concatenated frame follows
  }
  LZ4F_freeDecompressionContext(dctx);
  if (out_pos != uncompressed_size || in_pos != frame.size()) return fail(ErrorCode::parse_error, "lz4 chunk does not decompress to its size");
  return plain;
#else
  (void)frame;
  (void)uncompressed_size;
  return fail(ErrorCode::out_of_range, "lz4 chunk, but visnav was built without liblz4 (install liblz4-dev)");
#endif
}

}  // namespace

// ---- Writer ------------------------------------------------------------------------------

Result<std::unique_ptr<Writer>> Writer::create(const std::string& path, WriterOptions options) {
  std::unique_ptr<Writer> w(new Writer());
  w->path_ = path;
  w->options_ = std::move(options);
  if (w->options_.compression != "zstd" && w->options_.compression != "lz4")
    return fail(ErrorCode::out_of_range, "MCAP compression '" + w->options_.compression + "' is not one of zstd, lz4");
  w->out_.open(path, std::ios::binary | std::ios::trunc);
  if (!w->out_) return fail(ErrorCode::io, {path}, "cannot create the MCAP file");
  std::string head(kMagic, sizeof kMagic);
  std::string c;
  put_str(c, w->options_.profile);
  put_str(c, w->options_.library);
  head += record(kHeader, c);
  VISNAV_TRY(w->put(head));
  return w;
}

Writer::~Writer() { (void)close(); }

Status Writer::put(const std::string& bytes) {
  out_.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (!out_) return fail(ErrorCode::io, {path_}, "write failed at byte " + std::to_string(offset_) + " (disk full?)");
  offset_ += bytes.size();
  return ok();
}

std::uint16_t Writer::add_schema(const std::string& name, const std::string& encoding, const std::string& data) {
  schemas_.push_back({static_cast<std::uint16_t>(schemas_.size() + 1), name, encoding, data});
  chunk_has_schema_.push_back(false);
  return schemas_.back().id;
}

std::uint16_t Writer::add_channel(std::uint16_t schema_id, const std::string& topic, const std::string& message_encoding,
                                  std::vector<std::pair<std::string, std::string>> metadata) {
  channels_.push_back({static_cast<std::uint16_t>(channels_.size() + 1), schema_id, topic, message_encoding, std::move(metadata)});
  chunk_has_channel_.push_back(false);
  return channels_.back().id;
}

Status Writer::write(const Message& m) {
  if (closed_) return fail(path_ + ": write after close");
  if (m.channel_id == 0 || m.channel_id > channels_.size())
    return fail(path_ + ": message on unknown channel " + std::to_string(m.channel_id));
  const Channel& ch = channels_[m.channel_id - 1U];
  // Each chunk carries the schema and channel records its messages need, so a reader can start
  // at any chunk (and a truncated file keeps them).
  if (ch.schema_id != 0 && !chunk_has_schema_[ch.schema_id - 1U]) {
    chunk_records_ += schema_record(schemas_[ch.schema_id - 1U]);
    chunk_has_schema_[ch.schema_id - 1U] = true;
  }
  if (!chunk_has_channel_[m.channel_id - 1U]) {
    chunk_records_ += channel_record(ch);
    chunk_has_channel_[m.channel_id - 1U] = true;
  }
  if (chunk_index_.empty() || m.log_time_ns < chunk_start_ns_) chunk_start_ns_ = m.log_time_ns;
  if (chunk_index_.empty() || m.log_time_ns > chunk_end_ns_) chunk_end_ns_ = m.log_time_ns;
  chunk_index_[m.channel_id].emplace_back(m.log_time_ns, chunk_records_.size());
  std::string c;
  c.reserve(22 + m.data.size());
  put_le<std::uint16_t>(c, m.channel_id);
  put_le<std::uint32_t>(c, m.sequence);
  put_le<std::uint64_t>(c, m.log_time_ns);
  put_le<std::uint64_t>(c, m.publish_time_ns);
  c.append(reinterpret_cast<const char*>(m.data.data()), m.data.size());
  chunk_records_ += record(kMessage, c);
  if (message_count_ == 0 || m.log_time_ns < start_ns_) start_ns_ = m.log_time_ns;
  if (message_count_ == 0 || m.log_time_ns > end_ns_) end_ns_ = m.log_time_ns;
  ++message_count_;
  ++channel_counts_[m.channel_id];
  if (chunk_records_.size() >= options_.chunk_size_bytes) return flush_chunk();
  return ok();
}

Status Writer::flush_chunk() {
  if (chunk_records_.empty()) return ok();
  const std::uint32_t crc = crc32(chunk_records_.data(), chunk_records_.size());
  std::string compression;
  std::string payload;
  if (options_.compress && options_.compression == "lz4" && lz4_available()) {
    VISNAV_ASSIGN(payload, lz4_compress(chunk_records_));
    compression = "lz4";
  }
#ifdef VISNAV_HAVE_ZSTD
  if (options_.compress && options_.compression == "zstd") {
    payload.resize(ZSTD_compressBound(chunk_records_.size()));
    const std::size_t n = ZSTD_compress(payload.data(), payload.size(), chunk_records_.data(), chunk_records_.size(), 3);
    if (ZSTD_isError(n) != 0U) return fail(path_ + ": zstd: " + ZSTD_getErrorName(n));
    payload.resize(n);
    compression = "zstd";
  }
#endif
  if (compression.empty()) payload = chunk_records_;
  std::string c;
  put_le<std::uint64_t>(c, chunk_start_ns_);
  put_le<std::uint64_t>(c, chunk_end_ns_);
  put_le<std::uint64_t>(c, chunk_records_.size());
  put_le<std::uint32_t>(c, crc);
  put_str(c, compression);
  put_le<std::uint64_t>(c, payload.size());
  c += payload;
  const std::uint64_t chunk_start = offset_;
  const std::string chunk = record(kChunk, c);
  VISNAV_TRY(put(chunk));
  // Message Index records, one per channel in the chunk.
  std::string index_offsets;
  const std::uint64_t indexes_start = offset_;
  for (const auto& [channel, entries] : chunk_index_) {
    put_le<std::uint16_t>(index_offsets, channel);
    put_le<std::uint64_t>(index_offsets, offset_);
    std::string ic;
    put_le<std::uint16_t>(ic, channel);
    std::string array;
    for (const auto& [t, off] : entries) {
      put_le<std::uint64_t>(array, t);
      put_le<std::uint64_t>(array, off);
    }
    put_str(ic, array);
    VISNAV_TRY(put(record(kMessageIndex, ic)));
  }
  std::string ci;
  put_le<std::uint64_t>(ci, chunk_start_ns_);
  put_le<std::uint64_t>(ci, chunk_end_ns_);
  put_le<std::uint64_t>(ci, chunk_start);
  put_le<std::uint64_t>(ci, chunk.size());
  put_str(ci, index_offsets);
  put_le<std::uint64_t>(ci, offset_ - indexes_start);
  put_str(ci, compression);
  put_le<std::uint64_t>(ci, payload.size());
  put_le<std::uint64_t>(ci, chunk_records_.size());
  chunk_indexes_ += record(kChunkIndex, ci);
  ++chunk_count_;
  chunk_records_.clear();
  chunk_index_.clear();
  std::fill(chunk_has_schema_.begin(), chunk_has_schema_.end(), false);
  std::fill(chunk_has_channel_.begin(), chunk_has_channel_.end(), false);
  out_.flush();  // a crash after this keeps the chunk
  return ok();
}

Status Writer::write_attachment(const Attachment& a) {
  if (closed_) return fail(path_ + ": write after close");
  VISNAV_TRY(flush_chunk());  // attachments live outside chunks
  std::string c;
  put_le<std::uint64_t>(c, a.log_time_ns);
  put_le<std::uint64_t>(c, a.create_time_ns);
  put_str(c, a.name);
  put_str(c, a.media_type);
  put_le<std::uint64_t>(c, a.data.size());
  c += a.data;
  put_le<std::uint32_t>(c, crc32(c.data(), c.size()));
  const std::uint64_t at = offset_;
  const std::string r = record(kAttachment, c);
  VISNAV_TRY(put(r));
  std::string ai;
  put_le<std::uint64_t>(ai, at);
  put_le<std::uint64_t>(ai, r.size());
  put_le<std::uint64_t>(ai, a.log_time_ns);
  put_le<std::uint64_t>(ai, a.create_time_ns);
  put_le<std::uint64_t>(ai, a.data.size());
  put_str(ai, a.name);
  put_str(ai, a.media_type);
  attachment_indexes_ += record(kAttachmentIndex, ai);
  ++attachment_count_;
  return ok();
}

Status Writer::close() {
  if (closed_) return ok();
  closed_ = true;
  VISNAV_TRY(flush_chunk());
  std::string de;
  put_le<std::uint32_t>(de, 0);  // data section CRC: 0 = not computed (allowed by the spec)
  VISNAV_TRY(put(record(kDataEnd, de)));

  // Summary: groups of one opcode each, with a Summary Offset per group.
  const std::uint64_t summary_start = offset_;
  std::string summary;
  std::string offsets;
  auto group = [&](std::uint8_t op, const std::string& records) {
    if (records.empty()) return;
    put_le<std::uint8_t>(offsets, op);
    put_le<std::uint64_t>(offsets, summary_start + summary.size());
    put_le<std::uint64_t>(offsets, records.size());
    summary += records;
  };
  std::string schemas, channels;
  for (const auto& s : schemas_) schemas += schema_record(s);
  for (const auto& ch : channels_) channels += channel_record(ch);
  std::string st;
  put_le<std::uint64_t>(st, message_count_);
  put_le<std::uint16_t>(st, static_cast<std::uint16_t>(schemas_.size()));
  put_le<std::uint32_t>(st, static_cast<std::uint32_t>(channels_.size()));
  put_le<std::uint32_t>(st, attachment_count_);
  put_le<std::uint32_t>(st, 0);  // metadata
  put_le<std::uint32_t>(st, chunk_count_);
  put_le<std::uint64_t>(st, start_ns_);
  put_le<std::uint64_t>(st, end_ns_);
  std::string counts;
  for (const auto& [ch, n] : channel_counts_) {
    put_le<std::uint16_t>(counts, ch);
    put_le<std::uint64_t>(counts, n);
  }
  put_str(st, counts);
  group(kSchema, schemas);
  group(kChannel, channels);
  group(kStatistics, record(kStatistics, st));
  group(kChunkIndex, chunk_indexes_);
  group(kAttachmentIndex, attachment_indexes_);
  std::string offset_records;
  for (std::size_t i = 0; i < offsets.size(); i += 17) offset_records += record(kSummaryOffset, offsets.substr(i, 17));
  const std::uint64_t summary_offset_start = summary_start + summary.size();
  // Footer: its summary CRC covers the summary, the summary offsets and the footer up to and
  // including summary_offset_start.
  std::string footer_head;
  footer_head.push_back(static_cast<char>(kFooter));
  put_le<std::uint64_t>(footer_head, 20);
  put_le<std::uint64_t>(footer_head, summary.empty() ? 0 : summary_start);
  put_le<std::uint64_t>(footer_head, offset_records.empty() ? 0 : summary_offset_start);
  std::string tail = summary + offset_records + footer_head;
  const std::uint32_t crc = crc32(tail.data(), tail.size());
  put_le<std::uint32_t>(tail, crc);
  tail.append(kMagic, sizeof kMagic);
  VISNAV_TRY(put(tail));
  out_.close();
  if (!out_) return fail(ErrorCode::io, {path_}, "close failed");
  return ok();
}

// ---- Reader ------------------------------------------------------------------------------

namespace {

struct ScanState {
  const std::string& path;
  const ReadHandlers& handlers;
  std::map<std::uint16_t, Schema> schemas;
  std::map<std::uint16_t, Channel> channels;
  ReadReport report;
};

std::string at(const std::string& path, std::uint64_t offset) { return path + ": byte " + std::to_string(offset) + ": "; }

/// A damaged or unreadable record at byte `offset` of `path` (parse_error, located at the file).
Error damaged(const std::string& path, std::uint64_t offset, const std::string& what,
              ErrorCode code = ErrorCode::parse_error) {
  return Error{at(path, offset) + what, code, {path}};
}

Status parse_record(ScanState& st, std::uint8_t op, Cursor c, std::uint64_t offset);

Status parse_records(ScanState& st, const std::uint8_t* data, std::size_t size, std::uint64_t base_offset) {
  Cursor c(data, size);
  while (c.left() > 0) {
    const std::uint64_t rec_offset = base_offset + c.pos();
    std::uint8_t op = 0;
    std::uint64_t len = 0;
    if (!c.get(op) || !c.get(len) || c.left() < len)
      return damaged(st.path, rec_offset, "chunk record runs past the end of its chunk");
    VISNAV_TRY(parse_record(st, op, Cursor(c.here(), len), rec_offset));
    c.skip(len);
  }
  return ok();
}

Status parse_record(ScanState& st, std::uint8_t op, Cursor c, std::uint64_t offset) {
  switch (op) {
    case kSchema: {
      Schema s;
      if (!c.get(s.id) || !c.str(s.name) || !c.str(s.encoding) || !c.str(s.data))
        return damaged(st.path, offset, "bad Schema record");
      st.schemas[s.id] = std::move(s);
      return ok();
    }
    case kChannel: {
      Channel ch;
      std::string map;
      if (!c.get(ch.id) || !c.get(ch.schema_id) || !c.str(ch.topic) || !c.str(ch.message_encoding) || !c.str(map))
        return damaged(st.path, offset, "bad Channel record");
      Cursor m(reinterpret_cast<const std::uint8_t*>(map.data()), map.size());
      while (m.left() > 0) {
        std::string k, v;
        if (!m.str(k) || !m.str(v)) return damaged(st.path, offset, "bad Channel metadata");
        ch.metadata.emplace_back(std::move(k), std::move(v));
      }
      st.channels[ch.id] = std::move(ch);
      return ok();
    }
    case kMessage: {
      Message m;
      if (!c.get(m.channel_id) || !c.get(m.sequence) || !c.get(m.log_time_ns) || !c.get(m.publish_time_ns))
        return damaged(st.path, offset, "bad Message record");
      m.data.assign(c.here(), c.here() + c.left());
      auto ch = st.channels.find(m.channel_id);
      if (ch == st.channels.end())
        return damaged(st.path, offset, "message on channel " + std::to_string(m.channel_id) + " before its Channel record");
      const Schema* schema = nullptr;
      if (auto s = st.schemas.find(ch->second.schema_id); s != st.schemas.end()) schema = &s->second;
      ++st.report.messages;
      if (st.handlers.on_message) return st.handlers.on_message(ch->second, schema, m);
      return ok();
    }
    case kChunk: {
      std::uint64_t t0 = 0, t1 = 0, uncompressed_size = 0;
      std::uint32_t crc = 0;
      std::string compression, records;
      if (!c.get(t0) || !c.get(t1) || !c.get(uncompressed_size) || !c.get(crc) || !c.str(compression) ||
          !c.bytes64(records))
        return damaged(st.path, offset, "bad Chunk record");
      std::string plain;
      if (compression.empty()) {
        plain = std::move(records);
      } else if (compression == "zstd") {
#ifdef VISNAV_HAVE_ZSTD
        if (uncompressed_size > (std::uint64_t{1} << 34)) return damaged(st.path, offset, "chunk too large");
        plain.resize(uncompressed_size);
        const std::size_t n = ZSTD_decompress(plain.data(), plain.size(), records.data(), records.size());
        if (ZSTD_isError(n) != 0U || n != uncompressed_size)
          return damaged(st.path, offset, "zstd chunk does not decompress to its size");
#else
        return damaged(st.path, offset, "zstd chunk, but visnav was built without libzstd (install libzstd-dev)");
#endif
      } else if (compression == "lz4") {
        if (uncompressed_size > (std::uint64_t{1} << 34)) return damaged(st.path, offset, "chunk too large");
        auto p = lz4_decompress(records, uncompressed_size);
        if (!p) return damaged(st.path, offset, p.error().message, p.error().with_default_code(ErrorCode::parse_error).code);
        plain = std::move(*p);
      } else {
        return damaged(st.path, offset,
                       "chunk compression '" + compression +
                           "' is not supported (visnav reads none, zstd and lz4; convert with `mcap convert --compression zstd`)",
                       ErrorCode::out_of_range);
      }
      if (crc != 0 && crc32(plain.data(), plain.size()) != crc)
        return damaged(st.path, offset, "chunk CRC mismatch (damaged file)");
      return parse_records(st, reinterpret_cast<const std::uint8_t*>(plain.data()), plain.size(), offset);
    }
    case kAttachment: {
      Attachment a;
      if (!c.get(a.log_time_ns) || !c.get(a.create_time_ns) || !c.str(a.name) || !c.str(a.media_type) ||
          !c.bytes64(a.data))
        return damaged(st.path, offset, "bad Attachment record");
      if (st.handlers.on_attachment) return st.handlers.on_attachment(a);
      return ok();
    }
    default:
      return ok();  // indexes, statistics, metadata: not needed for a linear read
  }
}

}  // namespace

Result<ReadReport> read_file(const std::string& path, const ReadHandlers& handlers) {
  // Streamed record by record, so any size is fine; a device or a pipe is not a recording.
  VISNAV_TRY(check_input_file(path, UINT64_MAX, "MCAP"));
  std::ifstream in(path, std::ios::binary);
  if (!in) return fail(ErrorCode::io, {path}, "cannot open");
  char magic[8];
  if (!in.read(magic, 8) || std::memcmp(magic, kMagic, 8) != 0)
    return fail(ErrorCode::parse_error, {path}, "not an MCAP file (bad magic; a ROS 2 bag folder holds the .mcap file inside)");
  ScanState st{path, handlers, {}, {}, {}};
  std::uint64_t offset = 8;
  std::vector<std::uint8_t> content;
  for (;;) {
    std::uint8_t head[9];
    if (!in.read(reinterpret_cast<char*>(head), 9)) {
      st.report.truncated = true;  // no DataEnd/Footer: cut short (crash while recording)
      break;
    }
    std::uint64_t len = 0;
    for (int i = 0; i < 8; ++i) len |= static_cast<std::uint64_t>(head[1 + i]) << (8 * i);
    if (len > (std::uint64_t{1} << 36)) return damaged(path, offset, "record length " + std::to_string(len) + " is implausible");
    content.resize(len);
    if (!in.read(reinterpret_cast<char*>(content.data()), static_cast<std::streamsize>(len))) {
      st.report.truncated = true;
      break;
    }
    if (head[0] == kHeader) {
      Cursor c(content.data(), content.size());
      if (!c.str(st.report.profile)) return damaged(path, offset, "bad Header record");
    } else if (head[0] == kDataEnd || head[0] == kFooter) {
      break;
    } else {
      VISNAV_TRY(parse_record(st, head[0], Cursor(content.data(), content.size()), offset));
    }
    offset += 9 + len;
  }
  return st.report;
}

}  // namespace visnav::mcap
