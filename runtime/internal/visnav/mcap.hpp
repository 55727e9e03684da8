// visnav SDK — MCAP files (https://mcap.dev/spec, format version 0) and ROS 2 CDR messages, so
// recordings open in `ros2 bag`, Foxglove and every MCAP tool, and bags recorded on a ROS 2 robot
// play back here. Written from the public specification; no MCAP library is used.
//
// Writer: Header (profile "ros2"), Schema/Channel records, Messages in Chunks (zstd- or
// lz4-compressed when the runtime was built with libzstd / liblz4, else uncompressed) each followed by its Message Index
// records; Attachments; DataEnd; a Summary section (Schemas, Channels, Statistics, Chunk Indexes,
// Attachment Indexes), Summary Offsets, Footer with the summary CRC. Chunk CRCs are CRC-32
// (IEEE) of the uncompressed records.
// Reader: a linear scan of the data section — so a file cut short by a crash reads up to its
// last complete chunk — with chunks uncompressed or zstd (lz4 chunks are an error saying so),
// chunk CRCs checked when non-zero. Errors name the file and the byte offset.
//
// ROS 2 messages (namespace visnav::ros2): CDR little-endian with the 4-byte encapsulation
// header, as rmw writes it; schemas are "ros2msg" text (the .msg definitions with their
// dependencies), message encoding "cdr".
//
// Thread-safety: a Writer or Reader is used from one thread. Ownership: the Writer owns its
// file; close() (or the destructor) finishes it.
#pragma once

#include <cstdint>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "visnav/dds.hpp"
#include "visnav/dds_joy.hpp"
#include "visnav/host.hpp"
#include "visnav/result.hpp"
#include "visnav/types.hpp"

namespace visnav::mcap {

/// CRC-32 (IEEE 802.3, as zlib's crc32) of `size` bytes, continuing from `crc`.
[[nodiscard]] std::uint32_t crc32(const void* data, std::size_t size, std::uint32_t crc = 0);

/// True when chunks can be written and read zstd-compressed (runtime built with libzstd).
[[nodiscard]] bool zstd_available();
/// True when chunks can be written and read lz4-compressed (runtime built with liblz4).
[[nodiscard]] bool lz4_available();

struct Schema {
  std::uint16_t id = 0;
  std::string name;      ///< e.g. "sensor_msgs/msg/Image"
  std::string encoding;  ///< "ros2msg", "jsonschema", ...
  std::string data;      ///< the definition text
};

struct Channel {
  std::uint16_t id = 0;
  std::uint16_t schema_id = 0;  ///< 0 = no schema
  std::string topic;
  std::string message_encoding;  ///< "cdr", "json", ...
  std::vector<std::pair<std::string, std::string>> metadata;
};

struct Message {
  std::uint16_t channel_id = 0;
  std::uint32_t sequence = 0;
  std::uint64_t log_time_ns = 0;
  std::uint64_t publish_time_ns = 0;
  std::vector<std::uint8_t> data;
};

struct Attachment {
  std::uint64_t log_time_ns = 0;
  std::uint64_t create_time_ns = 0;
  std::string name;
  std::string media_type;
  std::string data;
};

struct WriterOptions {
  std::string profile = "ros2";
  std::string library = "visnav";
  bool compress = true;                          ///< compress chunks with `compression` when available
  std::string compression = "zstd";              ///< "zstd" or "lz4" (validated by Writer::create)
  std::size_t chunk_size_bytes = 4 * 1024 * 1024;  ///< a chunk is closed once its records exceed this
};

class Writer {
 public:
  /// Creates (truncates) `path` and writes the magic and the Header.
  [[nodiscard]] static Result<std::unique_ptr<Writer>> create(const std::string& path, WriterOptions options = {});
  ~Writer();
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;

  /// Registers a schema / channel; returns its id (1, 2, ...).
  std::uint16_t add_schema(const std::string& name, const std::string& encoding, const std::string& data);
  std::uint16_t add_channel(std::uint16_t schema_id, const std::string& topic, const std::string& message_encoding,
                            std::vector<std::pair<std::string, std::string>> metadata = {});
  /// Appends a message to the open chunk (its channel must exist); writes the chunk when full.
  Status write(const Message& message);
  Status write_attachment(const Attachment& attachment);
  /// Writes the last chunk, DataEnd, summary, footer and closing magic. Idempotent.
  Status close();
  [[nodiscard]] std::uint64_t message_count() const { return message_count_; }

