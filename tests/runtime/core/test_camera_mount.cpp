// The camera mount (camera_mount.hpp, CameraMount in devices.hpp): the all-or-nothing mount keys
// of a camera's params, their ranges, and the schema fields every camera plugin adds.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "error_expect.hpp"
#include "visnav/camera_mount.hpp"
#include "visnav/config_node.hpp"

using visnav::CameraMount;
using visnav::CameraMountOptions;
using visnav::ErrorCode;
using visnav::test::At;
using visnav::test::error_is;
using visnav::test::fails_with;
using visnav::test::key_only;

namespace {

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

CameraMountOptions required_three(double hfov = 70.0, double height = 0.4, double pitch = 10.0) {
  CameraMountOptions o;
  o.hfov_deg = hfov;
  o.mount_height_m = height;
  o.mount_pitch_down_deg = pitch;
  return o;
}

/// A camera's params as a plugin writes them: its own key plus the mount keys.
struct TestCameraParams : CameraMountOptions {
  std::string device = "cam0";
  [[nodiscard]] visnav::Status validate() const { return CameraMountOptions::validate(); }
  static const visnav::ParamSchema<TestCameraParams>& schema() {
    static const auto s = [] {
      visnav::ParamSchema<TestCameraParams> p;
      p.field("device", &TestCameraParams::device, "device name");
      visnav::add_camera_mount_fields(p);
      return p;
    }();
    return s;
  }
};

visnav::ConfigNode yaml(const std::string& text) {
  auto node = visnav::parse_yaml_string(text, "cam.yaml");
  EXPECT_TRUE(node.ok()) << (node.ok() ? "" : node.error().message);
  return node.ok() ? *node : visnav::ConfigNode{};
}

}  // namespace

TEST(CameraMountOptions, NoKeysDeclareNoMount) {
  const CameraMountOptions none;
  EXPECT_TRUE(none.validate().ok());
  auto d = none.declared();
  ASSERT_TRUE(d.ok()) << d.error().message;
  EXPECT_FALSE(d->has_value());
  EXPECT_FALSE(none.mount().has_value());
}

TEST(CameraMountOptions, TheThreeRequiredKeysDeclareAMountAtTheOrigin) {
  const CameraMountOptions o = required_three(70.0, 0.4, 10.0);
  EXPECT_TRUE(o.validate().ok());
  auto d = o.declared();
  ASSERT_TRUE(d.ok()) << d.error().message;
  ASSERT_TRUE(d->has_value());
  EXPECT_DOUBLE_EQ((*d)->hfov_deg, 70.0);
  EXPECT_DOUBLE_EQ((*d)->height_m, 0.4);
  EXPECT_DOUBLE_EQ((*d)->pitch_down_deg, 10.0);
  EXPECT_DOUBLE_EQ((*d)->forward_m, 0.0);  // unset forward/lateral default to 0
  EXPECT_DOUBLE_EQ((*d)->lateral_m, 0.0);
  ASSERT_TRUE(o.mount().has_value());
  EXPECT_DOUBLE_EQ(o.mount()->hfov_deg, 70.0);
}

TEST(CameraMountOptions, ForwardAndLateralAreTakenWhenGiven) {
  CameraMountOptions o = required_three();
  o.mount_forward_m = 0.25;
  o.mount_lateral_m = -0.1;
  ASSERT_TRUE(o.mount().has_value());
  EXPECT_DOUBLE_EQ(o.mount()->forward_m, 0.25);
  EXPECT_DOUBLE_EQ(o.mount()->lateral_m, -0.1);
  // Negative pitch (looking up) inside (-89, 89) is a valid mount.
  o.mount_pitch_down_deg = -20.0;
  EXPECT_TRUE(o.validate().ok());
}

