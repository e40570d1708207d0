#include "bench/track/default_rule.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "common/errors.h"
#include "common/testing.h"

namespace rrslam::bench {
namespace {

std::map<std::string, ReferenceFigure> SmallTable() {
  return {{"kitchen/pipeline", {4.0, 3.9, 4.4}},
          {"fr1_xyz/pipeline", {1.0, 0.9, 1.1}},
          {"synth-loop-clean", {2.0, 1.0, 3.0}}};
}

TEST(DefaultRuleTest, ScoreIsTheGeometricMeanOfTheRealRatios) {
  const RuleResult r = ApplyDefaultRule({{"kitchen/pipeline", true, 2.0},
                                         {"fr1_xyz/pipeline", true, 2.0},
                                         {"synth-loop-clean", false, 1.0}},
                                        SmallTable());
  ASSERT_EQ(r.cases.size(), 3u);
  EXPECT_EQ(r.real_cases, 2);
  // Ratios 0.5 and 2: geometric mean 1 (the synthetic case does not vote).
  EXPECT_NEAR(r.score, 1.0, 1e-12);
  EXPECT_NEAR(r.cases[0].ratio, 0.5, 1e-12);
  EXPECT_NEAR(r.cases[2].ratio, 0.5, 1e-12);
  // fr1_xyz at 2.0 is beyond ORB-SLAM2's worst run (1.1): not allowed.
  EXPECT_TRUE(r.cases[0].allowed);
  EXPECT_FALSE(r.cases[1].allowed);
  EXPECT_FALSE(r.conditions_hold);
}

TEST(DefaultRuleTest, RealCaseMayExceedTheMedianUpToTheWorstRun) {
  const RuleResult r = ApplyDefaultRule({{"fr1_xyz/pipeline", true, 1.05}}, SmallTable());
  ASSERT_EQ(r.cases.size(), 1u);
  EXPECT_TRUE(r.cases[0].allowed);
  EXPECT_TRUE(r.conditions_hold);
  EXPECT_NEAR(r.score, 1.05, 1e-12);
}

TEST(DefaultRuleTest, SyntheticGuardIsOrbSlam2sMedian) {
  EXPECT_TRUE(ApplyDefaultRule({{"synth-loop-clean", false, 2.0}}, SmallTable()).conditions_hold);
  const RuleResult r = ApplyDefaultRule({{"synth-loop-clean", false, 2.5}}, SmallTable());
  EXPECT_FALSE(r.conditions_hold);
  EXPECT_EQ(r.real_cases, 0);
  EXPECT_EQ(r.score, 0);
}

TEST(DefaultRuleTest, RunsWithoutReferenceAreListedNotScored) {
  const RuleResult r = ApplyDefaultRule(
      {{"fr2_desk/pipeline", true, 1.0}, {"kitchen/pipeline", true, 4.0}}, SmallTable());
  ASSERT_EQ(r.missing.size(), 1u);
  EXPECT_EQ(r.missing[0], "fr2_desk/pipeline");
  EXPECT_EQ(r.real_cases, 1);
  EXPECT_NEAR(r.score, 1.0, 1e-12);
}

TEST(DefaultRuleTest, ReadsTheTsvOfBenchOrbslam2) {
  testing::TempDir dir;
  const auto path = dir.path() / "orbslam2.tsv";
  std::ofstream(path)
      << "case\tvocabulary\truns\tate_cm\tmedian_cm\tmin_cm\tmax_cm\tposes\tframes\tloops\n"
      << "fr1_xyz/pipeline\tpipeline/fr1_xyz/voc.rrv\t3\t1.04,1.05,1.03\t1.04\t1.03\t1.05"
         "\t594\t594\t0\n";
  const auto table = ReadOrbSlam2Reference(path);
  ASSERT_EQ(table.size(), 1u);
  EXPECT_DOUBLE_EQ(table.at("fr1_xyz/pipeline").median_cm, 1.04);
  EXPECT_DOUBLE_EQ(table.at("fr1_xyz/pipeline").max_cm, 1.05);
}

TEST(DefaultRuleTest, RejectsMalformedTsvNamingTheLine) {
  testing::TempDir dir;
  const auto path = dir.path() / "bad.tsv";
  std::ofstream(path) << "case\tvocabulary\n"
                      << "fr1_xyz/pipeline\tv\t3\t1,2\t1.04\t1.10\t1.05\n";  // min > median
  try {
    ReadOrbSlam2Reference(path);
    FAIL() << "accepted min > median";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.tsv:2"), std::string::npos) << e.what();
  }
  std::ofstream(path) << "fr1_xyz/pipeline\tv\t3\n";
  EXPECT_THROW(ReadOrbSlam2Reference(path), DataError);
  EXPECT_THROW(ReadOrbSlam2Reference(dir.path() / "absent.tsv"), NoInputError);
}

}  // namespace
}  // namespace rrslam::bench
