// Scoring of labelled pairs (align_score.hpp): the GRIEF protocol's error rate (no estimate
// counts as wrong), refusal rate, error among answered, and the gate curve.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "visnav/feature_replay/align_score.hpp"

using visnav::feature_replay::gate_curve;
using visnav::feature_replay::PairOutcome;
using visnav::feature_replay::score_pairs;

namespace {
PairOutcome answered(double offset, double confidence, double shift) { return {true, offset, confidence, shift}; }
}  // namespace

TEST(AlignScore, ThreeRatesByTheGriefProtocol) {
  const std::vector<PairOutcome> o = {
      answered(10.0, 0.9, 12.0),    // right
      answered(-40.0, 0.6, -40.0),  // right
      answered(100.0, 0.5, 30.0),   // answered, 70 px off: wrong
      answered(0.0, 0.1, 0.0),      // below the 0.25 gate: refused
      {false, 0.0, 0.0, 5.0},       // no estimate: refused
      answered(35.0, 0.3, 0.0),     // exactly 35 px off: right
  };
  const auto s = score_pairs(o, 0.25, 35.0);
  EXPECT_EQ(s.pairs, 6);
  EXPECT_EQ(s.answered, 4);
  EXPECT_EQ(s.refused, 2);
  EXPECT_EQ(s.wrong_answered, 1);
  EXPECT_EQ(s.wrong, 3);
  EXPECT_DOUBLE_EQ(s.error_rate, 0.5);
  EXPECT_DOUBLE_EQ(s.refusal_rate, 2.0 / 6.0);
  EXPECT_DOUBLE_EQ(s.answered_error_rate, 0.25);
  EXPECT_DOUBLE_EQ(s.precision, 0.75);
  // A tighter tolerance makes the 35 px pair wrong too.
  EXPECT_EQ(score_pairs(o, 0.25, 20.0).wrong_answered, 2);
  // Confidence 0 is never answered, even with the gate at 0.
  EXPECT_EQ(score_pairs(std::vector<PairOutcome>{answered(0.0, 0.0, 0.0)}, 0.0, 35.0).answered, 0);
  const auto none = score_pairs(std::vector<PairOutcome>{{false, 0.0, 0.0, 0.0}}, 0.25, 35.0);
  EXPECT_TRUE(std::isnan(none.answered_error_rate));
  EXPECT_DOUBLE_EQ(none.error_rate, 1.0);
}

TEST(AlignScore, GateCurveTradesCoverageForPrecision) {
  // Confident pairs right, weak ones wrong: raising the gate lowers coverage and raises precision.
  const std::vector<PairOutcome> o = {answered(0.0, 0.9, 0.0), answered(0.0, 0.8, 0.0), answered(200.0, 0.2, 0.0),
                                      answered(-200.0, 0.1, 0.0), {false, 0.0, 0.0, 0.0}};
  const auto c = gate_curve(o, 10, 35.0);
  ASSERT_EQ(c.size(), 11u);
  EXPECT_DOUBLE_EQ(c[0].min_confidence, 0.0);
  EXPECT_DOUBLE_EQ(c[10].min_confidence, 1.0);
  EXPECT_DOUBLE_EQ(c[0].coverage, 0.8);
  EXPECT_DOUBLE_EQ(c[0].precision, 0.5);
  EXPECT_DOUBLE_EQ(c[3].coverage, 0.4);  // gate 0.3
  EXPECT_DOUBLE_EQ(c[3].precision, 1.0);
  EXPECT_EQ(c[10].answered, 0);
  EXPECT_TRUE(std::isnan(c[10].precision));
  for (std::size_t i = 1; i < c.size(); ++i) EXPECT_LE(c[i].coverage, c[i - 1].coverage);
  // The point at a gate equals score_pairs at that gate.
  EXPECT_EQ(c[2].answered, score_pairs(o, 0.2, 35.0).answered);
}
