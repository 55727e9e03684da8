#include "visnav/ipt_eval/sim_eval.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <random>

#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include <Eigen/Cholesky>

#include "visnav/ipt_obstacles/pipeline.hpp"
#include "visnav_sim/render.hpp"
#include "visnav_sim/world.hpp"

namespace visnav::ipt {

namespace vs = visnav::sim;

std::vector<RocRun> obstacle_course_runs() {
  const double deg = CV_PI / 180.0;
  return {
      {{0.0, 0.0, 0.0}, 3.0},         // towards crate_1 (x = 4), stops 0.5 m short of it
      {{4.6, 0.0, 0.0}, 2.6},         // crate_2 on the right, the two posts ahead
      {{8.5, -1.7, 0.0}, 8.0},        // along the parked van's side, 0.95 m from it
      {{14.5, 0.5, 0.0}, 6.0},        // the person on the right, the low box ahead left
      {{16.0, 3.5, -25.0 * deg}, 3.0},  // across the square towards the person
  };
}

namespace {

/// The rendered scene both evaluations run on: the world file and a pinhole model of the
/// camera at the given mount. Errors name the world or the model's bad value.
struct RenderedScene {
  std::shared_ptr<const vs::World> world;
  vs::CameraModel model;
};
Result<RenderedScene> rendered_scene(const std::string& world_name, int width_px, int height_px, double hfov_deg,
                                     double height_m, double pitch_down_deg) {
  VISNAV_ASSIGN(const std::string path, vs::resolve_world_path(world_name));
  RenderedScene scene;
  VISNAV_ASSIGN(scene.world, vs::load_world_cached(path));
  scene.model.width_px = width_px;
  scene.model.height_px = height_px;
  scene.model.hfov_deg = hfov_deg;
  scene.model.height_m = height_m;
  scene.model.pitch_down_deg = pitch_down_deg;
  VISNAV_TRY(scene.model.validate());
  return scene;
}

/// The IPT camera of a rendered model's intrinsics, mounted at `height_m` and `pitch_down_deg`.
IptCamera ipt_camera_of(const vs::CameraModel& model, double height_m, double pitch_down_deg) {
  IptCamera cam;
  cam.width_px = model.width_px;
  cam.height_px = model.height_px;
  cam.fx_px = cam.fy_px = model.fx();
  cam.cx_px = model.cx();
  cam.cy_px = model.cy();
  cam.height_m = height_m;
  cam.pitch_rad = -pitch_down_deg * CV_PI / 180.0;
  return cam;
}


bool is_ground_class(std::uint8_t label) {
  switch (static_cast<vs::LabelClass>(label)) {
    case vs::LabelClass::path:
    case vs::LabelClass::grass:
    case vs::LabelClass::floor:
    case vs::LabelClass::pavement:
    case vs::LabelClass::ground: return true;
    default: return false;
  }
}

/// +1 obstacle, 0 ground, −1 mixed neighbourhood (object border) or outside.
int truth_at(const cv::Mat& labels, const cv::Point2f& p) {
  const int u = static_cast<int>(std::lround(p.x)), v = static_cast<int>(std::lround(p.y));
  if (u < 1 || v < 1 || u >= labels.cols - 1 || v >= labels.rows - 1) return -1;
  int ground = 0, other = 0;
  for (int dv = -1; dv <= 1; ++dv)
    for (int du = -1; du <= 1; ++du) (is_ground_class(labels.at<std::uint8_t>(v + dv, u + du)) ? ground : other)++;
  if (ground > 0 && other > 0) return -1;
  return other > 0 ? 1 : 0;
}

Pose2D advance(const Pose2D& p, double d_m) {
  return {p.x_m + d_m * std::cos(p.heading_rad), p.y_m + d_m * std::sin(p.heading_rad), p.heading_rad};
}

struct Sample {
  int truth;        // 1 obstacle, 0 ground
  double score;     // D, +inf above the horizon
};

/// Area under recall(fall-out) as β sweeps: Mann-Whitney with ties counted half.
double auc(std::vector<Sample> samples) {
  std::sort(samples.begin(), samples.end(), [](const Sample& a, const Sample& b) { return a.score < b.score; });
  long pos = 0, neg = 0;
  for (const auto& s : samples) (s.truth != 0 ? pos : neg)++;
  if (pos == 0 || neg == 0) return 0.0;
  double rank_sum = 0.0;
  for (std::size_t i = 0; i < samples.size();) {
    std::size_t j = i;
    while (j < samples.size() && samples[j].score == samples[i].score) ++j;
    const double mid_rank = 0.5 * static_cast<double>(i + 1 + j);  // 1-based average rank
    for (std::size_t k = i; k < j; ++k)
      if (samples[k].truth != 0) rank_sum += mid_rank;
    i = j;
  }
  return (rank_sum - 0.5 * static_cast<double>(pos) * static_cast<double>(pos + 1)) /
         (static_cast<double>(pos) * static_cast<double>(neg));
}

}  // namespace

void draw_classification(cv::Mat& bgr, const std::vector<ClassifiedFeature>& features,
                         const std::vector<ContactPoint>& contacts) {
  for (const auto& f : features) {
    const cv::Scalar colour = f.label == FeatureClass::obstacle ? cv::Scalar(0, 0, 255)
                              : f.label == FeatureClass::ground  ? cv::Scalar(255, 80, 0)
                                                                 : cv::Scalar(0, 220, 255);
    cv::circle(bgr, f.pixel, 2, colour, cv::FILLED, cv::LINE_AA);
  }
  for (const auto& c : contacts) cv::drawMarker(bgr, c.pixel, cv::Scalar(255, 0, 255), cv::MARKER_CROSS, 7, 1);
}

namespace {

// FAST corners described by the 16 pixels of their radius-3 Bresenham circle (the thesis's
// FAST + 16-pixel SSD tracker, spec §11 item 26).
constexpr std::array<std::array<int, 2>, 16> kCircle{{{0, -3}, {1, -3}, {2, -2}, {3, -1}, {3, 0}, {3, 1}, {2, 2}, {1, 3},
                                                      {0, 3}, {-1, 3}, {-2, 2}, {-3, 1}, {-3, 0}, {-3, -1}, {-2, -2}, {-1, -3}}};

void fast_circles(const cv::Mat& grey, int max_features, std::vector<cv::KeyPoint>& keypoints,
                  std::vector<std::array<float, 16>>& circles) {
  cv::FAST(grey, keypoints, 20, true);
  cv::KeyPointsFilter::runByImageBorder(keypoints, grey.size(), 4);
  cv::KeyPointsFilter::retainBest(keypoints, max_features);
  circles.resize(keypoints.size());
  for (std::size_t i = 0; i < keypoints.size(); ++i) {
    const cv::Point c(cvRound(keypoints[i].pt.x), cvRound(keypoints[i].pt.y));
    for (std::size_t k = 0; k < kCircle.size(); ++k) circles[i][k] = grey.at<std::uint8_t>(c + cv::Point(kCircle[k][0], kCircle[k][1]));
  }
}

float ssd(const std::array<float, 16>& a, const std::array<float, 16>& b) {
  float sum = 0.0f;
  for (std::size_t k = 0; k < a.size(); ++k) sum += (a[k] - b[k]) * (a[k] - b[k]);
  return sum;
}

// Matches of the pair by a detector/descriptor tracker (not "klt"): a → b before RANSAC.
// Returns the number of features detected in the first frame.
long descriptor_matches(const cv::Mat& grey0, const cv::Mat& grey1, const RocOptions& options,
                        std::vector<cv::Point2f>& a, std::vector<cv::Point2f>& b) {
  a.clear();
  b.clear();
  std::vector<cv::KeyPoint> k0, k1;
  if (options.tracker == "fast") {
    std::vector<std::array<float, 16>> c0, c1;
    fast_circles(grey0, options.max_features, k0, c0);
    fast_circles(grey1, options.max_features, k1, c1);
    constexpr float kSearchPx = 30.0f;
    auto best = [&](const std::vector<cv::KeyPoint>& from, const std::vector<std::array<float, 16>>& cf, std::size_t i,
                    const std::vector<cv::KeyPoint>& to, const std::vector<std::array<float, 16>>& ct) {
      int found = -1;
      float best_ssd = std::numeric_limits<float>::max();
      for (std::size_t j = 0; j < to.size(); ++j) {
        if (std::abs(to[j].pt.x - from[i].pt.x) > kSearchPx || std::abs(to[j].pt.y - from[i].pt.y) > kSearchPx) continue;
        const float d = ssd(cf[i], ct[j]);
        if (d < best_ssd) {
          best_ssd = d;
          found = static_cast<int>(j);
        }
      }
      return found;
    };
    for (std::size_t i = 0; i < k0.size(); ++i) {
      const int j = best(k0, c0, i, k1, c1);
      if (j < 0 || best(k1, c1, static_cast<std::size_t>(j), k0, c0) != static_cast<int>(i)) continue;
      a.push_back(k0[i].pt);
      b.push_back(k1[static_cast<std::size_t>(j)].pt);
    }
    return static_cast<long>(k0.size());
  }
  cv::Ptr<cv::Feature2D> detector;
  int norm = cv::NORM_L2;
  if (options.tracker == "sift") {
    detector = cv::SIFT::create(options.max_features);
  } else {
    detector = cv::ORB::create(options.max_features);
    norm = cv::NORM_HAMMING;
  }
  cv::Mat d0, d1;
  detector->detectAndCompute(grey0, cv::noArray(), k0, d0);
  detector->detectAndCompute(grey1, cv::noArray(), k1, d1);
  if (d0.empty() || d1.rows < 2) return static_cast<long>(k0.size());
  cv::BFMatcher matcher(norm);
  std::vector<std::vector<cv::DMatch>> knn;
  matcher.knnMatch(d0, d1, knn, 2);
  for (const auto& m : knn) {
    if (m.size() < 2 || m[0].distance > 0.8f * m[1].distance) continue;
    a.push_back(k0[static_cast<std::size_t>(m[0].queryIdx)].pt);
    b.push_back(k1[static_cast<std::size_t>(m[0].trainIdx)].pt);
  }
  return static_cast<long>(k0.size());
}

/// evaluate_classifier's running totals: the report and the samples of the AUC and the β sweep.
struct RocTally {
  RocReport report;
  std::vector<Sample> samples;
  std::vector<double> d_ground, d_obstacle;  // D of features below the guard band, for the β sweep
  long above_horizon_pos = 0, above_horizon_neg = 0;
};

Status check_roc_options(const RocOptions& options) {
  VISNAV_TRY(options.classifier.validate());
  VISNAV_TRY(options.profiles.validate());
  VISNAV_TRY(options.tracking.validate());
  if (!(options.step_m > 0.0) || !(options.pair_every_m > 0.0) || options.max_features < 8)
    return Error{"ipt-roc: step_m and pair_every_m must be > 0 and max_features >= 8", ErrorCode::out_of_range};
  if (options.tracker != "klt" && options.tracker != "sift" && options.tracker != "orb" && options.tracker != "fast")
    return Error{"ipt-roc: unknown tracker '" + options.tracker + "' (known: klt, sift, orb, fast)", ErrorCode::out_of_range};
  return ok();
}

/// Tracks the pair with options.tracker (with the epipolar check of `motion`) into ia → ib;
/// adds the features detected to the report. Returns the outliers dropped.
int track_roc_pair(const cv::Mat& grey0, const cv::Mat& grey1, const RocOptions& options,
                   const PipelineParams& tracking, const OdometryEpipolar& motion, std::vector<cv::Point2f>& ia,
                   std::vector<cv::Point2f>& ib, TrackScratch& tracks, RocReport& report) {
  int outliers = 0;
  if (options.tracker == "klt") {
    outliers = track_pair(grey0, grey1, tracking, ia, ib, tracks, &motion);
    report.detected += static_cast<long>(tracks.corners.size());
  } else {
    report.detected += descriptor_matches(grey0, grey1, options, ia, ib);
    outliers = reject_epipolar_outliers(ia, ib, tracking, tracks.inliers, &motion);
  }
  return outliers;
}

/// Scores the pair's classified features against the renderer's labels of its second frame.
void tally_classified(const std::vector<ClassifiedFeature>& classified, const cv::Mat& labels1, RocTally& tally) {
  RocReport& report = tally.report;
  Counts& c = report.at_operating_point;
  for (const auto& f : classified) {
    const int truth = truth_at(labels1, cv::Point2f(static_cast<float>(f.pixel.x), static_cast<float>(f.pixel.y)));
    if (truth < 0) {
      ++c.border;
      continue;
    }
    ++report.features;
    const bool obstacle = truth == 1;
    auto count = [&](Counts& k) {
      switch (f.label) {
        case FeatureClass::obstacle: (obstacle ? k.tp : k.fp)++; break;
        case FeatureClass::ground: (obstacle ? k.fn : k.tn)++; break;
        case FeatureClass::unclassified: (obstacle ? k.unclassified_obstacle : k.unclassified_ground)++; break;
      }
    };
    count(c);
    if (f.reason != ClassReason::above_horizon && f.reason != ClassReason::guard_band) count(report.below_horizon);
    if (f.reason == ClassReason::above_horizon) {
      tally.samples.push_back({truth, std::numeric_limits<double>::infinity()});
      (obstacle ? tally.above_horizon_pos : tally.above_horizon_neg)++;
    } else if (f.discrepancy_m >= 0.0 && f.reason != ClassReason::beyond_range) {
      tally.samples.push_back({truth, f.discrepancy_m});
      (obstacle ? tally.d_obstacle : tally.d_ground).push_back(f.discrepancy_m);
    }
  }
}

/// The contact points of the pair's second frame; counts them, and those within 3 px of an
/// obstacle (not ground, not sky) pixel of the labels.
std::vector<ContactPoint> tally_contacts(const cv::Mat& grey1, const cv::Mat& labels1,
                                         const std::vector<ClassifiedFeature>& classified, const IptCamera& cam,
                                         const Pose2D& p1_odo, const RocOptions& options, cv::Mat& edges,
                                         EdgeScratch& scratch, RocReport& report) {
  reduced_canny(grey1, options.profiles, edges, scratch);
  auto contacts = contact_points(edges, classified, cam, p1_odo, options.profiles);
  report.contact_points += static_cast<long>(contacts.size());
  for (const auto& cp : contacts) {
    const int u = static_cast<int>(cp.pixel.x), v = static_cast<int>(cp.pixel.y);
    bool near_obstacle = false;
    for (int dv = -3; dv <= 3 && !near_obstacle; ++dv)
      for (int du = -3; du <= 3 && !near_obstacle; ++du) {
        const int uu = u + du, vv = v + dv;
        if (uu >= 0 && vv >= 0 && uu < labels1.cols && vv < labels1.rows &&
            !is_ground_class(labels1.at<std::uint8_t>(vv, uu)) &&
            static_cast<vs::LabelClass>(labels1.at<std::uint8_t>(vv, uu)) != vs::LabelClass::sky)
          near_obstacle = true;
      }
    if (near_obstacle) ++report.contact_points_on_obstacle_base;
  }
  return contacts;
}

/// The AUCs without and with the D band, and the β minimising FP + 0.5·FN, from the samples.
void finish_roc_report(const RocOptions& options, RocTally& tally) {
  RocReport& report = tally.report;
  const std::vector<Sample>& samples = tally.samples;
  report.auc_without_band = auc(samples);
  // With the band filter kept: features whose D falls in a stored band leave the set.
  std::vector<Sample> kept;
  for (const auto& s : samples) {
    bool in_band = false;
    const auto& bands = options.classifier.unclassified_bands_m;
    for (std::size_t i = 0; i + 1 < bands.size(); i += 2) in_band |= s.score > bands[i] && s.score <= bands[i + 1];
    if (!in_band) kept.push_back(s);
  }
  report.auc_with_band = auc(kept);
  // β sweep, f(β) = FP + 0.5·FN (thesis §4.3), band off; above-horizon features are constant.
  const std::vector<double>& d_ground = tally.d_ground;
  const std::vector<double>& d_obstacle = tally.d_obstacle;
  double best_cost = std::numeric_limits<double>::infinity();
  for (int mm = 0; mm <= 300; ++mm) {
    const double beta = mm * 1e-3;
    const double fp = static_cast<double>(tally.above_horizon_neg +
                                          std::count_if(d_ground.begin(), d_ground.end(), [&](double d) { return d > beta; }));
    const double fn = static_cast<double>(std::count_if(d_obstacle.begin(), d_obstacle.end(), [&](double d) { return d <= beta; }));
    const double cost = fp + 0.5 * fn;
    if (cost < best_cost) {
      best_cost = cost;
      report.best_beta_m = beta;
    }
  }
}

}  // namespace

Result<RocReport> evaluate_classifier(const RocOptions& options, cv::Mat* picture) {
  VISNAV_TRY(check_roc_options(options));
  VISNAV_ASSIGN(const RenderedScene scene, rendered_scene(options.world, options.width_px, options.height_px,
                                                         options.hfov_deg, options.mount_height_m, options.pitch_down_deg));
  const auto& world = scene.world;
  const vs::CameraModel& model = scene.model;
  const IptCamera cam = ipt_camera_of(model, model.height_m, model.pitch_down_deg);
  VISNAV_TRY(cam.validate());

  vs::Renderer renderer(world, model);
  cv::RNG pixel_rng(static_cast<std::uint64_t>(options.seed) * 7919u + 1u);
  std::mt19937_64 odo_rng(static_cast<std::uint64_t>(options.seed));
  std::normal_distribution<double> unit(0.0, 1.0);
  cv::Mat bgr0, bgr1, grey0, grey1, labels0, labels1, noise, edges;
  EdgeScratch scratch;
  TrackScratch tracks;
  auto render_grey = [&](const Pose2D& pose, cv::Mat& bgr, cv::Mat& grey, cv::Mat& labels) {
    renderer.render(pose, bgr, &labels);
    if (options.noise_std > 0.0) {
      noise.create(bgr.size(), CV_16SC3);
      pixel_rng.fill(noise, cv::RNG::NORMAL, 0.0, options.noise_std);
      cv::Mat sum;
      cv::add(bgr, noise, sum, cv::noArray(), CV_16SC3);
      sum.convertTo(bgr, CV_8UC3);
    }
    cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  };

  RocTally tally;
  RocReport& report = tally.report;
  int run_index = -1;
  for (const RocRun& run : options.runs) {
    ++run_index;
    for (double s = 0.0; s + options.step_m <= run.length_m + 1e-9; s += options.pair_every_m) {
      const Pose2D p0 = advance(run.start, s), p1 = advance(p0, options.step_m);
      render_grey(p0, bgr0, grey0, labels0);
      render_grey(p1, bgr1, grey1, labels1);
      std::vector<cv::Point2f> ia, ib;
      PipelineParams tracking = options.tracking;
      tracking.max_features = options.max_features;
      const auto started = std::chrono::steady_clock::now();
      // odometry: the true relative motion plus noise (also the epipolar check's lens motion)
      Pose2D p1_odo = p1;
      p1_odo.x_m += options.odom_position_sd_m * unit(odo_rng);
      p1_odo.y_m += options.odom_position_sd_m * unit(odo_rng);
      p1_odo.heading_rad += options.odom_heading_sd_rad * unit(odo_rng);
      const OdometryEpipolar motion{cam, lens_pose(cam, p0), lens_pose(cam, p1_odo)};
      const int outliers = track_roc_pair(grey0, grey1, options, tracking, motion, ia, ib, tracks, report);
      report.tracking_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - started).count();
      report.matched += static_cast<long>(ia.size()) + outliers;
      report.inliers += static_cast<long>(ia.size());
      report.at_operating_point.ransac_outliers += outliers;
      if (ia.size() < 8) continue;
      VISNAV_ASSIGN(auto classified, classify_features(cam, lens_pose(cam, p0), lens_pose(cam, p1_odo), ia, ib,
                                                       options.classifier));
      ++report.pairs;
      tally_classified(classified, labels1, tally);
      const auto contacts = tally_contacts(grey1, labels1, classified, cam, p1_odo, options, edges, scratch, report);
      if (picture != nullptr && (options.picture_run < 0 || options.picture_run == run_index)) {
        *picture = bgr1.clone();
        draw_classification(*picture, classified, contacts);
      }
    }
  }
  finish_roc_report(options, tally);
  return report;
}

