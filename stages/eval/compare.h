// `rrslam-eval compare`: the ATE of several variants of a run side by side,
// one row per sequence and one column per variant (e.g. the vocabulary each
// run tracked with), as a Markdown table, CSV, JSON and a grouped bar chart.
//
// Each column is a folder laid out as `make eval-all` / `make paper` write
// them: one subfolder per sequence, read with ReadRunSummary (summary.h), so
// a cell is the sequence's `ate.json` and `run.json` (directly or in
// `track/`), or a failed run (no ate.json; the first line of `error.txt`),
// or a skipped one (`skipped.txt`). The rows are the union of the sequence
// subfolders over all columns, sorted by name; a column without a folder
// for a sequence has an empty cell there (e.g. a vocabulary transferred from
// a sequence is not evaluated on that sequence). Folder names starting with
// '.' or ending in ".tmp" (AtomicOutput's temporaries) are not sequences.
//
// Every column but the baseline also shows the change of its ATE RMSE
// against the baseline's on the same sequence, in percent:
// (cell - baseline) / baseline * 100.
//
// An ATE computed over fewer frames is not comparable with one over all of
// them, so the table marks every run that lost frames (tracked < frames in
// its run.json) with a note "<variant>/<sequence>: T of F frames tracked",
// and lists the runs whose run.json is missing (frames tracked unknown).
//
// Units: ATE in metres in memory and JSON (as ate.json), centimetres in the
// table, the CSV and the chart; changes in percent.
#pragma once

#include <cstddef>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "stages/eval/summary.h"

namespace rrslam {

// One variant: a column of the table, a bar colour of the chart.
struct CompareColumn {
  std::string name;           // Heading and legend entry; not empty, no '|' or line break.
  std::filesystem::path dir;  // Folder with one run folder per sequence.
};

// Parses a `--column` value "NAME=DIR" (split at the first '='; DIR may hold
// '=' itself). Throws UsageError ("--column 'own': expected NAME=DIR") when
// there is no '='. Empty parts are reported by EvalCompareOptions::Check.
CompareColumn ParseCompareColumn(const std::string& spec);

// A variant's run on one sequence.
struct CompareCell {
  std::optional<RunSummary> run;  // nullopt: the column has no folder for the sequence.
  // Change of the ATE RMSE against the baseline's cell on the same row, in
  // percent; set when both are evaluated, the baseline's RMSE is > 0 and
  // this is not the baseline column.
  std::optional<double> change_pct;

  bool evaluated() const { return run && run->evaluated; }
  bool failed() const { return run && !run->evaluated && !run->skipped; }
  bool skipped() const { return run && run->skipped; }
  // Frames were lost: run.json says tracked < frames.
  bool lost_frames() const {
    return run && run->frames && run->tracked && *run->tracked < *run->frames;
  }
  // "evaluated", "failed", "skipped" or "absent" (no folder).
  std::string status() const;
};

struct CompareTable {
  std::vector<CompareColumn> columns;
  size_t baseline = 0;                          // Index of the baseline in `columns`.
  std::vector<std::string> sequences;           // Row names, sorted.
  std::vector<std::vector<CompareCell>> cells;  // [row][column], sequences x columns.
};

// Reads every column's sequence folders and computes the changes against
// columns[baseline]. Throws NoInputError when a column's folder is missing
// (naming the column) or when no column has any sequence folder, DataError
// when an ate.json or run.json is malformed (naming the file).
CompareTable ReadCompareTable(const std::vector<CompareColumn>& columns, size_t baseline = 0);

// (value - baseline) / baseline * 100 as the table prints it: one decimal,
// sign always shown, e.g. "-12.5%", "+3.0%" ("+0.0%" for a change that
// rounds to zero).
std::string FormatChangePercent(double change_pct);

// The Markdown table: a `**title**` line when `title` is not empty, then
// `| sequence | <column>... |` with the ATE RMSE in cm (2 decimals, as
// `summary`), `<rmse> (<change>)` in non-baseline columns, `failed [k]` /
// `skipped [k]`, an empty cell for an absent run, a run that lost frames
// marked `[k]`; a last row with each column's mean over the sequences
// evaluated in every column (when there is one). Notes below: the units and
// the baseline, then the numbered notes [k] (frames tracked, failure or skip
// reason) and the runs without run.json.
std::string FormatCompareTable(const CompareTable& table, const std::string& title = "");

// One line per cell after the header
// `sequence,variant,ate_rmse_cm,change_pct,status,frames,tracked` (rows in table order, columns in
// column order; absent cells included with status `absent`). Empty fields where a value is unknown;
// fields holding
// ',', '"' or a line break quoted as RFC 4180.
std::string FormatCompareCsv(const CompareTable& table);

// The table as JSON: producer, command, `options` (when not null), the
// columns (name, dir, baseline), the baseline's name, per sequence each
// column's cell (status, frames / tracked / lost when known, pairs and ate_m
// {rmse, mean, max} in metres when evaluated, change_pct, failure or skipped
// reason), and `mean` over the sequences evaluated in every column.
nlohmann::ordered_json CompareToJson(const CompareTable& table,
                                     const nlohmann::ordered_json& options = nullptr);

// Size of the bar chart.
struct CompareChartOptions {
  int width_px = 1200;  // Image width, pixels, in [320, 8000].
  int height_px = 700;  // Image height, pixels, in [240, 8000].

