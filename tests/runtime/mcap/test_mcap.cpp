// MCAP writer/reader and ROS 2 CDR (visnav/mcap.hpp): round trips through chunks (zstd and
// uncompressed), a file cut short, a damaged chunk, and CDR layouts checked byte for byte where
// the alignment rules matter.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "error_expect.hpp"
#include "visnav/mcap.hpp"

namespace fs = std::filesystem;
using namespace visnav;

namespace {

fs::path temp_file(const std::string& name) {
  return fs::temp_directory_path() / ("visnav_mcap_" + std::to_string(::getpid()) + "_" + name);
}

struct Seen {
  std::vector<std::string> topics;
  std::vector<mcap::Message> messages;
  std::vector<std::string> schemas;
  std::vector<mcap::Attachment> attachments;
};

Result<mcap::ReadReport> read_all(const fs::path& p, Seen& seen) {
  mcap::ReadHandlers h;
  h.on_message = [&](const mcap::Channel& ch, const mcap::Schema* s, const mcap::Message& m) -> Status {
    seen.topics.push_back(ch.topic);
    seen.schemas.push_back(s != nullptr ? s->name : "");
    seen.messages.push_back(m);
    return ok();
  };
  h.on_attachment = [&](const mcap::Attachment& a) -> Status {
    seen.attachments.push_back(a);
    return ok();
  };
  return mcap::read_file(p.string(), h);
}

void write_sample(const fs::path& p, bool compress, std::size_t chunk_bytes, int count, const std::string& compression = "zstd") {
  mcap::WriterOptions o;
  o.compress = compress;
  o.compression = compression;
  o.chunk_size_bytes = chunk_bytes;
  auto w = mcap::Writer::create(p.string(), o);
  ASSERT_TRUE(w.ok()) << w.error().message;
  const auto twist = (*w)->add_schema("geometry_msgs/msg/Twist", "ros2msg", ros2::schema_text("geometry_msgs/msg/Twist"));
  const auto cmd = (*w)->add_channel(twist, "/cmd_vel", "cdr");
  const auto json = (*w)->add_channel(0, "/visnav/tick", "json");
  for (int i = 0; i < count; ++i) {
    dds::msg::Twist t;
    t.linear.x = 0.1 * i;
    t.angular.z = -0.01 * i;
    mcap::Message m{cmd, static_cast<std::uint32_t>(i), 1000000ULL * static_cast<std::uint64_t>(i), 0, ros2::encode(t)};
    ASSERT_TRUE((*w)->write(m).ok());
    const std::string j = "{\"tick\":" + std::to_string(i) + "}";
    ASSERT_TRUE((*w)->write({json, 0, m.log_time_ns, 0, std::vector<std::uint8_t>(j.begin(), j.end())}).ok());
  }
  ASSERT_TRUE((*w)->write_attachment({5, 6, "run.yaml", "application/yaml", "format: x\n"}).ok());
  ASSERT_TRUE((*w)->close().ok());
}

using visnav::test::At;
using visnav::test::fails_with;
using visnav::test::key_only;

TEST(Mcap, RoundTripThroughManyChunksCompressedAndNot) {
  for (bool compress : {false, true}) {
    SCOPED_TRACE(compress ? "zstd" : "uncompressed");
    const fs::path p = temp_file(compress ? "z.mcap" : "u.mcap");
    write_sample(p, compress, 200, 100);  // ~8 messages per chunk
    Seen seen;
    auto r = read_all(p, seen);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_FALSE(r->truncated);
    EXPECT_EQ(r->profile, "ros2");
    ASSERT_EQ(seen.messages.size(), 200U);
    for (int i = 0; i < 100; ++i) {
      EXPECT_EQ(seen.topics[2 * i], "/cmd_vel");
      EXPECT_EQ(seen.schemas[2 * i], "geometry_msgs/msg/Twist");
      EXPECT_EQ(seen.topics[2 * i + 1], "/visnav/tick");
      auto t = ros2::decode_twist(seen.messages[2 * i].data);
      ASSERT_TRUE(t.ok());
      EXPECT_DOUBLE_EQ(t->linear.x, 0.1 * i);
      EXPECT_DOUBLE_EQ(t->angular.z, -0.01 * i);
      EXPECT_EQ(seen.messages[2 * i].log_time_ns, 1000000ULL * static_cast<std::uint64_t>(i));
    }
    ASSERT_EQ(seen.attachments.size(), 1U);
    EXPECT_EQ(seen.attachments[0].data, "format: x\n");
    fs::remove(p);
  }
}

/// The compression field of the first Chunk record (opcode 0x06) of a file.
std::string first_chunk_compression(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  const std::string b((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::size_t pos = 8;  // magic
  while (pos + 9 <= b.size()) {
    const auto op = static_cast<std::uint8_t>(b[pos]);
    std::uint64_t len = 0;
    std::memcpy(&len, b.data() + pos + 1, 8);
    if (op == 0x06) {
      std::uint32_t n = 0;  // after start, end, uncompressed size (u64 each) and crc (u32)
      std::memcpy(&n, b.data() + pos + 9 + 28, 4);
      return b.substr(pos + 9 + 32, n);
    }
    pos += 9 + len;
  }
  return "?";
}

TEST(Mcap, Lz4ChunksRoundTripAndAreMarkedLz4) {
  if (!mcap::lz4_available()) GTEST_SKIP() << "built without liblz4 (liblz4-dev)";
  const fs::path p = temp_file("l.mcap");
  write_sample(p, true, 200, 100, "lz4");
  EXPECT_EQ(first_chunk_compression(p), "lz4");
  Seen seen;
  auto r = read_all(p, seen);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(seen.messages.size(), 200U);
  for (int i = 0; i < 100; i += 33) {
    auto t = ros2::decode_twist(seen.messages[2 * i].data);
    ASSERT_TRUE(t.ok());
    EXPECT_DOUBLE_EQ(t->linear.x, 0.1 * i);
  }
  // A damaged lz4 payload is an error naming the file, not a crash.
  {
    std::fstream f(p, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(200);
    const char junk[16] = {'\x7f', '\x7f', '\x7f', '\x7f', '\x7f', '\x7f', '\x7f', '\x7f',
                           '\x7f', '\x7f', '\x7f', '\x7f', '\x7f', '\x7f', '\x7f', '\x7f'};
    f.write(junk, sizeof junk);
  }
  Seen bad;
  r = read_all(p, bad);
  EXPECT_TRUE(fails_with(r, ErrorCode::parse_error, At{p.string()}));
  fs::remove(p);
}

TEST(Mcap, UnknownCompressionIsRefusedWithItsCode) {
  mcap::WriterOptions o;
  o.compression = "brotli";
  auto w = mcap::Writer::create(temp_file("x.mcap").string(), o);
  ASSERT_FALSE(w.ok());
  EXPECT_EQ(w.error().code, ErrorCode::out_of_range);
}

TEST(Mcap, TelemetryIsRecordedAsRos2CdrAndExactJsonAndConvertsBothWays) {
  const fs::path bag = temp_file("t.mcap"), folder = temp_file("t_run"), again = temp_file("t2.mcap");
  NavStatus s;
  s.node_path = "Root/Replay \"x\"";
  s.map_node = "n1";
  s.edge = "e1";
  s.distance_m = 1.0 / 3.0;
  s.matches = 42;
  s.inliers = 17;
  s.offset_px = -12.25;
  s.command = {0.4, -0.0123456789012345};
  s.confidence = 0.875;
  s.blind_m = 0.3;
  s.status = "steering, ok\tnow";
  {
    auto w = mcap::RunMcapWriter::create(bag.string(), false);
    ASSERT_TRUE(w.ok()) << w.error().message;
    const std::vector<std::uint8_t> png = {0x89, 'P', 'N', 'G'};
    ASSERT_TRUE((*w)->telemetry(0.1, s).ok());
    ASSERT_TRUE((*w)->frame(0, 0.1, 7, png, "png").ok());
    Odometry o;
    o.timestamp_s = 0.1;
    ASSERT_TRUE((*w)->odometry(o).ok());
    ASSERT_TRUE((*w)->tick(1, 0.1, 0, s.command, 1).ok());
    ASSERT_TRUE((*w)->attach("run.yaml", "format: visnav-recorded-run\n", 0.1).ok());
    ASSERT_TRUE((*w)->close().ok());
  }
  Seen seen;
  ASSERT_TRUE(read_all(bag, seen).ok());
  bool cdr = false;
  for (std::size_t i = 0; i < seen.messages.size(); ++i) {
    if (seen.topics[i] != "/visnav/telemetry") continue;
    cdr = true;
    EXPECT_EQ(seen.schemas[i], "visnav/msg/Telemetry");
    auto t = ros2::decode_telemetry(seen.messages[i].data);
    ASSERT_TRUE(t.ok()) << t.error().message;
    EXPECT_EQ(t->edge, "e1");
    EXPECT_EQ(t->matches, 42);
    EXPECT_DOUBLE_EQ(t->angular_radps, s.command.angular_radps);
    EXPECT_EQ(t->status, s.status);
  }
  EXPECT_TRUE(cdr);
  // MCAP -> folder (telemetry.jsonl) -> MCAP: every field exact, and the bag byte-identical.
  auto r = mcap::mcap_to_run_folder(bag.string(), folder.string());
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->telemetry, 1);
  std::ifstream lines(folder / "telemetry.jsonl");
  std::string line;
  ASSERT_TRUE(static_cast<bool>(std::getline(lines, line)));
  auto parsed = mcap::parse_telemetry_json(line);
  ASSERT_TRUE(parsed.ok()) << parsed.error().message;
  EXPECT_EQ(parsed->first, 0.1);
  EXPECT_EQ(parsed->second.node_path, s.node_path);
  EXPECT_EQ(parsed->second.status, s.status);
  EXPECT_EQ(parsed->second.distance_m, s.distance_m);
  EXPECT_EQ(parsed->second.command.angular_radps, s.command.angular_radps);
  EXPECT_EQ(parsed->second.confidence, 0.875);
  EXPECT_EQ(parsed->second.blind_m, 0.3);
  EXPECT_EQ(parsed->second.inliers, 17);
  auto back = mcap::run_folder_to_mcap(folder.string(), again.string());
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->telemetry, 1);
  std::ifstream a(bag, std::ios::binary), b(again, std::ios::binary);
  const std::string ba((std::istreambuf_iterator<char>(a)), std::istreambuf_iterator<char>());
  const std::string bb((std::istreambuf_iterator<char>(b)), std::istreambuf_iterator<char>());
  EXPECT_EQ(ba, bb);
  // A broken line in the middle is an error naming file:line; a cut last line is dropped.
  std::ofstream(folder / "telemetry.jsonl") << line << "\n{\"t_s\":0.2,\"edge\":\"e1\n" << line << "\n";
  back = mcap::run_folder_to_mcap(folder.string(), again.string());
  ASSERT_FALSE(back.ok());
  EXPECT_TRUE(fails_with(back, ErrorCode::parse_error, At{"telemetry.jsonl", 2}));
  std::ofstream(folder / "telemetry.jsonl") << line << "\n{\"t_s\":0.2,\"ed";
  back = mcap::run_folder_to_mcap(folder.string(), again.string());
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->telemetry, 1);
  fs::remove(bag);
  fs::remove(again);
  fs::remove_all(folder);
}

TEST(Mcap, FileCutShortReadsUpToItsLastCompleteChunk) {
  const fs::path p = temp_file("cut.mcap");
  write_sample(p, true, 200, 100);
  const auto size = fs::file_size(p);
  fs::resize_file(p, size / 2);
  Seen seen;
  auto r = read_all(p, seen);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_TRUE(r->truncated);
  EXPECT_GT(seen.messages.size(), 20U);
  EXPECT_LT(seen.messages.size(), 200U);
  fs::remove(p);
}

TEST(Mcap, DamagedChunkAndForeignFileAreErrorsNamingTheFile) {
  const fs::path p = temp_file("bad.mcap");
  write_sample(p, false, 1 << 20, 10);  // one uncompressed chunk: flip a byte of a message
  {
    std::fstream f(p, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(400);
    char c = 0;
    f.read(&c, 1);
    f.seekp(400);
    c = static_cast<char>(c ^ 0x5A);
    f.write(&c, 1);
  }
  Seen seen;
  auto r = read_all(p, seen);
  EXPECT_TRUE(fails_with(r, ErrorCode::parse_error, At{p.string()}));
  std::ofstream(p) << "not an mcap file";
  r = read_all(p, seen);
  EXPECT_TRUE(fails_with(r, ErrorCode::parse_error, At{p.string()}));
  fs::remove(p);
}

TEST(Mcap, Crc32IsTheIeeeCrc) {
  const std::string s = "123456789";
  EXPECT_EQ(mcap::crc32(s.data(), s.size()), 0xCBF43926U);
}

TEST(Ros2Cdr, TwistIsFortyEightBytesAfterTheHeader) {
  dds::msg::Twist t;
  t.linear.x = 1.5;
  auto b = ros2::encode(t);
  ASSERT_EQ(b.size(), 52U);
  EXPECT_EQ(b[0], 0x00);
  EXPECT_EQ(b[1], 0x01);
  double x = 0;
  std::memcpy(&x, b.data() + 4, 8);
  EXPECT_EQ(x, 1.5);
}

TEST(Ros2Cdr, OdometryAlignsDoublesAfterTheStrings) {
  dds::msg::Odometry o;
  o.header.stamp = {12, 345};
  o.header.frame_id = "odom";        // 4 + 4 + (4 + 5) = 17 bytes
  o.child_frame_id = "base_link";    // pad to 20, 4 + 10 = 34 bytes
  o.pose.pose.position.x = 2.0;      // pad to 40
  o.pose.pose.orientation = dds::quaternion_from_yaw(0.5);
  o.twist.twist.angular.z = -0.25;
  o.pose.covariance[35] = 9.0;
  auto b = ros2::encode(o);
  double x = 0;
  std::memcpy(&x, b.data() + 4 + 40, 8);
  EXPECT_EQ(x, 2.0);
  EXPECT_EQ(b.size(), 4U + 40 + 7 * 8 + 36 * 8 + 6 * 8 + 36 * 8);
  auto back = ros2::decode_odometry(b);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->header.frame_id, "odom");
  EXPECT_EQ(back->child_frame_id, "base_link");
  EXPECT_EQ(back->header.stamp.nanosec, 345U);
  EXPECT_NEAR(dds::yaw_from_quaternion(back->pose.pose.orientation), 0.5, 1e-12);
  EXPECT_EQ(back->twist.twist.angular.z, -0.25);
  EXPECT_EQ(back->pose.covariance[35], 9.0);
  b.resize(b.size() - 3);
  auto cut = ros2::decode_odometry(b);
  EXPECT_TRUE(fails_with(cut, ErrorCode::parse_error, key_only("twist.covariance")));
}

TEST(Ros2Cdr, ImagesAndTelemetryRoundTrip) {
  dds::msg::Image im;
  im.header.frame_id = "camera";
  im.width = 3;
  im.height = 2;
  im.encoding = "mono8";
  im.step = 3;
  im.data = {1, 2, 3, 4, 5, 6};
  auto i2 = ros2::decode_image(ros2::encode(im));
  ASSERT_TRUE(i2.ok());
  EXPECT_EQ(i2->data, im.data);
  EXPECT_EQ(i2->encoding, "mono8");
  EXPECT_EQ(i2->step, 3U);
  dds::msg::CompressedImage c;
  c.format = "png";
  c.data = {9, 8, 7};
  auto c2 = ros2::decode_compressed_image(ros2::encode(c));
  ASSERT_TRUE(c2.ok());
  EXPECT_EQ(c2->format, "png");
  EXPECT_EQ(c2->data, c.data);
  dds::msg::Telemetry t;
  t.edge = "e3";
  t.matches = 41;
  t.offset_px = -3.5;
  t.status = "running";
  auto t2 = ros2::decode_telemetry(ros2::encode(t));
  ASSERT_TRUE(t2.ok());
  EXPECT_EQ(t2->edge, "e3");
  EXPECT_EQ(t2->matches, 41);
  EXPECT_EQ(t2->offset_px, -3.5);
  EXPECT_EQ(t2->status, "running");
  for (const char* type : {"sensor_msgs/msg/Image", "sensor_msgs/msg/CompressedImage", "nav_msgs/msg/Odometry",
                           "geometry_msgs/msg/Twist", "visnav/msg/Telemetry"})
    EXPECT_FALSE(ros2::schema_text(type).empty()) << type;
}

}  // namespace

