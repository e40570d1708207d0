// `rrslam-eval summary`: one table over many evaluated runs (`make eval-all`).
//
// Each run folder holds `ate.json` (the output of `rrslam-eval ate --json`)
// and, when the run came from rrslam-track, its `run.json` (directly or in a
// `track/` subfolder). A folder without ate.json is listed as failed, with the
// first line of its `error.txt` when there is one. The table is Markdown: one
// row per run (named by its folder) with frames, tracked and lost frames,
// keyframes, ATE RMSE / mean / max in centimetres and the median tracking time
// per frame; a last row gives the mean ATE RMSE over the runs that have one.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace rrslam {

struct RunSummary {
  std::string name;                                         // The run folder's name.
  bool evaluated = false;                                   // ate.json was found and read.
  std::string failure;                                      // Why not, when !evaluated.
  std::optional<int64_t> frames, tracked, lost, keyframes;  // From run.json.
  std::optional<double> tracking_median_ms;                 // From run.json.
  int64_t pairs = 0;                                        // ATE pairs.
  double ate_rmse_m = 0, ate_mean_m = 0, ate_max_m = 0;
};

// Reads one run folder. Throws DataError when ate.json or run.json exists
// but is not valid JSON of the expected shape (names the file).
RunSummary ReadRunSummary(const std::filesystem::path& dir);

// The Markdown table, and the same as JSON.
std::string FormatSummaryTable(const std::vector<RunSummary>& runs);
nlohmann::ordered_json SummaryToJson(const std::vector<RunSummary>& runs);

struct EvalSummaryOptions {
  std::vector<std::filesystem::path> run_dirs;  // Run folders, in table order. At least one.
  std::filesystem::path out;                    // Table file; empty: stdout.
  bool json = false;                            // JSON instead of Markdown.
  bool Check(std::string* why) const;
};

// Runs `rrslam-eval summary`: writes the table to options.out atomically, or
// to `out`. Throws UsageError, NoInputError (a folder is missing), DataError.
void RunEvalSummary(const EvalSummaryOptions& options, std::ostream& out);

}  // namespace rrslam
