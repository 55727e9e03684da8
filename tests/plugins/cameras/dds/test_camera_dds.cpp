// The `dds` camera: decoding raw and compressed images, and dropping bad input.
#include <gtest/gtest.h>

#include <mutex>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "dds_test_util.hpp"
#include "image_decoder.hpp"
#include "visnav/config.hpp"
#include "visnav/dds.hpp"
#include "visnav/loader.hpp"
#include "visnav/runtime_host.hpp"

namespace dds = visnav::dds;
using dds::testing::eventually;
using visnav::camera_dds::DropReason;
using visnav::camera_dds::ImageDecoder;

namespace {

cv::Mat test_pattern(int rows, int cols) {
  cv::Mat bgr(rows, cols, CV_8UC3);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) bgr.at<cv::Vec3b>(r, c) = cv::Vec3b(uchar(c * 3), uchar(r * 5), uchar((r + c) & 0xff));
  return bgr;
}

dds::msg::Image raw(const cv::Mat& image, const std::string& encoding = "") {
  dds::msg::Image m;
  EXPECT_TRUE(dds::fill_image_message(image, m).ok());
  if (!encoding.empty()) m.encoding = encoding;
  return m;
}

dds::msg::CompressedImage compressed(const cv::Mat& image, const std::string& ext, const std::string& format) {
  dds::msg::CompressedImage m;
  m.format = format;
  std::vector<uchar> buf;
  EXPECT_TRUE(cv::imencode(ext, image, buf));
  m.data.assign(buf.begin(), buf.end());
  return m;
}

double max_abs_diff(const cv::Mat& a, const cv::Mat& b) {
  double mx = 0;
  cv::Mat d;
  cv::absdiff(a, b, d);
  cv::minMaxLoc(d.reshape(1), nullptr, &mx);
  return mx;
}

// ---- core ------------------------------------------------------------------------------------

TEST(ImageDecoder, DecodesRawEncodings) {
  ImageDecoder decoder;
  const cv::Mat bgr = test_pattern(48, 64);
  auto b = decoder.decode(raw(bgr));
  ASSERT_TRUE(b.has_value());
  EXPECT_EQ(b->type(), CV_8UC3);
  EXPECT_EQ(max_abs_diff(*b, bgr), 0.0);

  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  auto r = decoder.decode(raw(rgb, "rgb8"));
  ASSERT_TRUE(r.has_value());
  EXPECT_EQ(max_abs_diff(*r, bgr), 0.0);  // converted back to BGR

  cv::Mat grey;
  cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  auto g = decoder.decode(raw(grey));
  ASSERT_TRUE(g.has_value());
  EXPECT_EQ(g->type(), CV_8UC1);
  EXPECT_EQ(max_abs_diff(*g, grey), 0.0);
  EXPECT_EQ(decoder.counts().total(), 0u);
}

TEST(ImageDecoder, HonoursPaddedRowsAndCopiesOutOfTheSample) {
  ImageDecoder decoder;
  const cv::Mat bgr = test_pattern(10, 7);
  dds::msg::Image m = raw(bgr);
  // Re-pack with 4 bytes of padding per row.
  const std::uint32_t step = m.step + 4;
  std::vector<std::uint8_t> padded(static_cast<std::size_t>(step) * m.height, 0xAB);
  for (std::uint32_t r = 0; r < m.height; ++r)
    std::copy_n(m.data.begin() + r * m.step, m.step, padded.begin() + r * step);
  m.step = step;
  m.data = padded;
  auto out = decoder.decode(m);
  ASSERT_TRUE(out.has_value());
  EXPECT_TRUE(out->isContinuous());
  EXPECT_EQ(max_abs_diff(*out, bgr), 0.0);
  std::fill(m.data.begin(), m.data.end(), 0);  // the frame owns its pixels
  EXPECT_EQ(max_abs_diff(*out, bgr), 0.0);
}

TEST(ImageDecoder, DecodesJpegAndPng) {
  ImageDecoder decoder;
  const cv::Mat bgr = test_pattern(120, 160);
  auto png = decoder.decode(compressed(bgr, ".png", "png"));
  ASSERT_TRUE(png.has_value());
  EXPECT_EQ(max_abs_diff(*png, bgr), 0.0);
  auto jpg = decoder.decode(compressed(bgr, ".jpg", "bgr8; jpeg compressed bgr8"));
  ASSERT_TRUE(jpg.has_value());
  EXPECT_EQ(jpg->size(), bgr.size());
  EXPECT_EQ(jpg->type(), CV_8UC3);
  EXPECT_LT(cv::norm(*jpg, bgr, cv::NORM_L1) / (bgr.total() * 3), 12.0);
  cv::Mat grey;
  cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  auto gpng = decoder.decode(compressed(grey, ".png", "png"));
  ASSERT_TRUE(gpng.has_value());
  EXPECT_EQ(gpng->type(), CV_8UC1);
  EXPECT_EQ(decoder.counts().total(), 0u);
}