Result<CalibrationResult> calibrate_on_rendered_frames(const CalibrationRunOptions& options) {
  VISNAV_ASSIGN(const RenderedScene scene, rendered_scene(options.world, options.width_px, options.height_px,
                                                         options.hfov_deg, options.true_height_m,
                                                         options.true_pitch_down_deg));
  const auto& world = scene.world;
  const vs::CameraModel& model = scene.model;
  vs::Renderer renderer(world, model);
  cv::RNG rng(static_cast<std::uint64_t>(options.seed) * 104729u + 3u);
  cv::Mat bgr, noise, grey_a, grey_b;
  TrackScratch tracks;
  auto render = [&](const Pose2D& pose, cv::Mat& grey) {
    renderer.render(pose, bgr);
    if (options.noise_std > 0.0) {
      noise.create(bgr.size(), CV_16SC3);
      rng.fill(noise, cv::RNG::NORMAL, 0.0, options.noise_std);
      cv::Mat sum;
      cv::add(bgr, noise, sum, cv::noArray(), CV_16SC3);
      sum.convertTo(bgr, CV_8UC3);
    }
    cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  };
  std::vector<CalibrationPair> pairs;
  for (int k = 0; k < options.pairs; ++k) {
    CalibrationPair p;
    p.pose_a = advance(options.start, k * options.spacing_m);
    p.pose_b = advance(p.pose_a, options.baseline_m);
    render(p.pose_a, grey_a);
    render(p.pose_b, grey_b);
    (void)track_pair(grey_a, grey_b, PipelineParams{}, p.pixels_a, p.pixels_b, tracks);
    if (p.pixels_a.size() < 8) continue;
    pairs.push_back(std::move(p));
  }
  return calibrate_height_pitch(ipt_camera_of(model, options.guess_height_m, options.guess_pitch_down_deg), pairs);
}

