// The `image_folder` camera (plugins/cameras/image_folder) through the real loader.
#include <gtest/gtest.h>

#include <chrono>
#include <optional>
#include <vector>

#include "camera_test_support.hpp"
#include "error_expect.hpp"

using namespace visnav::testing;

using visnav::ErrorCode;
using visnav::test::At;
using visnav::test::fails_with;

TEST(ImageFolderCamera, DeliversSortedImagesThenEnds) {
  const std::string dir = scratch();
  for (int i = 0; i < 4; ++i) cv::imwrite(dir + "/f" + std::to_string(i * 5) + ".png", test_image(i));
  LoaderHost h;
  auto cam = h.loader.create<visnav::Camera>("image_folder", yaml("folder: " + dir + "\ncrop_rows: [0, 0.5]\n"), h.host);
  ASSERT_TRUE(cam.ok()) << cam.error().message;
  for (int i = 0; i < 4; ++i) {
    h.clock.set(0.25 * i);
    auto f = (*cam)->grab(0.0);
    ASSERT_TRUE(f.ok()) << f.error().message;
    ASSERT_TRUE(f->has_value());
    EXPECT_EQ((*f)->image.size(), cv::Size(64, 24));  // top half
    EXPECT_EQ(cv::norm((*f)->image, test_image(i)(cv::Rect(0, 0, 64, 24)), cv::NORM_INF), 0.0) << "frame " << i;
    EXPECT_DOUBLE_EQ((*f)->timestamp_s, 0.25 * i);  // fast pacing: stamped with the run clock
  }
  auto end = (*cam)->grab(0.0);
  ASSERT_FALSE(end.ok());
  EXPECT_NE(end.error().message.find("end of the image sequence after 4 frames"), std::string::npos) << end.error().message;
}

TEST(ImageFolderCamera, TimestampsFileWithClockAndRealtimePacing) {
  const std::string dir = scratch();
  for (int i = 0; i < 3; ++i) cv::imwrite(dir + "/im" + std::to_string(i) + ".jpg", test_image(i));
  write_text(dir + "/timestamps.txt", "# t\n100.0\n100.05\n100.10\n");
  LoaderHost h;
  auto cam = h.loader.create<visnav::Camera>("image_folder", yaml("folder: " + dir + "\npacing: clock\n"), h.host);
  ASSERT_TRUE(cam.ok()) << cam.error().message;
  h.clock.set(99.0);
  EXPECT_FALSE((*cam)->grab(0.0)->has_value());
  h.clock.set(100.07);
  auto f = (*cam)->grab(0.0);
  ASSERT_TRUE(f.ok() && f->has_value());
  EXPECT_DOUBLE_EQ((*f)->timestamp_s, 100.05);  // newest due; 100.0 skipped
  EXPECT_EQ((*f)->sequence, 1u);

  auto rt = h.loader.create<visnav::Camera>("image_folder", yaml("folder: " + dir + "\npacing: realtime\n"), h.host);
  ASSERT_TRUE(rt.ok()) << rt.error().message;
  const auto start = std::chrono::steady_clock::now();
  for (int i = 0; i < 3; ++i) {
    auto g = (*rt)->grab(1.0);
    ASSERT_TRUE(g.ok() && g->has_value()) << i;
  }
  const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_GT(took, 0.09);  // frames 50 ms apart
  EXPECT_LT(took, 1.5);  // generous: CI shares 2 cores
}