TEST(ImageDecoder, RejectsAndCountsBadSamples) {
  ImageDecoder decoder(visnav::camera_dds::ImageLimits{640, 480, 1u << 20});
  visnav::camera_dds::Rejection why;
  const cv::Mat small = test_pattern(8, 8);

  auto short_data = raw(small);
  short_data.data.pop_back();  // data.size() != step * height
  EXPECT_FALSE(decoder.decode(short_data, &why).has_value());
  EXPECT_EQ(why.reason, DropReason::malformed);
  EXPECT_NE(why.message.find("step*height"), std::string::npos);

  auto small_step = raw(small);
  small_step.step = 3;  // < width * 3
  small_step.data.resize(3 * 8);
  EXPECT_FALSE(decoder.decode(small_step, &why).has_value());
  EXPECT_EQ(why.reason, DropReason::malformed);

  auto lying = raw(small);
  lying.height = 0xFFFFFFFFu;  // huge claimed size, tiny data: no overflow, no read past the end
  EXPECT_FALSE(decoder.decode(lying, &why).has_value());
  EXPECT_EQ(why.reason, DropReason::oversized);

  auto big = raw(cv::Mat(481, 10, CV_8UC1, cv::Scalar(1)));
  EXPECT_FALSE(decoder.decode(big, &why).has_value());
  EXPECT_EQ(why.reason, DropReason::oversized);

  auto yuv = raw(small, "yuv422");
  EXPECT_FALSE(decoder.decode(yuv, &why).has_value());
  EXPECT_EQ(why.reason, DropReason::unknown_encoding);
  EXPECT_NE(why.message.find("yuv422"), std::string::npos);

  auto tiff = compressed(small, ".png", "tiff");
  EXPECT_FALSE(decoder.decode(tiff, &why).has_value());
  EXPECT_EQ(why.reason, DropReason::unknown_encoding);

  auto garbage = compressed(small, ".jpg", "jpeg");
  for (std::size_t i = 2; i < garbage.data.size(); ++i) garbage.data[i] = static_cast<std::uint8_t>(i * 7);
  EXPECT_FALSE(decoder.decode(garbage, &why).has_value());
  EXPECT_EQ(why.reason, DropReason::undecodable);

  auto truncated = compressed(test_pattern(64, 64), ".png", "png");
  truncated.data.resize(40);
  EXPECT_FALSE(decoder.decode(truncated, &why).has_value());

  // A PNG whose header claims 100000 x 100000 px is refused before decoding.
  auto bomb = compressed(small, ".png", "png");
  bomb.data[16] = 0; bomb.data[17] = 0x01; bomb.data[18] = 0x86; bomb.data[19] = 0xA0;
  bomb.data[20] = 0; bomb.data[21] = 0x01; bomb.data[22] = 0x86; bomb.data[23] = 0xA0;
  EXPECT_FALSE(decoder.decode(bomb, &why).has_value());
  EXPECT_EQ(why.reason, DropReason::oversized);

  auto empty = dds::msg::CompressedImage{};
  empty.format = "jpeg";
  EXPECT_FALSE(decoder.decode(empty, &why).has_value());

  const auto& c = decoder.counts();
  EXPECT_EQ(c.malformed, 3u);
  EXPECT_EQ(c.oversized, 3u);
  EXPECT_EQ(c.unknown_encoding, 2u);
  EXPECT_EQ(c.undecodable, 2u);
  EXPECT_EQ(c.total(), 10u);
  // Still decodes good input afterwards.
  EXPECT_TRUE(decoder.decode(raw(small)).has_value());
}

