#include "bench/track/default_rule.h"

#include <cmath>
#include <sstream>

#include "common/atomic_file.h"
#include "common/errors.h"
#include "common/text.h"

namespace rrslam::bench {

namespace {

std::vector<std::string> SplitTabs(const std::string& line) {
  std::vector<std::string> fields;
  std::string field;
  std::istringstream in(line);
  while (std::getline(in, field, '\t')) fields.push_back(field);
  return fields;
}

}  // namespace

std::map<std::string, ReferenceFigure> ReadOrbSlam2Reference(const std::filesystem::path& tsv) {
  const std::string source = tsv.string();
  std::istringstream in(ReadFileToString(tsv));
  std::map<std::string, ReferenceFigure> reference;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.empty() || line[0] == '#' || line.rfind("case\t", 0) == 0) continue;
    // case vocabulary runs ate_cm median_cm min_cm max_cm (poses frames loops)
    const std::vector<std::string> f = SplitTabs(line);
    if (f.size() < 7) {
      throw DataError(source + ":" + std::to_string(number) +
                      ": expected at least 7 tab-separated " +
                      "fields (case vocabulary runs ate_cm median_cm min_cm max_cm), got " +
                      std::to_string(f.size()));
    }
    ReferenceFigure figure{ParseDouble(f[4], source, number), ParseDouble(f[5], source, number),
                           ParseDouble(f[6], source, number)};
    if (!(figure.min_cm > 0 && figure.min_cm <= figure.median_cm &&
          figure.median_cm <= figure.max_cm)) {
      throw DataError(source + ":" + std::to_string(number) +
                      ": ATE figures must be positive with min <= median <= max");
    }
    reference[f[0]] = figure;
  }
  return reference;
}

RuleResult ApplyDefaultRule(const std::vector<RuleInput>& runs,
                            const std::map<std::string, ReferenceFigure>& reference) {
  RuleResult result;
  double log_sum = 0;
  for (const RuleInput& run : runs) {
    const auto it = reference.find(run.case_name);
    if (it == reference.end()) {
      result.missing.push_back(run.case_name);
      continue;
    }
    RuleCase c{run, it->second, run.ate_cm / it->second.median_cm, false};
    c.allowed = run.real ? run.ate_cm <= c.reference.max_cm : run.ate_cm <= c.reference.median_cm;
    result.conditions_hold = result.conditions_hold && c.allowed;
    if (run.real) {
      log_sum += std::log(c.ratio);
      ++result.real_cases;
    }
    result.cases.push_back(c);
  }
  if (result.real_cases > 0) result.score = std::exp(log_sum / result.real_cases);
  return result;
}

void ReportDefaultRule(const RuleResult& result, const std::string& source, double score_goal,
                       Report* report) {
  const std::string s = "the rule for defaults: ATE against ORB-SLAM2's (issue 30)";
  report->Note(s, "ORB-SLAM2's figures: " + source);
  report->Note(s,
               "real: ratio to ORB-SLAM2's median (goal <= 1), never beyond its worst run; "
               "synthetic (guard, no vote): never beyond its median");
  for (const std::string& name : result.missing) {
    report->Note(s, name + ": no ORB-SLAM2 figure, not scored");
  }
  for (const RuleCase& c : result.cases) {
    std::ostringstream unit;
    unit << "(" << c.run.ate_cm << " / " << c.reference.median_cm << " cm)";
    if (c.run.real) {
      std::ostringstream worst;
      worst << "worst " << c.reference.max_cm;
      report->Add(s, {c.run.case_name + ": ratio", c.ratio, unit.str(), "<= 1", c.ratio <= 1});
      report->Add(s, {c.run.case_name + ": ATE within ORB-SLAM2's worst run", c.run.ate_cm, "cm",
                      worst.str(), c.allowed});
    } else {
      report->Add(s, {c.run.case_name + ": ratio (guard)", c.ratio, unit.str(), "<= 1", c.allowed});
    }
  }
  std::ostringstream goal;
  goal << "<= " << score_goal;
  report->Add(s,
              {"score (geometric mean over " + std::to_string(result.real_cases) + " real)",
               result.score, "", goal.str(), result.real_cases > 0 && result.score <= score_goal});
}

}  // namespace rrslam::bench