TEST(ImageFolderCamera, BadInputIsAClearError) {
  LoaderHost h;
  const std::string empty = scratch("_empty");
  auto none = h.loader.create<visnav::Camera>("image_folder", yaml("folder: " + empty + "\n"), h.host);
  ASSERT_FALSE(none.ok());
  EXPECT_TRUE(fails_with(none, ErrorCode::missing, At{empty}));
  auto missing = h.loader.create<visnav::Camera>("image_folder", yaml("folder: /no/such/folder\n"), h.host);
  ASSERT_FALSE(missing.ok());
  EXPECT_TRUE(fails_with(missing, ErrorCode::not_found, At{"/no/such/folder"}));

  const std::string dir = scratch();
  cv::imwrite(dir + "/a.png", test_image(0));
  write_text(dir + "/b.png", "this is not a png");
  write_text(dir + "/timestamps.csv", "file,t_s\na.png,1\nb.png,one\n");
  auto bad_ts = h.loader.create<visnav::Camera>("image_folder", yaml("folder: " + dir + "\n"), h.host);
  ASSERT_FALSE(bad_ts.ok());
  EXPECT_TRUE(fails_with(bad_ts, ErrorCode::invalid_value, At{"timestamps.csv", 3, "t_s"}));
  write_text(dir + "/timestamps.csv", "file,t_s\na.png,1\nb.png,2\n");
  auto cam = h.loader.create<visnav::Camera>("image_folder", yaml("folder: " + dir + "\n"), h.host);
  ASSERT_TRUE(cam.ok()) << cam.error().message;
  ASSERT_TRUE((*cam)->grab(0.0).ok());
  auto broken = (*cam)->grab(0.0);
  ASSERT_FALSE(broken.ok());
  EXPECT_TRUE(fails_with(broken, ErrorCode::io, At{"timestamps.csv", 3, "file"}));
  EXPECT_NE(broken.error().message.find("b.png"), std::string::npos) << broken.error().message;  // names the image

  auto bad_param = h.loader.create<visnav::Camera>("image_folder", yaml("folder: " + dir + "\npacing: warp\n"), h.host);
  ASSERT_FALSE(bad_param.ok());
  EXPECT_TRUE(fails_with(bad_param, ErrorCode::out_of_range, At{"test.yaml", 2, "pacing"}));
}

// The camera mount keys (camera_mount.hpp): all three required ones declare the mount the camera
// reports (and the host hands to nodes), none declare no mount, a partial set is refused.
TEST(ImageFolderCamera, ReportsTheMountItsParamsDeclare) {
  const std::string dir = scratch();
  cv::imwrite(dir + "/a.png", test_image(0));
  LoaderHost h;
  auto cam = h.loader.create<visnav::Camera>(
      "image_folder", yaml("folder: " + dir + "\nhfov_deg: 84\nmount_height_m: 0.62\nmount_pitch_down_deg: 7.5\n"), h.host);
  ASSERT_TRUE(cam.ok()) << cam.error().message;
  const std::optional<visnav::CameraMount> m = (*cam)->mount();
  ASSERT_TRUE(m.has_value());
  EXPECT_DOUBLE_EQ(m->hfov_deg, 84.0);
  EXPECT_DOUBLE_EQ(m->height_m, 0.62);
  EXPECT_DOUBLE_EQ(m->pitch_down_deg, 7.5);
  EXPECT_DOUBLE_EQ(m->forward_m, 0.0);
  EXPECT_DOUBLE_EQ(m->lateral_m, 0.0);

  // What a node asks the host during a run.
  h.host.set_camera(cam->get(), "camera 'image_folder' (test.yaml:1)");
  auto through_host = h.host.camera_mount();
  ASSERT_TRUE(through_host.ok()) << through_host.error().message;
  EXPECT_DOUBLE_EQ(through_host->hfov_deg, 84.0);
  EXPECT_DOUBLE_EQ(through_host->height_m, 0.62);
  EXPECT_DOUBLE_EQ(through_host->pitch_down_deg, 7.5);

  auto offset = h.loader.create<visnav::Camera>(
      "image_folder",
      yaml("folder: " + dir + "\nhfov_deg: 84\nmount_height_m: 0.62\nmount_pitch_down_deg: 7.5\nmount_forward_m: 0.15\n"
           "mount_lateral_m: -0.04\n"),
      h.host);
  ASSERT_TRUE(offset.ok()) << offset.error().message;
  ASSERT_TRUE((*offset)->mount().has_value());
  EXPECT_DOUBLE_EQ((*offset)->mount()->forward_m, 0.15);
  EXPECT_DOUBLE_EQ((*offset)->mount()->lateral_m, -0.04);

  auto plain = h.loader.create<visnav::Camera>("image_folder", yaml("folder: " + dir + "\n"), h.host);
  ASSERT_TRUE(plain.ok()) << plain.error().message;
  EXPECT_FALSE((*plain)->mount().has_value());
  h.host.set_camera(plain->get(), "camera 'image_folder' (test.yaml:1)");
  auto none = h.host.camera_mount();
  EXPECT_TRUE(fails_with(none, ErrorCode::missing));
  if (!none.ok()) {
    EXPECT_NE(none.error().message.find("camera 'image_folder' (test.yaml:1) declares no mount"), std::string::npos)
        << none.error().message;
  }
  h.host.set_camera(nullptr, {});
}

