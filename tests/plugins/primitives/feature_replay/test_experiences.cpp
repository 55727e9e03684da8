// Appearance experiences of a feature edge (experience.hpp, issue 13 part 3), core level:
//  * the experience file round-trips; the bound evicts the oldest learned experience, never the
//    taught one;
//  * a map without experience files loads as one experience; a damaged, foreign or stale file is
//    an error with its code and the file (and edge) as location;
//  * the selector tries the last winner first and pays for the others only when it is unsure,
//    and then picks the best-matching experience;
//  * the view registrar moves a replay frame onto the reference heading;
//  * a supervised drive's edge becomes an experience aligned to the taught edge (distances
//    scaled to the taught length, the taught azimuth / commands kept); a drive of another length
//    or kind, or a damaged body, is refused with its code.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <vector>

#include "error_expect.hpp"
#include "temp_folder.hpp"
#include "visnav/feature_replay/experience.hpp"
#include "visnav/feature_replay/local_map.hpp"
#include "visnav/feature_replay/segment_map.hpp"
#include "visnav/map.hpp"

namespace fr = visnav::feature_replay;
using visnav::ErrorCode;
using visnav::test::At;
using visnav::test::fails_with;

namespace {

fr::Experience experience(std::uint8_t fill, std::size_t bytes = 40) {
  fr::Experience e;
  e.created = "2026-11-24T08:00:00Z";
  e.source = "test";
  e.body.assign(bytes, fill);
  return e;
}

const std::vector<std::uint8_t> kTeachBody = {1, 2, 3, 4, 5, 6, 7, 8};

TEST(ExperienceSet, RoundTripsAndBoundsEvictTheOldestLearned) {
  fr::ExperienceSet set;
  set.teach_crc32 = visnav::map_format::crc32(kTeachBody);
  // max_experiences 3 counts the taught one: two learned ones are kept.
  EXPECT_TRUE(set.add(experience(1), 3).empty());
  EXPECT_TRUE(set.add(experience(2), 3).empty());
  EXPECT_EQ(set.add(experience(3), 3), std::vector<std::uint32_t>{1});
  EXPECT_EQ(set.add(experience(4), 3), std::vector<std::uint32_t>{2});
  ASSERT_EQ(set.learned.size(), 2u);
  EXPECT_EQ(set.learned[0].number, 3u);
  EXPECT_EQ(set.learned[1].number, 4u);
  EXPECT_EQ(set.learned[1].body.front(), 4);
  // max_experiences 1: only the taught payload; nothing learned is kept.
  fr::ExperienceSet only_teach;
  EXPECT_EQ(only_teach.add(experience(9), 1), std::vector<std::uint32_t>{1});
  EXPECT_TRUE(only_teach.learned.empty());

  auto back = fr::ExperienceSet::deserialize(set.serialize());
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->teach_crc32, set.teach_crc32);
  EXPECT_EQ(back->next_number, 5u);
  ASSERT_EQ(back->learned.size(), 2u);
  EXPECT_EQ(back->learned[0].number, 3u);
  EXPECT_EQ(back->learned[0].created, "2026-11-24T08:00:00Z");
  EXPECT_EQ(back->learned[1].body, set.learned[1].body);
}

TEST(ExperienceSet, GarbageAndTruncationAreParseErrorsNeverCrashes) {
  fr::ExperienceSet set;
  set.add(experience(1), 4);
  set.add(experience(2), 4);
  const std::vector<std::uint8_t> good = set.serialize();
  for (std::size_t n = 0; n < good.size(); ++n) {
    const std::vector<std::uint8_t> cut(good.begin(), good.begin() + static_cast<std::ptrdiff_t>(n));
    EXPECT_TRUE(fails_with(fr::ExperienceSet::deserialize(cut), ErrorCode::parse_error)) << "cut at " << n;
  }
  std::vector<std::uint8_t> trailing = good;
  trailing.push_back(0);
  EXPECT_TRUE(fails_with(fr::ExperienceSet::deserialize(trailing), ErrorCode::parse_error));
  std::vector<std::uint8_t> huge_count = good;
  huge_count[14] = 0xff;  // count (u32 at offset 14)
  huge_count[17] = 0x7f;
  EXPECT_TRUE(fails_with(fr::ExperienceSet::deserialize(huge_count), ErrorCode::parse_error));
}