 private:
  Writer() = default;
  Status flush_chunk();
  Status put(const std::string& bytes);

  std::string path_;
  WriterOptions options_;
  std::ofstream out_;
  std::uint64_t offset_ = 0;
  bool closed_ = false;
  std::vector<Schema> schemas_;
  std::vector<Channel> channels_;
  // The open chunk.
  std::string chunk_records_;
  std::uint64_t chunk_start_ns_ = 0, chunk_end_ns_ = 0;
  std::map<std::uint16_t, std::vector<std::pair<std::uint64_t, std::uint64_t>>> chunk_index_;  // channel -> (time, offset)
  std::vector<bool> chunk_has_schema_, chunk_has_channel_;
  // Summary.
  std::string chunk_indexes_;
  std::string attachment_indexes_;
  std::uint64_t message_count_ = 0, start_ns_ = 0, end_ns_ = 0;
  std::uint32_t chunk_count_ = 0, attachment_count_ = 0;
  std::map<std::uint16_t, std::uint64_t> channel_counts_;
};

/// Everything a linear scan sees, message by message (in file order).
struct ReadHandlers {
  /// Called for every message with its channel and the channel's schema (nullptr if none).
  std::function<Status(const Channel&, const Schema*, const Message&)> on_message;
  std::function<Status(const Attachment&)> on_attachment;  ///< optional
};

/// Reads `path` from start to DataEnd (or the last complete record). A file that ends early
/// (no footer) is read up to there and `truncated` is set; a bad magic, a record running past
/// the end inside a chunk, an unknown compression or a CRC mismatch is an error naming the file
/// and byte offset.
struct ReadReport {
  std::uint64_t messages = 0;
  bool truncated = false;
  std::string profile;
};
[[nodiscard]] Result<ReadReport> read_file(const std::string& path, const ReadHandlers& handlers);

// ------------------------------------------------------------------------------------------
// Recorded runs as MCAP (docs/recorded_runs.md, "MCAP"). Channels:
//   /camera/image_raw/compressed  sensor_msgs/msg/CompressedImage  the frame (png or jpeg bytes)
//   /odom                         nav_msgs/msg/Odometry            every odometry reading
//   /cmd_vel                      geometry_msgs/msg/Twist          the command in force after each tick
//   /visnav/ground_truth          nav_msgs/msg/Odometry            simulated robots only (world frame)
//   /visnav/telemetry             visnav/msg/Telemetry             each NavStatus of a mission (the DDS
//                                 telemetry type, so a bag of rt/visnav/telemetry reads the same)
//   /visnav/frame, /visnav/odometry, /visnav/tick, /visnav/truth, /visnav/status   JSON: the folder format's rows with exact
//                                 (17-digit) times and the odometric distance, so a conversion
//                                 back to a folder is exact
//   attachments run.yaml and config.yaml (the last run.yaml attached wins).
// Log times are the run clock in ns (simulated runs start near 0, i.e. 1970).
// ------------------------------------------------------------------------------------------
class RunMcapWriter {
 public:
  [[nodiscard]] static Result<std::unique_ptr<RunMcapWriter>> create(const std::string& path, bool with_truth,
                                                                     WriterOptions options = {});
  /// `encoded` is the image file's bytes; `format` "png" or "jpeg".
  Status frame(long index, double t_s, std::uint64_t sequence, const std::vector<std::uint8_t>& encoded,
               const std::string& format);
  Status odometry(const Odometry& o);
  Status tick(std::uint64_t tick, double t_s, long frame_index, const Twist& command, std::uint64_t commands_sent);
  Status truth(double t_s, const Pose2D& pose);
  /// One NavStatus published at run-clock time `t_s` (CDR on /visnav/telemetry, and every field
  /// including confidence and blind_m as JSON on /visnav/status).
  Status telemetry(double t_s, const NavStatus& status);
  Status attach(const std::string& name, const std::string& text, double t_s);
  Status close();