TEST(CameraMountOptions, APartialSetNamesTheFirstMissingKey) {
  CameraMountOptions o;
  o.hfov_deg = 70.0;
  o.mount_height_m = 0.4;
  const auto st = o.validate();
  ASSERT_FALSE(st.ok());
  EXPECT_TRUE(error_is(st.error(), ErrorCode::missing, key_only("mount_pitch_down_deg")));
  EXPECT_TRUE(contains(st.error().message, "'mount_pitch_down_deg'")) << st.error().message;
  EXPECT_TRUE(contains(st.error().message, "given: hfov_deg, mount_height_m")) << st.error().message;
  EXPECT_TRUE(fails_with(o.declared(), ErrorCode::missing, key_only("mount_pitch_down_deg")));
  EXPECT_FALSE(o.mount().has_value());  // an invalid set declares nothing

  // Only an optional key given: the first required one is missing.
  CameraMountOptions only_forward;
  only_forward.mount_forward_m = 0.1;
  const auto f = only_forward.validate();
  ASSERT_FALSE(f.ok());
  EXPECT_TRUE(error_is(f.error(), ErrorCode::missing, key_only("hfov_deg")));
  EXPECT_TRUE(contains(f.error().message, "'hfov_deg'")) << f.error().message;

  CameraMountOptions no_height;
  no_height.hfov_deg = 70.0;
  no_height.mount_pitch_down_deg = 5.0;
  const auto h = no_height.validate();
  ASSERT_FALSE(h.ok());
  EXPECT_TRUE(error_is(h.error(), ErrorCode::missing, key_only("mount_height_m")));
  EXPECT_TRUE(contains(h.error().message, "'mount_height_m'")) << h.error().message;
}

TEST(CameraMountOptions, OutOfRangeValuesNameTheirKey) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  struct Case {
    CameraMountOptions options;
    const char* key;
  };
  CameraMountOptions lateral_inf = required_three();
  lateral_inf.mount_lateral_m = inf;
  CameraMountOptions forward_nan = required_three();
  forward_nan.mount_forward_m = nan;
  const Case cases[] = {
      {required_three(0.0), "hfov_deg"},          {required_three(179.0), "hfov_deg"},
      {required_three(nan), "hfov_deg"},          {required_three(70.0, -1.0), "mount_height_m"},
      {required_three(70.0, 0.0), "mount_height_m"}, {required_three(70.0, nan), "mount_height_m"},
      {required_three(70.0, inf), "mount_height_m"}, {required_three(70.0, 0.4, 95.0), "mount_pitch_down_deg"},
      {required_three(70.0, 0.4, -90.0), "mount_pitch_down_deg"}, {required_three(70.0, 0.4, nan), "mount_pitch_down_deg"},
      {forward_nan, "mount_forward_m"},           {lateral_inf, "mount_lateral_m"},
  };
  for (const Case& c : cases) {
    const auto st = c.options.validate();
    ASSERT_FALSE(st.ok()) << c.key;
    EXPECT_TRUE(error_is(st.error(), ErrorCode::out_of_range, key_only(c.key))) << c.key;
    EXPECT_TRUE(contains(st.error().message, std::string("'") + c.key + "'")) << st.error().message;
    EXPECT_FALSE(c.options.mount().has_value()) << c.key;
  }
  const auto pitch = required_three(70.0, 0.4, 95.0).validate();
  ASSERT_FALSE(pitch.ok());
  EXPECT_TRUE(contains(pitch.error().message, "95")) << pitch.error().message;  // names the value
}

TEST(CameraMount, ValidateNamesTheField) {
  CameraMount good;
  good.hfov_deg = 60.0;
  good.height_m = 0.5;
  good.pitch_down_deg = 5.0;
  EXPECT_TRUE(good.validate().ok());

  CameraMount zero_hfov = good;
  zero_hfov.hfov_deg = 0.0;
  const auto h = zero_hfov.validate();
  ASSERT_FALSE(h.ok());
  EXPECT_TRUE(error_is(h.error(), ErrorCode::out_of_range, key_only("hfov_deg")));
  EXPECT_TRUE(contains(h.error().message, "camera mount: hfov_deg 0 is out of range (1, 179)")) << h.error().message;

  CameraMount low = good;
  low.height_m = -1.0;
  const auto l = low.validate();
  ASSERT_FALSE(l.ok());
  EXPECT_TRUE(error_is(l.error(), ErrorCode::out_of_range, key_only("height_m")));
  EXPECT_TRUE(contains(l.error().message, "height_m -1")) << l.error().message;

  CameraMount steep = good;
  steep.pitch_down_deg = std::nan("");
  const auto p = steep.validate();
  ASSERT_FALSE(p.ok());
  EXPECT_TRUE(error_is(p.error(), ErrorCode::out_of_range, key_only("pitch_down_deg")));

  CameraMount aside = good;
  aside.lateral_m = std::numeric_limits<double>::infinity();
  EXPECT_TRUE(error_is(aside.validate().error(), ErrorCode::out_of_range, key_only("lateral_m")));
  // The default-constructed mount (hfov 0) is not a valid one.
  EXPECT_FALSE(CameraMount{}.validate().ok());
}

