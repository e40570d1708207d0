#include "stages/eval/summary.h"

#include <cstdio>
#include <ostream>

#include "common/atomic_file.h"
#include "common/cli.h"
#include "common/errors.h"

namespace rrslam {
namespace fs = std::filesystem;
namespace {

nlohmann::json ReadJson(const fs::path& path) {
  const nlohmann::json j = nlohmann::json::parse(ReadFileToString(path), nullptr, false);
  if (j.is_discarded() || !j.is_object()) throw DataError(path.string() + ": not a JSON object");
  return j;
}

// The number at `pointer` in `j`, or nullopt when absent; DataError when present
// but not a number.
template <typename T>
std::optional<T> Number(const nlohmann::json& j, const char* pointer, const fs::path& path) {
  const nlohmann::json::json_pointer p(pointer);
  if (!j.contains(p)) return std::nullopt;
  const nlohmann::json& value = j.at(p);
  if (!value.is_number()) throw DataError(path.string() + ": " + pointer + " is not a number");
  return value.get<T>();
}

std::string Cell(const std::optional<int64_t>& value) {
  return value ? std::to_string(*value) : "-";
}

std::string Fixed(double value, int decimals) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.*f", decimals, value);
  return buffer;
}

}  // namespace

RunSummary ReadRunSummary(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw NoInputError(dir.string() + ": no such run folder");
  RunSummary run;
  run.name = fs::absolute(dir).lexically_normal().filename().string();
  if (run.name.empty()) run.name = fs::absolute(dir).lexically_normal().parent_path().filename();
  for (const fs::path& candidate : {dir / "run.json", dir / "track" / "run.json"}) {
    if (!fs::is_regular_file(candidate, ec)) continue;
    const nlohmann::json j = ReadJson(candidate);
    run.frames = Number<int64_t>(j, "/counts/frames", candidate);
    run.tracked = Number<int64_t>(j, "/counts/tracked", candidate);
    run.lost = Number<int64_t>(j, "/counts/lost", candidate);
    run.keyframes = Number<int64_t>(j, "/counts/keyframes", candidate);
    run.tracking_median_ms = Number<double>(j, "/timings/tracking/median_ms", candidate);
    break;
  }
  const fs::path ate = dir / "ate.json";
  if (!fs::is_regular_file(ate, ec)) {
    run.failure = "no ate.json";
    const fs::path error = dir / "error.txt";
    if (fs::is_regular_file(error, ec)) {
      const std::string text = ReadFileToString(error);
      run.failure = text.substr(0, text.find('\n'));
    }
    return run;
  }
  const nlohmann::json j = ReadJson(ate);
  const auto pairs = Number<int64_t>(j, "/pairs", ate);
  const auto rmse = Number<double>(j, "/ate_m/rmse", ate);
  const auto mean = Number<double>(j, "/ate_m/mean", ate);
  const auto max = Number<double>(j, "/ate_m/max", ate);
  if (!pairs || !rmse || !mean || !max) {
    throw DataError(ate.string() + ": not an `rrslam-eval ate --json` result (pairs, ate_m)");
  }
  run.evaluated = true;
  run.pairs = *pairs;
  run.ate_rmse_m = *rmse;
  run.ate_mean_m = *mean;
  run.ate_max_m = *max;
  return run;
}

std::string FormatSummaryTable(const std::vector<RunSummary>& runs) {
  std::string out =
      "| run | frames | tracked | lost | keyframes | ATE RMSE cm | ATE mean cm | ATE max cm | "
      "tracking median ms |\n"
      "|---|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  double sum = 0;
  int evaluated = 0;
  for (const RunSummary& r : runs) {
    out += "| " + r.name + " | " + Cell(r.frames) + " | " + Cell(r.tracked) + " | " + Cell(r.lost) +
           " | " + Cell(r.keyframes) + " | ";
    if (r.evaluated) {
      out += Fixed(100 * r.ate_rmse_m, 2) + " | " + Fixed(100 * r.ate_mean_m, 2) + " | " +
             Fixed(100 * r.ate_max_m, 2) + " | ";
      sum += r.ate_rmse_m;
      ++evaluated;
    } else {
      out += "failed: " + r.failure + " | - | - | ";
    }
    out += (r.tracking_median_ms ? Fixed(*r.tracking_median_ms, 1) : "-") + " |\n";
  }
  out += "| mean of " + std::to_string(evaluated) + " evaluated | | | | | " +
         (evaluated > 0 ? Fixed(100 * sum / evaluated, 2) : "-") + " | | | |\n";
  return out;
}

nlohmann::ordered_json SummaryToJson(const std::vector<RunSummary>& runs) {
  nlohmann::ordered_json rows = nlohmann::ordered_json::array();
  for (const RunSummary& r : runs) {
    nlohmann::ordered_json row = {{"run", r.name}, {"evaluated", r.evaluated}};
    if (!r.evaluated) row["failure"] = r.failure;
    if (r.frames) row["frames"] = *r.frames;
    if (r.tracked) row["tracked"] = *r.tracked;
    if (r.lost) row["lost"] = *r.lost;
    if (r.keyframes) row["keyframes"] = *r.keyframes;
    if (r.tracking_median_ms) row["tracking_median_ms"] = *r.tracking_median_ms;
    if (r.evaluated) {
      row["pairs"] = r.pairs;
      row["ate_m"] = {{"rmse", r.ate_rmse_m}, {"mean", r.ate_mean_m}, {"max", r.ate_max_m}};
    }
    rows.push_back(row);
  }
  return {{"producer", Producer("eval")}, {"runs", rows}};
}

bool EvalSummaryOptions::Check(std::string* why) const {
  if (run_dirs.empty()) {
    *why = "give at least one run folder";
    return false;
  }
  return true;
}

void RunEvalSummary(const EvalSummaryOptions& options, std::ostream& out) {
  std::string why;
  if (!options.Check(&why)) throw UsageError(why);
  std::vector<RunSummary> runs;
  for (const fs::path& dir : options.run_dirs) runs.push_back(ReadRunSummary(dir));
  const std::string text =
      options.json ? SummaryToJson(runs).dump(2) + "\n" : FormatSummaryTable(runs);
  if (options.out.empty()) {
    out << text;
    out.flush();
  } else {
    WriteFileAtomically(options.out, text);
  }
}

}  // namespace rrslam