TEST(ImageDecoder, PeeksJpegAndPngSizes) {
  const cv::Mat img = test_pattern(37, 53);
  for (const char* ext : {".png", ".jpg"}) {
    std::vector<uchar> buf;
    ASSERT_TRUE(cv::imencode(ext, img, buf));
    auto size = visnav::camera_dds::peek_compressed_size(buf.data(), buf.size());
    ASSERT_TRUE(size.has_value()) << ext;
    EXPECT_EQ(size->width, 53) << ext;
    EXPECT_EQ(size->height, 37) << ext;
  }
  const std::uint8_t junk[] = {1, 2, 3, 4, 5, 6, 7, 8};
  EXPECT_FALSE(visnav::camera_dds::peek_compressed_size(junk, sizeof junk).has_value());
  const std::uint8_t soi_only[] = {0xFF, 0xD8, 0xFF};
  EXPECT_FALSE(visnav::camera_dds::peek_compressed_size(soi_only, sizeof soi_only).has_value());
}

// ---- plugin ----------------------------------------------------------------------------------

class CapturingLogger final : public visnav::Logger {
 public:
  void log(visnav::LogLevel level, std::string_view component, std::string_view message) override {
    std::lock_guard lock(mutex_);
    if (level == visnav::LogLevel::warn) warnings_.push_back(std::string(component) + ": " + std::string(message));
  }
  std::vector<std::string> warnings() {
    std::lock_guard lock(mutex_);
    return warnings_;
  }
  bool any_contains(const std::string& text) {
    for (const auto& w : warnings())
      if (w.find(text) != std::string::npos) return true;
    return false;
  }

 private:
  std::mutex mutex_;
  std::vector<std::string> warnings_;
};

class CameraDdsPlugin : public ::testing::Test {
 protected:
  void SetUp() override {
    dds::testing::use_loopback();
    domain_ = dds::testing::random_domain_id();
    partition_ = dds::testing::unique_partition();
    loader_ = std::make_unique<visnav::PluginLoader>(std::vector<std::string>{VISNAV_TEST_PLUGIN_DIR});
    ASSERT_TRUE(loader_->load_library("camera_dds").ok());
    host_ = std::make_unique<visnav::RuntimeHost>(*loader_, logger_, clock_);
    auto p = dds::Participant::create(domain_);
    ASSERT_TRUE(p.ok());
    participant_.emplace(*p);
  }
  visnav::Result<visnav::PluginPtr<visnav::Camera>> make_camera(const std::string& extra = "") {
    auto params = visnav::parse_yaml_string(
        "domain_id: " + std::to_string(domain_) + "\npartition: " + partition_ + "\n" + extra, "camera.yaml");
    EXPECT_TRUE(params.ok());
    return loader_->create<visnav::Camera>("dds", *params, *host_);
  }
  template <typename M>
  dds::Writer<M> writer(const std::string& topic) {
    auto w = dds::Writer<M>::create(*participant_, {topic, dds::Qos::ros_default(), partition_});
    EXPECT_TRUE(w.ok());
    EXPECT_TRUE(w->wait_for_readers(1, 5.0));
    return std::move(*w);
  }
  std::optional<visnav::Frame> grab(visnav::Camera& camera, double timeout_s = 3.0) {
    auto f = camera.grab(timeout_s);
    EXPECT_TRUE(f.ok());
    return f.ok() ? *f : std::nullopt;
  }
  int domain_ = 0;
  std::string partition_;
  CapturingLogger logger_;
  visnav::WallClock clock_;
  std::unique_ptr<visnav::PluginLoader> loader_;
  std::unique_ptr<visnav::RuntimeHost> host_;
  std::optional<dds::Participant> participant_;
};

TEST_F(CameraDdsPlugin, DeliversRawFramesInAllEncodings) {
  auto camera = make_camera();
  ASSERT_TRUE(camera.ok()) << camera.error().message;
  auto w = writer<dds::msg::Image>("rt/camera/image_raw");
  EXPECT_FALSE(grab(**camera, 0.05).has_value());  // nothing yet: timeout, not an error

  const cv::Mat bgr = test_pattern(480, 640);
  ASSERT_TRUE(w.write(raw(bgr)).ok());
  auto f1 = grab(**camera);
  ASSERT_TRUE(f1.has_value());
  EXPECT_EQ(f1->image.type(), CV_8UC3);
  EXPECT_EQ(max_abs_diff(f1->image, bgr), 0.0);
  EXPECT_LE(f1->timestamp_s, clock_.now_s());
  EXPECT_GT(f1->timestamp_s, clock_.now_s() - 1.0);
  EXPECT_FALSE(grab(**camera, 0.05).has_value());  // no newer frame

  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  ASSERT_TRUE(w.write(raw(rgb, "rgb8")).ok());
  auto f2 = grab(**camera);
  ASSERT_TRUE(f2.has_value());
  EXPECT_EQ(max_abs_diff(f2->image, bgr), 0.0);
  EXPECT_GT(f2->sequence, f1->sequence);

  cv::Mat grey;
  cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  ASSERT_TRUE(w.write(raw(grey)).ok());
  auto f3 = grab(**camera);
  ASSERT_TRUE(f3.has_value());
  EXPECT_EQ(f3->image.type(), CV_8UC1);
  EXPECT_EQ(max_abs_diff(f3->image, grey), 0.0);
  EXPECT_TRUE(logger_.warnings().empty());
}

