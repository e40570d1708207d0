// `rrslam-eval summary`: one table over many evaluated runs (`make eval-all`).
//
// Each run folder holds `ate.json` (the output of `rrslam-eval ate --json`)
// and, when the run came from rrslam-track, its `run.json` (directly or in a
// `track/` subfolder). A folder with `skipped.txt` was not run on purpose
// (eval-all writes it for a sequence too short to evaluate) and is listed as
// skipped with that file's first line; a folder without ate.json is listed as
// failed, with the first line of its `error.txt` when there is one. The table
// is Markdown: one row per run (named by its folder) with its status, frames,
// tracked and lost frames, keyframes, ATE RMSE / mean / max in centimetres
// and the median tracking time per frame; a last row gives the mean ATE RMSE
// over the runs that have one. With a reference file (`--reference`, e.g.
// pipelines/orbslam2_ate.csv) a column gives another system's published ATE
// RMSE for the runs whose sequence the file lists, and a note below the table
// names each figure's source.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace rrslam {

// Another system's ATE RMSE on one sequence, with where the figure comes from.
struct ReferenceAte {
  std::string sequence;   // As written in the file (fr1_desk, rgbd_dataset_freiburg1_desk, ...).
  double ate_rmse_m = 0;  // Metres (the file gives centimetres).
  std::string source;     // Publication or measurement the figure comes from; never empty.
};

struct RunSummary {
  std::string name;        // The run folder's name.
  bool evaluated = false;  // ate.json was found and read.
  bool skipped = false;    // skipped.txt was found.
  std::string failure;     // Why not evaluated (first line of error.txt or skipped.txt).
  std::optional<int64_t> frames, tracked, lost, keyframes;  // From run.json.
  std::optional<double> tracking_median_ms;                 // From run.json.
  int64_t pairs = 0;                                        // ATE pairs.
  double ate_rmse_m = 0, ate_mean_m = 0, ate_max_m = 0;
  std::optional<ReferenceAte> reference;  // The reference file's figure for this sequence.
};

// Reads one run folder. Throws DataError when ate.json or run.json exists
// but is not valid JSON of the expected shape (names the file), or when an
// ATE figure (ate_m.rmse, .mean, .max) is negative or not finite (names the
// file and the line).
RunSummary ReadRunSummary(const std::filesystem::path& dir);

// The sequence name under which `name` is looked up in a reference file:
// a TUM download's folder name rgbd_dataset_freiburg<N>_<rest> becomes
// fr<N>_<rest> (the short name the vocab pipeline also accepts), so that
// rgbd_dataset_freiburg1_desk and fr1_desk find the same line; any other name
// is returned unchanged.
std::string CanonicalSequenceName(const std::string& name);

// Reads a reference file: CSV (RFC 4180 quoting; '#' lines and blank lines are
// skipped) with the header line `sequence,ate_rmse_cm,source` and then one line
// per sequence: its name, the ATE RMSE in centimetres (> 0) and the figure's
// source (not empty). Throws NoInputError when the file cannot be read and
// DataError naming the file and line for a wrong header, a wrong field count,
// an unterminated quote, a figure that is not a positive number, an empty name
// or source, or a sequence listed twice (after CanonicalSequenceName).
std::vector<ReferenceAte> ReadReferenceAte(const std::filesystem::path& path);

// Sets each run's `reference` to the entry of its sequence (same
// CanonicalSequenceName), or clears it when `references` has none.
void AttachReferences(const std::vector<ReferenceAte>& references, std::vector<RunSummary>* runs);

// The reference column of a table: its heading is "<name> ATE RMSE cm";
// `file` is named in the note under the table and in the JSON.
struct ReferenceColumn {
  std::string name;
  std::filesystem::path file;
};

// The Markdown table, and the same as JSON. Without `reference` there is no
// reference column (runs' `reference` fields are then ignored).
std::string FormatSummaryTable(const std::vector<RunSummary>& runs,
                               const std::optional<ReferenceColumn>& reference = std::nullopt);
nlohmann::ordered_json SummaryToJson(
    const std::vector<RunSummary>& runs,
    const std::optional<ReferenceColumn>& reference = std::nullopt);

struct EvalSummaryOptions {
  std::vector<std::filesystem::path> run_dirs;  // Run folders, in table order. At least one.
  std::filesystem::path out;                    // Table file; empty: stdout.
  bool json = false;                            // JSON instead of Markdown.
  std::filesystem::path reference;              // Reference file (ReadReferenceAte); empty: none.
  std::string reference_name = "reference";     // Heading of its column; no '|' or line break.
  bool Check(std::string* why) const;
};

// Runs `rrslam-eval summary`: writes the table to options.out atomically, or
// to `out`. Throws UsageError, NoInputError (a folder or the reference file is
// missing), DataError.
void RunEvalSummary(const EvalSummaryOptions& options, std::ostream& out);

}  // namespace rrslam