 private:
  RunMcapWriter() = default;
  std::unique_ptr<Writer> writer_;
  std::uint16_t image_ = 0, odom_ = 0, cmd_ = 0, truth_ = 0, frame_json_ = 0, odom_json_ = 0, tick_json_ = 0, truth_json_ = 0;
  std::uint16_t telemetry_ = 0, status_json_ = 0;
  std::uint32_t seq_ = 0;
  std::uint64_t telemetry_seq_ = 0;
};

/// Which topics of a bag hold what (a bag recorded by a ROS 2 robot names its own topics).
struct RunTopics {
  std::string image = "/camera/image_raw/compressed";  ///< sensor_msgs/msg/Image or CompressedImage
  std::string odometry = "/odom";                       ///< nav_msgs/msg/Odometry
  std::string command = "/cmd_vel";                     ///< geometry_msgs/msg/Twist (optional)
};

struct ConversionReport {
  long frames = 0;
  long odometry_samples = 0;
  long ticks = 0;
  long telemetry = 0;      ///< NavStatus messages (telemetry.jsonl rows)
  bool exact = false;      ///< the bag carried visnav's /visnav/* channels (a visnav recording)
  bool truncated = false;  ///< the bag ended early (a killed recording)
};

/// Writes the recorded-run folder `dir` (created; frames as PNG/JPEG files) from a bag. A visnav
/// recording converts exactly; a foreign bag takes frames from `topics.image` (Image: mono8,
/// bgr8, rgb8; CompressedImage: any OpenCV-readable format, kept as is), odometry from
/// `topics.odometry` (the odometric distance is the path length of the positions) and, for the
/// ticks, nothing (playback then steps frame by frame). Times are log times. Errors name the
/// topic that is missing and list the bag's topics.
[[nodiscard]] Result<ConversionReport> mcap_to_run_folder(const std::string& mcap_path, const std::string& dir,
                                                         const RunTopics& topics = {});
/// Primitive switches pressed on a gamepad during a recorded drive: the sensor_msgs/msg/Joy
/// messages on `joy_topic`, a button going from released to pressed that is bound in
/// `primitive_buttons` (button number -> edge kind, "" = turning) gives a mark (log time, kind).
/// `visnav teach --joy-topic` turns them into the marks file. Errors name the file and topic.
[[nodiscard]] Result<std::vector<std::pair<double, std::string>>> joy_marks(
    const std::string& mcap_path, const std::string& joy_topic, const std::vector<std::pair<int, std::string>>& primitive_buttons);

/// Writes a bag from a recorded-run folder (frames.csv, odometry.csv, commands.csv,
/// ground_truth.csv, telemetry.jsonl, run.yaml, config.yaml).
/// One telemetry.jsonl line (the folder format's telemetry: a flat JSON object with t_s and the
/// NavStatus fields, numbers with 17 digits) and back. parse errors name what is wrong.
[[nodiscard]] std::string telemetry_json(double t_s, const NavStatus& status);
[[nodiscard]] Result<std::pair<double, NavStatus>> parse_telemetry_json(std::string_view line);

[[nodiscard]] Result<ConversionReport> run_folder_to_mcap(const std::string& dir, const std::string& mcap_path,
                                                         WriterOptions options = {});

}  // namespace visnav::mcap

namespace visnav::ros2 {

/// ROS 2 schema (ros2msg text with dependencies) of the message types below, by name
/// ("sensor_msgs/msg/Image"); empty for an unknown name.
[[nodiscard]] std::string schema_text(std::string_view type_name);

/// CDR (little-endian, with encapsulation header) of the ROS 2 messages visnav records.
[[nodiscard]] std::vector<std::uint8_t> encode(const dds::msg::Image& m);
[[nodiscard]] std::vector<std::uint8_t> encode(const dds::msg::CompressedImage& m);
[[nodiscard]] std::vector<std::uint8_t> encode(const dds::msg::Odometry& m);
[[nodiscard]] std::vector<std::uint8_t> encode(const dds::msg::Twist& m);
[[nodiscard]] std::vector<std::uint8_t> encode(const dds::msg::Telemetry& m);
[[nodiscard]] std::vector<std::uint8_t> encode(const dds::msg::Joy& m);
/// Decoders: errors say which field ran past the end (truncated or not this type).
[[nodiscard]] Result<dds::msg::Image> decode_image(const std::vector<std::uint8_t>& cdr);
[[nodiscard]] Result<dds::msg::CompressedImage> decode_compressed_image(const std::vector<std::uint8_t>& cdr);
[[nodiscard]] Result<dds::msg::Odometry> decode_odometry(const std::vector<std::uint8_t>& cdr);
[[nodiscard]] Result<dds::msg::Twist> decode_twist(const std::vector<std::uint8_t>& cdr);
[[nodiscard]] Result<dds::msg::Telemetry> decode_telemetry(const std::vector<std::uint8_t>& cdr);
[[nodiscard]] Result<dds::msg::Joy> decode_joy(const std::vector<std::uint8_t>& cdr);

}  // namespace visnav::ros2
