// Start-view search (start_view_search.hpp).
#include "visnav/feature_replay/start_view_search.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>

#include "visnav/primitive.hpp"

namespace visnav::feature_replay {
namespace {

std::string format_double(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.3f", v);
  return buf;
}

std::string degrees(double rad) { return format_double(rad * 180.0 / std::numbers::pi); }

}  // namespace

void StartViewSearch::begin(const StartViewSearchParams& params, double started_m) {
  params_ = params;
  scan_rad_ = params.scan_rad;
  if (params.max_heading_deviation_rad > 0.0)
    scan_rad_ = std::min(scan_rad_, params.max_heading_deviation_rad - StartViewSearchParams::kHeadingMarginRad);
  phase_ = started_m >= 0.3 ? Phase::driving : scan_rad_ > 0.0 ? Phase::probe : Phase::watch;
  sample_count_ = 0;
  look_frames_ = 0;
  look_confidence_sum_ = 0.0;
  look_offset_sum_ = 0.0;
  best_confidence_ = -1.0;
  best_score_ = -1.0;
  best_turn_rad_ = 0.0;
  scan_turned_rad_ = 0.0;
}

bool StartViewSearch::look(double confidence, double offset_fraction, bool& seen, double& mean_confidence,
                           double& mean_offset) {
  look_confidence_sum_ += confidence;
  look_offset_sum_ += confidence > 0.0 ? offset_fraction : 1.0;
  if (++look_frames_ < 3) return false;
  mean_confidence = look_confidence_sum_ / look_frames_;
  mean_offset = look_offset_sum_ / look_frames_;
  seen = mean_confidence >= params_.min_confidence && mean_offset <= params_.max_offset;
  look_frames_ = 0;
  look_confidence_sum_ = 0.0;
  look_offset_sum_ = 0.0;
  return true;
}

double StartViewSearch::prior(double turn_rad) const {
  if (params_.prior_sd_rad <= 0.0) return 1.0;
  const double t = turn_rad / params_.prior_sd_rad;
  return std::exp(-0.5 * t * t);
}

bool StartViewSearch::is_peak(std::size_t i) const {
  const ScanSample& s = samples_[i];
  if (s.score <= 0.0F) return false;
  for (std::size_t k = 0; k < sample_count_; ++k)
    if (std::abs(samples_[k].turn_rad - s.turn_rad) <= kPeakWindowRad && samples_[k].score > s.score) return false;
  return true;
}

void StartViewSearch::choose_best(double& runner_up_score, double& runner_up_turn_rad) {
  // The peak (a heading that matched best within kPeakWindowRad) that is the likeliest start
  // view: its score weighted by the prior. The whole sweep is in the samples (scan_right passes
  // the range once), so every peak is seen.
  runner_up_score = -1.0;
  runner_up_turn_rad = 0.0;
  if (sample_count_ == 0) return;
  double best_weighted = -1.0;
  std::size_t best = sample_count_;
  for (std::size_t i = 0; i < sample_count_; ++i) {
    if (!is_peak(i)) continue;
    const double w = samples_[i].score * prior(samples_[i].turn_rad);
    if (w > best_weighted) {
      best_weighted = w;
      best = i;
    }
  }
  if (best == sample_count_) return;
  best_turn_rad_ = samples_[best].turn_rad;
  best_score_ = samples_[best].score;
  best_confidence_ = samples_[best].confidence;
  for (std::size_t i = 0; i < sample_count_; ++i)
    if (std::abs(samples_[i].turn_rad - best_turn_rad_) >= StartViewSearchParams::kAmbiguitySeparationRad &&
        samples_[i].score > runner_up_score) {
      runner_up_score = samples_[i].score;
      runner_up_turn_rad = samples_[i].turn_rad;
    }
}

void StartViewSearch::unwrap(double heading_rad) {
  scan_turned_rad_ += wrap_angle_rad(heading_rad - scan_last_rad_);
  scan_last_rad_ = heading_rad;
}

std::optional<Twist> StartViewSearch::update(double heading_rad, double confidence, double offset_fraction,
                                             bool informative, Logger& logger, const std::string& who,
                                             const std::string& edge_id) {
  if ((phase_ == Phase::probe || phase_ == Phase::watch) && !informative) phase_ = Phase::driving;
  auto turn = [](double w) { return std::optional<Twist>(Twist{0.0, w}); };
  auto track = [&]() {
    unwrap(heading_rad);
    const double score = confidence * std::max(0.0, 1.0 - 2.0 * offset_fraction);
    if (sample_count_ < samples_.size())
      samples_[sample_count_++] = ScanSample{static_cast<float>(scan_turned_rad_), static_cast<float>(score),
                                             static_cast<float>(confidence)};
  };
  // Turning in place to `target` (turned angle since the scan started); true once there.
  auto turned_to = [&](double target, std::optional<Twist>& command) {
    unwrap(heading_rad);
    const double left = target - scan_turned_rad_;
    if (std::abs(left) > 0.03) {
      command = turn(std::copysign(std::min(params_.scan_speed_radps, 0.2 + std::abs(left)), left));
      return false;
    }
    return true;
  };
  bool seen = false;
  double mean_confidence = 0.0;
  double mean_offset = 0.0;
  switch (phase_) {
    case Phase::watch: {
      // Scan off: look at the first frames while driving, and only say what was seen.
      if (!look(confidence, offset_fraction, seen, mean_confidence, mean_offset)) return std::nullopt;
      if (!seen)
        logger.warn(who, "edge " + edge_id + ": start view not seen at the start (confidence " +
                             format_double(mean_confidence) + ", offset " + format_double(mean_offset) +
                             " of the width): the robot may have started away from the taught start; driving on "
                             "(the start-view scan is off)");
      phase_ = Phase::driving;
      return std::nullopt;
    }
    case Phase::probe: {
      // Three frames standing at the start: is the taught start view there?
      if (!look(confidence, offset_fraction, seen, mean_confidence, mean_offset)) return turn(0.0);
      if (seen) {
        phase_ = Phase::driving;
        return std::nullopt;
      }
      logger.warn(who, "edge " + edge_id + ": start view not seen ahead (confidence " + format_double(mean_confidence) +
                           ", offset " + format_double(mean_offset) + " of the width); searching by turning +-" +
                           degrees(scan_rad_) + " deg");
      phase_ = Phase::scan_left;
      sample_count_ = 0;
      scan_last_rad_ = heading_rad;
      scan_turned_rad_ = 0.0;
      best_confidence_ = -1.0;
      best_score_ = -1.0;
      track();
      return turn(params_.scan_speed_radps);
    }
    case Phase::scan_left:
      track();
      if (scan_turned_rad_ < scan_rad_) return turn(params_.scan_speed_radps);
      phase_ = Phase::scan_right;
      return turn(-params_.scan_speed_radps);
    case Phase::scan_right: {
      track();
      if (scan_turned_rad_ > -scan_rad_) return turn(-params_.scan_speed_radps);
      double second_score = -1.0;
      double second_turn_rad = 0.0;
      choose_best(second_score, second_turn_rad);
      if (best_confidence_ < params_.min_confidence) {
        // Nothing matched anywhere: start on the odometric heading and leave it to the lost
        // policy (a stretch that was hard to see when taught may still be driven on odometry).
        logger.warn(who, "edge " + edge_id + ": start view not found within +-" + degrees(scan_rad_) +
                             " deg; starting on the odometric heading");
        phase_ = Phase::turn_back;
      } else if (second_score >= StartViewSearchParams::kAmbiguityRatio * best_score_) {
        logger.warn(who, "edge " + edge_id + ": the scan is ambiguous: the likeliest match, " + degrees(best_turn_rad_) +
                             " deg from the odometric heading (score " + format_double(best_score_) + "), and one " +
                             degrees(second_turn_rad) + " deg from it (score " + format_double(second_score) +
                             ") match alike (a repeating scene); starting on the odometric heading");
        phase_ = Phase::turn_back;
      } else {
        phase_ = Phase::turn_to_best;
      }
      return turn(params_.scan_speed_radps);
    }
    case Phase::turn_to_best: {
      std::optional<Twist> command;
      if (!turned_to(best_turn_rad_, command)) return command;
      phase_ = Phase::confirm;
      return turn(0.0);
    }
    case Phase::confirm: {
      // The second look, standing still at the best heading.
      if (!look(confidence, offset_fraction, seen, mean_confidence, mean_offset)) return turn(0.0);
      if (seen) {
        logger.info(who, "edge " + edge_id + ": start view found " + degrees(scan_turned_rad_) +
                             " deg from the odometric heading (confidence " + format_double(mean_confidence) + ")");
        phase_ = Phase::driving;
        return std::nullopt;
      }
      logger.warn(who, "edge " + edge_id + ": the best match of the scan, " + degrees(best_turn_rad_) +
                           " deg from the odometric heading (confidence " + format_double(best_confidence_) +
                           "), is not there standing still (confidence " + format_double(mean_confidence) + ", offset " +
                           format_double(mean_offset) + "); starting on the odometric heading");
      phase_ = Phase::turn_back;
      return turn(0.0);
    }
    case Phase::turn_back: {
      std::optional<Twist> command;
      if (!turned_to(0.0, command)) return command;
      phase_ = Phase::driving;
      return std::nullopt;
    }
    case Phase::driving: break;
  }
  return std::nullopt;
}

}  // namespace visnav::feature_replay