TEST(ImageFolderCamera, PartialOrBadMountIsRefusedNamingTheKey) {
  const std::string dir = scratch();
  cv::imwrite(dir + "/a.png", test_image(0));
  LoaderHost h;
  const visnav::ConfigNode partial = yaml("folder: " + dir + "\nhfov_deg: 84\nmount_height_m: 0.62\n");
  auto cam = h.loader.create<visnav::Camera>("image_folder", partial, h.host);
  ASSERT_FALSE(cam.ok());
  EXPECT_TRUE(fails_with(cam, ErrorCode::missing, At{"test.yaml", 0, "mount_pitch_down_deg"}));
  EXPECT_NE(cam.error().message.find("mount_pitch_down_deg"), std::string::npos) << cam.error().message;

  // The check `visnav validate` runs on a params block finds the same problem.
  auto entry = h.loader.type_entry(visnav::PluginKind::camera, "image_folder");
  ASSERT_TRUE(entry.ok()) << entry.error().message;
  ASSERT_NE((*entry)->check_params, nullptr);
  const std::vector<visnav::Error> problems = (*entry)->check_params(partial);
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_TRUE(visnav::test::error_is(problems[0], ErrorCode::missing, At{"test.yaml", 0, "mount_pitch_down_deg"}));

  auto steep = h.loader.create<visnav::Camera>(
      "image_folder", yaml("folder: " + dir + "\nhfov_deg: 84\nmount_height_m: 0.62\nmount_pitch_down_deg: 95\n"), h.host);
  EXPECT_TRUE(fails_with(steep, ErrorCode::out_of_range, At{"test.yaml", 4, "mount_pitch_down_deg"}));
  auto narrow = h.loader.create<visnav::Camera>(
      "image_folder", yaml("folder: " + dir + "\nhfov_deg: 0\nmount_height_m: 0.62\nmount_pitch_down_deg: 5\n"), h.host);
  EXPECT_TRUE(fails_with(narrow, ErrorCode::out_of_range, At{"test.yaml", 2, "hfov_deg"}));
  auto underground = h.loader.create<visnav::Camera>(
      "image_folder", yaml("folder: " + dir + "\nhfov_deg: 60\nmount_height_m: -1\nmount_pitch_down_deg: 5\n"), h.host);
  EXPECT_TRUE(fails_with(underground, ErrorCode::out_of_range, At{"test.yaml", 3, "mount_height_m"}));

  // `visnav plugins --params` lists the mount keys, unset by default.
  auto docs = h.loader.param_docs(visnav::PluginKind::camera, "image_folder");
  ASSERT_TRUE(docs.ok()) << docs.error().message;
  int mount_keys = 0;
  for (const auto& d : *docs)
    if (d.name == "hfov_deg" || d.name.rfind("mount_", 0) == 0) {
      ++mount_keys;
      EXPECT_EQ(d.default_value, "unset") << d.name;
    }
  EXPECT_EQ(mount_keys, 5);
}