TEST(ExperienceFiles, AMapWithoutExperiencesHasOnlyTheTaughtOne) {
  visnav::test::TempFolder dir("visnav_fr_exp");
  auto set = fr::load_experiences(dir.file(""), "e1", kTeachBody);
  ASSERT_TRUE(set.ok()) << set.error().message;
  EXPECT_TRUE(set->learned.empty());
  EXPECT_EQ(set->teach_crc32, visnav::map_format::crc32(kTeachBody));
  EXPECT_FALSE(std::filesystem::exists(dir.file("experiences")));
}

TEST(ExperienceFiles, SaveLoadAndDamagedForeignOrStaleFilesNameTheFile) {
  visnav::test::TempFolder dir("visnav_fr_exp");
  const std::string map_dir = dir.file("");
  fr::ExperienceSet set;
  set.teach_crc32 = visnav::map_format::crc32(kTeachBody);
  set.add(experience(5, 300), 4);
  ASSERT_TRUE(fr::save_experiences(map_dir, "e1", set).ok());
  const std::string path = fr::experience_path(map_dir, "e1");
  ASSERT_TRUE(std::filesystem::exists(path));
  // No temporary file is left next to it.
  int files = 0;
  for ([[maybe_unused]] const auto& entry : std::filesystem::directory_iterator(dir.file("experiences"))) ++files;
  EXPECT_EQ(files, 1);

  auto loaded = fr::load_experiences(map_dir, "e1", kTeachBody);
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  ASSERT_EQ(loaded->learned.size(), 1u);
  EXPECT_EQ(loaded->learned[0].body, set.learned[0].body);

  // Stale: the edge's teach body changed since the experiences were learned.
  const std::vector<std::uint8_t> other_teach = {9, 9, 9};
  EXPECT_TRUE(fails_with(fr::load_experiences(map_dir, "e1", other_teach), ErrorCode::inconsistent,
                         At{"experiences/e1.bin", 0, "e1"}));
  // Foreign: the file of edge e1 under the name of edge e2.
  std::filesystem::copy_file(path, fr::experience_path(map_dir, "e2"));
  EXPECT_TRUE(fails_with(fr::load_experiences(map_dir, "e2", kTeachBody), ErrorCode::parse_error,
                         At{"experiences/e2.bin", 0, "e2"}));
  // Damaged: one flipped byte in the body fails the checksum.
  {
    std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(-10, std::ios::end);
    f.put('\x5a');
  }
  EXPECT_TRUE(fails_with(fr::load_experiences(map_dir, "e1", kTeachBody), ErrorCode::parse_error,
                         At{"experiences/e1.bin"}));
  EXPECT_TRUE(fails_with(fr::read_experience_file(path, "e1"), ErrorCode::parse_error, At{"experiences/e1.bin"}));
}

TEST(ExperienceSelector, TriesTheLastWinnerFirstAndTheOthersOnlyWhenUnsure) {
  // Experience 2 matches the "winter" frames; 0 (the taught one) does not.
  std::vector<fr::ExperienceSelector::Score> scores = {{0.1, 7}, {0.3, 10}, {0.9, 60}};
  std::vector<int> calls(3, 0);
  auto evaluate = [&](int i) {
    ++calls[static_cast<std::size_t>(i)];
    return scores[static_cast<std::size_t>(i)];
  };
  fr::ExperienceSelector selector(3, 0.5);
  EXPECT_EQ(selector.select(evaluate), 2);
  EXPECT_EQ(selector.evaluations(), 3);
  EXPECT_EQ(calls, (std::vector<int>{1, 1, 1}));
  // Next frames: the winner is confident, nothing else is evaluated.
  for (int k = 0; k < 5; ++k) EXPECT_EQ(selector.select(evaluate), 2);
  EXPECT_EQ(selector.evaluations(), 1);
  EXPECT_EQ(calls, (std::vector<int>{1, 1, 6}));
  // The light changes back: experience 2 is unsure, the taught one wins again.
  scores = {{0.8, 40}, {0.3, 10}, {0.2, 8}};
  EXPECT_EQ(selector.select(evaluate), 0);
  EXPECT_EQ(selector.switches(), 2);
  // Equal confidence: more inliers win; a full tie keeps the current one.
  scores = {{0.4, 10}, {0.4, 12}, {0.4, 10}};
  EXPECT_EQ(selector.select(evaluate), 1);
  scores = {{0.4, 12}, {0.4, 12}, {0.4, 12}};
  EXPECT_EQ(selector.select(evaluate), 1);
  // One experience: always it, one evaluation.
  fr::ExperienceSelector single(1, 1.0);
  EXPECT_EQ(single.select(evaluate), 0);
  EXPECT_EQ(single.evaluations(), 1);
}