TEST(CameraMountFields, SchemaParsesTheKeysAndLeavesAbsentOnesUnset) {
  const auto& schema = TestCameraParams::schema();
  auto none = schema.parse(yaml("device: cam1\n"));
  ASSERT_TRUE(none.ok()) << none.error().message;
  EXPECT_FALSE(none->hfov_deg.has_value());
  EXPECT_FALSE(none->mount().has_value());

  auto full = schema.parse(yaml("hfov_deg: 80\nmount_height_m: 1.2\nmount_pitch_down_deg: 15\nmount_lateral_m: 0.05\n"));
  ASSERT_TRUE(full.ok()) << full.error().message;
  ASSERT_TRUE(full->mount().has_value());
  EXPECT_DOUBLE_EQ(full->mount()->hfov_deg, 80.0);
  EXPECT_DOUBLE_EQ(full->mount()->height_m, 1.2);
  EXPECT_DOUBLE_EQ(full->mount()->pitch_down_deg, 15.0);
  EXPECT_DOUBLE_EQ(full->mount()->forward_m, 0.0);
  EXPECT_DOUBLE_EQ(full->mount()->lateral_m, 0.05);

  // A partial set: validate()'s error, located on the params map (the missing key has no line).
  auto partial = schema.parse(yaml("hfov_deg: 80\nmount_height_m: 1.2\n"));
  EXPECT_TRUE(fails_with(partial, ErrorCode::missing, At{"cam.yaml", 1, "mount_pitch_down_deg"}));
  if (!partial.ok()) {
    EXPECT_TRUE(contains(partial.error().message, "mount_pitch_down_deg")) << partial.error().message;
  }

  // Out of range at the key's own line, whether the schema's range or the mount's refuses it.
  EXPECT_TRUE(fails_with(schema.parse(yaml("hfov_deg: 0\nmount_height_m: 1\nmount_pitch_down_deg: 5\n")),
                         ErrorCode::out_of_range, At{"cam.yaml", 1, "hfov_deg"}));
  EXPECT_TRUE(fails_with(schema.parse(yaml("hfov_deg: 60\nmount_height_m: -1\nmount_pitch_down_deg: 5\n")),
                         ErrorCode::out_of_range, At{"cam.yaml", 2, "mount_height_m"}));
  EXPECT_TRUE(fails_with(schema.parse(yaml("hfov_deg: 60\nmount_height_m: 0\nmount_pitch_down_deg: 5\n")),
                         ErrorCode::out_of_range, At{"cam.yaml", 2, "mount_height_m"}));
  EXPECT_TRUE(fails_with(schema.parse(yaml("hfov_deg: 60\nmount_height_m: 1\nmount_pitch_down_deg: 95\n")),
                         ErrorCode::out_of_range, At{"cam.yaml", 3, "mount_pitch_down_deg"}));
  EXPECT_TRUE(fails_with(schema.parse(yaml("hfov_deg: wide\nmount_height_m: 1\nmount_pitch_down_deg: 5\n")),
                         ErrorCode::invalid_value, At{"cam.yaml", 1, "hfov_deg"}));
}

TEST(CameraMountFields, DocsListTheFiveKeysAsUnsetDoubles) {
  const auto docs = TestCameraParams::schema().docs();
  int found = 0;
  for (const auto& d : docs) {
    for (const char* key : {"hfov_deg", "mount_height_m", "mount_pitch_down_deg", "mount_forward_m", "mount_lateral_m"}) {
      if (d.name != key) continue;
      ++found;
      EXPECT_EQ(d.type, "double") << key;
      EXPECT_EQ(d.default_value, "unset") << key;
      EXPECT_FALSE(d.description.empty()) << key;
    }
  }
  EXPECT_EQ(found, 5);
}
