// The rule for defaults (issue 30; docs/track.md, "Departures from
// ORB-SLAM2"): how a variant of rrslam-track is scored against ORB-SLAM2 run
// on the same inputs.
//
//  - score: the geometric mean over the real sequences (each with each of
//    its benchmark vocabularies) of rrslam's ATE / ORB-SLAM2's median ATE;
//    lower is better, 1 is ORB-SLAM2's level;
//  - a real sequence may not be worse than ORB-SLAM2's worst run there;
//  - a synthetic sequence may not be worse than ORB-SLAM2's median there
//    (a guard: synthetic sequences do not enter the score).
// A variant becomes the default when it lowers the score and keeps both
// conditions. ORB-SLAM2's figures come from `make bench-orbslam2`
// (bench/orbslam2/run.sh), committed to bench/results/ as TSV, so the score
// is computed without ORB-SLAM2 installed.
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "bench/common/bench_report.h"

namespace rrslam::bench {

// ORB-SLAM2's ATE RMSE on one case over its runs, centimetres.
struct ReferenceFigure {
  double median_cm = 0;
  double min_cm = 0;
  double max_cm = 0;
};

// Case name -> figure, from the TSV bench/orbslam2/run.sh writes (a header
// line, then `case vocabulary runs ate_cm median_cm min_cm max_cm ...` per
// line, tab-separated). Case names: "<real sequence>/<vocabulary pipeline>"
// (e.g. "fr1_xyz/pipeline-stride2-seed0") and "synth-<sequence folder>".
// Throws NoInputError when the file cannot be read, DataError (naming the
// file and line) when a line has too few fields or a figure is not a
// positive number.
std::map<std::string, ReferenceFigure> ReadOrbSlam2Reference(const std::filesystem::path& tsv);

// One of rrslam's runs: its case name (as above), whether it is a real
// sequence, and its ATE RMSE in centimetres.
struct RuleInput {
  std::string case_name;
  bool real = false;
  double ate_cm = 0;
};

struct RuleCase {
  RuleInput run;
  ReferenceFigure reference;
  double ratio = 0;      // run.ate_cm / reference.median_cm.
  bool allowed = false;  // Real: ate <= ORB-SLAM2's worst; synthetic: <= its median.
};

struct RuleResult {
  std::vector<RuleCase> cases;       // Runs with a reference figure, in input order.
  std::vector<std::string> missing;  // Runs without one (not scored).
  int real_cases = 0;
  double score = 0;             // Geometric mean of the real cases' ratios; 0 if none.
  bool conditions_hold = true;  // Every case allowed.
};

// Scores `runs` against `reference`.
RuleResult ApplyDefaultRule(const std::vector<RuleInput>& runs,
                            const std::map<std::string, ReferenceFigure>& reference);

// Adds the result to `report` under one section: each case's ratio against
// its condition, the runs without a reference, and the score against the goal
// of issue 30 (<= `score_goal`). `source` names the reference file.
void ReportDefaultRule(const RuleResult& result, const std::string& source, double score_goal,
                       Report* report);

}  // namespace rrslam::bench