TEST(ViewRegistrar, MovesTheFrameOntoTheReferenceHeadingAndHoldsTheOffsetBriefly) {
  visnav::Features f;
  f.keypoints = {cv::KeyPoint(100.f, 50.f, 7.f), cv::KeyPoint(200.f, 60.f, 7.f)};
  f.descriptors = cv::Mat(2, 32, CV_8UC1, cv::Scalar(3));
  fr::HeadingEstimate valid;
  valid.valid = true;
  valid.offset_px = 25.0;
  fr::HeadingEstimate unsure;
  fr::ViewRegistrar registrar(1.0);
  EXPECT_EQ(registrar.add(0.0, f, unsure), nullptr) << "no offset known yet";
  const visnav::Features* r = registrar.add(0.5, f, valid);
  ASSERT_NE(r, nullptr);
  EXPECT_FLOAT_EQ(r->keypoints[0].pt.x, 75.f);
  EXPECT_FLOAT_EQ(r->keypoints[1].pt.x, 175.f);
  EXPECT_FLOAT_EQ(r->keypoints[1].pt.y, 60.f);
  EXPECT_EQ(r->descriptors.rows, 2);
  r = registrar.add(1.4, f, unsure);  // within 1 m of the last valid offset: held
  ASSERT_NE(r, nullptr);
  EXPECT_FLOAT_EQ(r->keypoints[0].pt.x, 75.f);
  EXPECT_EQ(registrar.add(1.6, f, unsure), nullptr) << "beyond hold_m the heading is unknown";

  // Learning on odometry (learn_hold_m > 1): an edge where nothing matches is learned from an
  // aligned start, up to hold_m.
  registrar.reset(5.0, true);
  r = registrar.add(0.2, f, unsure);
  ASSERT_NE(r, nullptr);
  EXPECT_FLOAT_EQ(r->keypoints[0].pt.x, 100.f);
  EXPECT_NE(registrar.add(4.9, f, unsure), nullptr);
  EXPECT_EQ(registrar.add(5.1, f, unsure), nullptr);
  registrar.reset(5.0, false);
  EXPECT_EQ(registrar.add(0.2, f, unsure), nullptr);
}

/// A segment of `length_m` with three landmarks spread over it, seen from `azimuth_rad`.
fr::SegmentMap segment(double length_m, double azimuth_rad, std::uint8_t fill) {
  fr::SegmentMap m;
  m.length_m = length_m;
  m.azimuth_rad = azimuth_rad;
  m.descriptors = cv::Mat(3, 32, CV_8UC1, cv::Scalar(fill));
  for (int i = 0; i < 3; ++i) {
    fr::Landmark l;
    l.count = 5;
    l.first_px = {100.f + 10.f * static_cast<float>(i), 50.f};
    l.last_px = {90.f + 10.f * static_cast<float>(i), 52.f};
    l.first_distance_m = static_cast<float>(length_m * 0.25 * i);
    l.last_distance_m = static_cast<float>(length_m * (0.25 * i + 0.5));
    m.landmarks.push_back(l);
    m.max_span_m = std::max(m.max_span_m, static_cast<double>(l.last_distance_m - l.first_distance_m));
  }
  return m;
}