namespace {

TEST(Mcap, GamepadPrimitivePressesInABagBecomeMarks) {
  const fs::path p = temp_file("joy.mcap");
  {
    auto w = mcap::Writer::create(p.string());
    ASSERT_TRUE(w.ok());
    const auto s = (*w)->add_schema("sensor_msgs/msg/Joy", "ros2msg", ros2::schema_text("sensor_msgs/msg/Joy"));
    const auto ch = (*w)->add_channel(s, "/joy", "cdr");
    // (time s, buttons held): X (2) pressed at 1 s and held, A (0) at 3 s, B (1) at 4 s.
    const std::vector<std::pair<double, std::vector<std::int32_t>>> states{
        {0.5, {0, 0, 0}}, {1.0, {0, 0, 1}}, {1.5, {0, 0, 1}}, {3.0, {1, 0, 0}}, {4.0, {0, 1, 0}}};
    for (const auto& [t, buttons] : states) {
      dds::msg::Joy j;
      j.axes = {0.0F, 0.5F};
      j.buttons = buttons;
      const auto ns = static_cast<std::uint64_t>(t * 1e9);
      ASSERT_TRUE((*w)->write({ch, 0, ns, ns, ros2::encode(j)}).ok());
    }
    ASSERT_TRUE((*w)->close().ok());
  }
  auto marks = mcap::joy_marks(p.string(), "/joy", {{0, "feature_segment"}, {2, "path_following"}, {1, ""}});
  ASSERT_TRUE(marks.ok()) << marks.error().message;
  ASSERT_EQ(marks->size(), 3U);
  EXPECT_DOUBLE_EQ((*marks)[0].first, 1.0);
  EXPECT_EQ((*marks)[0].second, "path_following");
  EXPECT_EQ((*marks)[1].second, "feature_segment");
  EXPECT_DOUBLE_EQ((*marks)[2].first, 4.0);
  EXPECT_EQ((*marks)[2].second, "");
  auto none = mcap::joy_marks(p.string(), "/other", {{0, "feature_segment"}});
  EXPECT_TRUE(fails_with(none, ErrorCode::not_found, key_only("/other")));
  dds::msg::Joy j;
  j.axes = {0.25F, -1.0F};
  j.buttons = {1, 0, 1};
  auto back = ros2::decode_joy(ros2::encode(j));
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(back->axes, j.axes);
  EXPECT_EQ(back->buttons, j.buttons);
  fs::remove(p);
}

}  // namespace