TEST_F(CameraDdsPlugin, DecodesCompressedJpegAndPng) {
  auto camera = make_camera("transport: compressed\n");
  ASSERT_TRUE(camera.ok()) << camera.error().message;
  auto w = writer<dds::msg::CompressedImage>("rt/camera/image_raw/compressed");
  const cv::Mat bgr = test_pattern(480, 640);
  ASSERT_TRUE(w.write(compressed(bgr, ".png", "png")).ok());
  auto png = grab(**camera);
  ASSERT_TRUE(png.has_value());
  EXPECT_EQ(max_abs_diff(png->image, bgr), 0.0);
  ASSERT_TRUE(w.write(compressed(bgr, ".jpg", "jpeg")).ok());
  auto jpg = grab(**camera);
  ASSERT_TRUE(jpg.has_value());
  EXPECT_EQ(jpg->image.size(), bgr.size());
  EXPECT_LT(cv::norm(jpg->image, bgr, cv::NORM_L1) / (bgr.total() * 3), 12.0);
}

TEST_F(CameraDdsPlugin, BadSamplesAreDroppedWithWarningsAndGoodOnesStillArrive) {
  // history_depth 10: every sample of the burst reaches the decoder (depth 1 keeps only the newest).
  auto camera = make_camera("max_width_px: 640\nmax_height_px: 480\nhistory_depth: 10\n");
  ASSERT_TRUE(camera.ok()) << camera.error().message;
  auto w = writer<dds::msg::Image>("rt/camera/image_raw");
  const cv::Mat small = test_pattern(16, 16);
  auto mismatch = raw(small);
  mismatch.data.resize(mismatch.data.size() / 2);
  ASSERT_TRUE(w.write(mismatch).ok());
  ASSERT_TRUE(w.write(raw(test_pattern(481, 8))).ok());
  ASSERT_TRUE(w.write(raw(small, "bayer_rggb8")).ok());
  EXPECT_FALSE(grab(**camera, 0.3).has_value());
  ASSERT_TRUE(eventually([&] { return logger_.any_contains("dropped a malformed sample"); }));
  EXPECT_TRUE(logger_.any_contains("step*height"));
  // Rate limited: three bad samples within a second give one warning.
  EXPECT_EQ(logger_.warnings().size(), 1u);
  ASSERT_TRUE(w.write(raw(small)).ok());
  auto good = grab(**camera);
  ASSERT_TRUE(good.has_value());
  EXPECT_EQ(max_abs_diff(good->image, small), 0.0);
  // After the rate-limit interval the next warning carries the running counts.
  std::this_thread::sleep_for(std::chrono::milliseconds(1050));
  ASSERT_TRUE(w.write(raw(small, "yuv422")).ok());
  ASSERT_TRUE(eventually([&] { return logger_.warnings().size() == 2; }));
  const auto last = logger_.warnings().back();
  EXPECT_NE(last.find("unknown encoding"), std::string::npos) << last;
  EXPECT_NE(last.find("dropped so far: 4"), std::string::npos) << last;
  EXPECT_NE(last.find("oversized 1"), std::string::npos) << last;
}

TEST_F(CameraDdsPlugin, WriterWithWrongTypeIsReported) {
  auto camera = make_camera();
  ASSERT_TRUE(camera.ok());
  auto w = dds::Writer<dds::msg::CompressedImage>::create(*participant_, {"rt/camera/image_raw", {}, partition_});
  ASSERT_TRUE(w.ok());
  ASSERT_TRUE(eventually([&] { return logger_.any_contains("sensor_msgs::msg::dds_::CompressedImage_"); }));
  ASSERT_TRUE(w->write(compressed(test_pattern(8, 8), ".png", "png")).ok());
  EXPECT_FALSE(grab(**camera, 0.2).has_value());
}

TEST_F(CameraDdsPlugin, ParamsAreValidated) {
  EXPECT_FALSE(make_camera("transport: h264\n").ok());
  EXPECT_FALSE(make_camera("max_width_px: 0\n").ok());
  EXPECT_FALSE(make_camera("colour: yes\n").ok());
}

}  // namespace