TEST(DriveExperience, ASegmentDriveIsScaledToTheTaughtLengthAndKeepsTheTaughtAzimuth) {
  const fr::SegmentMap teach = segment(10.0, 0.4, 1);
  const fr::SegmentMap drive = segment(11.0, -0.2, 9);  // odometry 10 % long, another start heading
  auto body = fr::experience_from_drive(fr::kSegmentKind, teach.serialize(), drive.serialize());
  ASSERT_TRUE(body.ok()) << body.error().message;
  auto out = fr::SegmentMap::deserialize(*body);
  ASSERT_TRUE(out.ok()) << out.error().message;
  EXPECT_DOUBLE_EQ(out->length_m, 10.0);
  EXPECT_DOUBLE_EQ(out->azimuth_rad, 0.4);
  ASSERT_EQ(out->landmarks.size(), 3u);
  // The landmark the drive saw from 5.5 m to 11 m is where the taught edge is 5 m to 10 m.
  EXPECT_NEAR(out->landmarks[2].first_distance_m, 5.0, 1e-4);
  EXPECT_NEAR(out->landmarks[2].last_distance_m, 10.0, 1e-4);
  EXPECT_NEAR(out->max_span_m, 5.0, 1e-4);
  EXPECT_EQ(out->descriptors.at<std::uint8_t>(0, 0), 9) << "the appearance is the drive's";
  EXPECT_FLOAT_EQ(out->landmarks[1].first_px.x, 110.f);
}

TEST(DriveExperience, ALocalMapDriveKeepsTheTaughtCommands) {
  auto path = [](double length_m, double speed_mps, std::uint8_t fill) {
    fr::LocalMapPath p;
    p.length_m = length_m;
    for (int i = 0; i <= 4; ++i) {
      fr::LocalMap m;
      m.distance_m = length_m * i / 4.0;
      m.positions_px = {{10.f, 20.f}, {30.f, 40.f}};
      m.descriptors = cv::Mat(2, 32, CV_8UC1, cv::Scalar(fill));
      p.maps.push_back(std::move(m));
    }
    p.commands.push_back({0.0, visnav::Twist{speed_mps, 0.1}});
    p.commands.push_back({length_m, visnav::Twist{}});
    return p;
  };
  const fr::LocalMapPath teach = path(4.0, 0.5, 1);
  const fr::LocalMapPath drive = path(3.6, 0.8, 7);
  auto body = fr::experience_from_drive(fr::kLocalMapsKind, teach.serialize(), drive.serialize());
  ASSERT_TRUE(body.ok()) << body.error().message;
  auto out = fr::LocalMapPath::deserialize(*body);
  ASSERT_TRUE(out.ok()) << out.error().message;
  EXPECT_DOUBLE_EQ(out->length_m, 4.0);
  ASSERT_EQ(out->maps.size(), 5u);
  EXPECT_NEAR(out->maps[2].distance_m, 2.0, 1e-9);
  EXPECT_NEAR(out->maps[4].distance_m, 4.0, 1e-9);
  EXPECT_EQ(out->maps[1].descriptors.at<std::uint8_t>(0, 0), 7);
  EXPECT_NEAR(out->command_at(1.0).linear_mps, 0.5, 1e-6) << "the route is the taught one";
}

TEST(DriveExperience, AnotherStretchAnotherKindOrGarbageIsRefusedWithItsCode) {
  const auto teach = segment(10.0, 0.0, 1).serialize();
  EXPECT_TRUE(fails_with(fr::experience_from_drive(fr::kSegmentKind, teach, segment(14.0, 0.0, 2).serialize()),
                         ErrorCode::inconsistent));
  EXPECT_TRUE(fails_with(fr::experience_from_drive(fr::kSegmentKind, teach, segment(7.0, 0.0, 2).serialize()),
                         ErrorCode::inconsistent));
  EXPECT_TRUE(fr::experience_from_drive(fr::kSegmentKind, teach, segment(14.0, 0.0, 2).serialize(), 0.5).ok())
      << "the tolerance is the caller's";
  EXPECT_TRUE(fails_with(fr::experience_from_drive("path_following", teach, teach), ErrorCode::out_of_range));
  const std::vector<std::uint8_t> garbage = {1, 2, 3};
  EXPECT_TRUE(fails_with(fr::experience_from_drive(fr::kSegmentKind, teach, garbage), ErrorCode::parse_error));
  EXPECT_TRUE(fails_with(fr::experience_from_drive(fr::kLocalMapsKind, teach, teach), ErrorCode::parse_error));
}

}  // namespace