  bool Check(std::string* why) const;
  nlohmann::ordered_json ToJson() const;
};

// The colour (BGR) of column `index`'s bars: matplotlib's "tab10" palette,
// repeated after 10 columns.
cv::Scalar CompareColumnColour(size_t index);

// Renders the grouped bar chart as an 8-bit BGR image: one group per
// sequence (labelled under the axis, TUM folder names shortened as
// CanonicalSequenceName), one bar per column in its colour
// (CompareColumnColour) with the ATE RMSE in cm above it ('*' appended when
// the run lost frames; values left out when bars are too narrow for them),
// an 'x' cross on the axis for a failed run, a dash for a skipped one,
// nothing for an absent one; the y axis in cm from 0 with round ticks and
// grid, room above the tallest bar for the legend of the columns, `title`
// (default "ATE RMSE per sequence") and a footer explaining the marks used.
// Throws UsageError for an invalid size.
cv::Mat RenderCompareChart(const CompareTable& table, const CompareChartOptions& options = {},
                           const std::string& title = "");

struct EvalCompareOptions {
  std::vector<CompareColumn> columns;  // The variants, in column order. At least one.
  std::string baseline;                // Column the changes are against; empty: the first.
  std::string title;                   // Table caption and chart title; empty: none / default.
  bool json = false;                   // JSON (CompareToJson) instead of the Markdown table.
  std::filesystem::path out;           // Table (or JSON) file; empty: the `out` stream.
  std::filesystem::path csv_path;      // CSV (FormatCompareCsv); empty: none.
  std::filesystem::path plot_path;     // PNG bar chart; empty: none. Must end in .png.
  CompareChartOptions plot;

  // Names the violated constraint: no column, an empty or duplicated name, a
  // name holding '|' or a line break, an empty DIR, an unknown --baseline, an
  // invalid chart size, a plot not ending in .png, an output that is an input
  // (or lies inside a column's folder) or another output.
  bool Check(std::string* why) const;
  // The index of the baseline column (options must pass Check).
  size_t BaselineIndex() const;
  nlohmann::ordered_json ToJson() const;
};

// Runs `rrslam-eval compare`: reads the table and writes the requested
// outputs, all prepared before any is committed (WriteOutputFiles, eval.h),
// the table (or JSON) to `out` when options.out is empty. Throws UsageError,
// NoInputError, DataError, CantCreateError (then no output file is written).
CompareTable RunEvalCompare(const EvalCompareOptions& options, std::ostream& out);

}  // namespace rrslam