Result<EkfRunReport> evaluate_ground_odometry(const EkfRunOptions& options) {
  VISNAV_TRY(options.filter.validate());
  if (!(options.frame_step_m > 0.0 && options.frame_step_m <= 0.2) || !(options.run.length_m > 0.0) ||
      !std::isfinite(options.turn_deg_per_m) || !(std::fabs(options.odom_scale_error) < 0.5) ||
      !(std::fabs(options.odom_heading_bias_rad_per_m) < 1.0))
    return Error{"ipt-ekf: frame_step_m must be in (0, 0.2], the run's length > 0, |scale error| < 0.5 and "
                 "|heading bias| < 1 rad/m",
                 ErrorCode::out_of_range};
  VISNAV_ASSIGN(RenderedScene scene, rendered_scene(options.world, options.width_px, options.height_px,
                                                   options.hfov_deg, options.mount_height_m, options.pitch_down_deg));
  if (!options.obstacles_path.empty()) {
    VISNAV_ASSIGN(const std::string path, vs::resolve_world_path(options.world));
    VISNAV_ASSIGN(scene.world, vs::load_world_with_obstacles(path, options.obstacles_path));
  }
  const IptCamera cam = ipt_camera_of(scene.model, scene.model.height_m, scene.model.pitch_down_deg);
  VISNAV_TRY(cam.validate());
  VISNAV_ASSIGN(ObstaclePipeline pipeline, ObstaclePipeline::create(cam, PipelineParams{}, ClassifierParams{}, ProfileParams{}));
  VISNAV_ASSIGN(GroundOdometry filter, GroundOdometry::create(cam, options.filter));

  vs::Renderer renderer(scene.world, scene.model);
  cv::RNG pixel_rng(static_cast<std::uint64_t>(options.seed) * 6133u + 5u);
  std::mt19937_64 odo_rng(static_cast<std::uint64_t>(options.seed) * 31u + 7u);
  std::normal_distribution<double> unit(0.0, 1.0);
  cv::Mat bgr, noise, sum, grey;
  auto render = [&](const Pose2D& pose) {
    renderer.render(pose, bgr);
    if (options.noise_std > 0.0) {
      noise.create(bgr.size(), CV_16SC3);
      pixel_rng.fill(noise, cv::RNG::NORMAL, 0.0, options.noise_std);
      cv::add(bgr, noise, sum, cv::noArray(), CV_16SC3);
      sum.convertTo(bgr, CV_8UC3);
    }
    cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  };
  auto compose = [](const Pose2D& p, double dx, double dy, double dth) {
    const double c = std::cos(p.heading_rad), s = std::sin(p.heading_rad);
    return Pose2D{p.x_m + c * dx - s * dy, p.y_m + s * dx + c * dy, std::remainder(p.heading_rad + dth, 2.0 * CV_PI)};
  };

  EkfRunReport report;
  Pose2D truth = options.run.start, odometry = options.run.start;
  filter.reset(odometry);
  const double turn_rad_per_m = options.turn_deg_per_m * CV_PI / 180.0;
  const double sd_t = options.filter.translation_sd_per_m * options.frame_step_m;
  const double sd_h = options.filter.heading_sd_rad_per_m * options.frame_step_m;
  double nees_sum = 0.0, observations = 0.0, wall_ms = 0.0;
  const int frames = static_cast<int>(std::floor(options.run.length_m / options.frame_step_m + 1e-9)) + 1;
  for (int k = 0; k < frames; ++k) {
    if (k > 0) {
      // True increment: an arc of frame_step_m (chord at half the turn), then what the wheels report.
      const double dth = turn_rad_per_m * options.frame_step_m;
      const double dx = options.frame_step_m * std::cos(dth / 2), dy = options.frame_step_m * std::sin(dth / 2);
      truth = compose(truth, dx, dy, dth);
      double ox = dx * (1.0 + options.odom_scale_error), oy = dy * (1.0 + options.odom_scale_error);
      double oth = dth + options.odom_heading_bias_rad_per_m * options.frame_step_m;
      if (options.odom_noise) {
        const double nx = unit(odo_rng);
        const double ny = unit(odo_rng);
        const double nh = unit(odo_rng);
        ox += sd_t * nx;
        oy += sd_t * ny;
        oth += sd_h * nh;
      }
      odometry = compose(odometry, ox, oy, oth);
    }
    render(truth);
    const auto t0 = std::chrono::steady_clock::now();
    VISNAV_ASSIGN(auto pair, pipeline.process(grey, odometry));
    if (pair) {
      // A rejected update follows the odometry for that pair.
      (void)filter.add_pair(pair->first_pose, pair->pose, pair->features);
      ++report.pairs;
      observations += filter.last_observations();
      // NEES in the start frame (the filter's world frame).
      const Pose2D f = filter.pose();
      const double c0 = std::cos(options.run.start.heading_rad), s0 = std::sin(options.run.start.heading_rad);
      const double ex = f.x_m - truth.x_m, ey = f.y_m - truth.y_m;
      const Eigen::Vector3d e(c0 * ex + s0 * ey, -s0 * ex + c0 * ey, std::remainder(f.heading_rad - truth.heading_rad, 2.0 * CV_PI));
      const Eigen::Matrix3d P = filter.covariance();
      nees_sum += e.dot(P.ldlt().solve(e));
    }
    wall_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  }
  report.frames = frames;
  report.mean_observations = report.pairs > 0 ? observations / report.pairs : 0.0;
  report.mean_nees = report.pairs > 0 ? nees_sum / report.pairs : 0.0;
  report.ms_per_pair = report.pairs > 0 ? wall_ms / report.pairs : 0.0;
  report.truth_end = truth;
  report.odometry_end = odometry;
  report.filter_end = filter.pose();
  const double c0 = std::cos(options.run.start.heading_rad), s0 = std::sin(options.run.start.heading_rad);
  auto errors = [&](const Pose2D& p, double& along, double& lateral, double& heading) {
    const double ex = p.x_m - truth.x_m, ey = p.y_m - truth.y_m;
    along = c0 * ex + s0 * ey;
    lateral = -s0 * ex + c0 * ey;
    heading = std::remainder(p.heading_rad - truth.heading_rad, 2.0 * CV_PI);
  };
  errors(odometry, report.odometry_along_error_m, report.odometry_lateral_error_m, report.odometry_heading_error_rad);
  errors(report.filter_end, report.filter_along_error_m, report.filter_lateral_error_m, report.filter_heading_error_rad);
  return report;
}

}  // namespace visnav::ipt
