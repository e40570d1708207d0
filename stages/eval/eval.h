// The `rrslam-eval` commands as library calls: read the trajectories, compute,
// write the requested files atomically and print the result.
//
//   ate: absolute trajectory error (ate.h), optional plot (plot.h), pairs and
//        aligned estimate files.
//   rpe: relative pose error over a fixed delta (rpe.h), optional pairs file.
//
// The result goes to `out` (stdout in the executable), or to a file with
// --out: evaluate_*.py's verbose text report, or JSON with the inputs, options
// and producer. Logs go to stderr.
// Output files are all prepared before any is committed, so a failure leaves
// none of them behind, and an existing file is only replaced by a complete one.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include "stages/eval/ate.h"
#include "stages/eval/plot.h"
#include "stages/eval/rpe.h"

namespace rrslam {

struct EvalAteOptions {
  std::filesystem::path gt_path;      // Ground-truth trajectory (TUM format). Required.
  std::filesystem::path est_path;     // Estimated trajectory (TUM format). Required.
  AteOptions ate;                     // Pairing, scale (ate.h).
  bool json = false;                  // Print JSON instead of the text report.
  std::filesystem::path report_path;  // Write the report here instead of `out`; empty: `out`.
  std::filesystem::path plot_path;    // PNG plot (plot.h); empty: none. Must end in .png.
  PlotOptions plot;
  // Pairs file (`gt_stamp gx gy gz est_stamp ex ey ez`, aligned estimate); empty: none.
  std::filesystem::path associations_path;
  // The whole estimate after scale and alignment, TUM format; empty: none.
  std::filesystem::path aligned_path;
  // Trajectory (TUM format) to compute the alignment from instead of the
  // estimate; empty: the estimate itself (plain ATE). The alignment is found
  // between this trajectory and the ground truth exactly as plain ATE would
  // find it for this trajectory (pairing, scale, --correct-scale), then
  // applied unchanged to the estimate (EvaluateAte). For an estimate in the
  // same world frame, e.g. a localization run (--est) on the map a mapping
  // run (--align-with) built: the error then includes any offset of the
  // estimate against the map, which a fresh alignment would absorb.
  std::filesystem::path align_with_path;

  // Names the violated constraint: missing input, invalid ATE or plot option,
  // an output that is an input or another output.
  bool Check(std::string* why) const;
  nlohmann::ordered_json ToJson() const;
};

struct EvalRpeOptions {
  std::filesystem::path gt_path;      // Ground-truth trajectory (TUM format). Required.
  std::filesystem::path est_path;     // Estimated trajectory (TUM format). Required.
  RpeOptions rpe;                     // Delta, lookup bound, error form (rpe.h).
  bool json = false;                  // Print JSON instead of the text report.
  std::filesystem::path report_path;  // Write the report here instead of `out`; empty: `out`.
  // Per-pair errors (`est_t0 est_t1 gt_t0 gt_t1 trans_m rot_deg`); empty: none.
  std::filesystem::path pairs_path;

  bool Check(std::string* why) const;
  nlohmann::ordered_json ToJson() const;
};

// Writes each (path, content) atomically (common/atomic_file.h): every file is
// written under its temporary name before the first is renamed to its final
// name, so an error in writing any of them leaves no output of the run behind
// and existing files keep their content. Throws CantCreateError. For the
// subcommands that write more than one file.
void WriteOutputFiles(std::vector<std::pair<std::filesystem::path, std::string>> files);

// Runs `rrslam-eval ate`. Throws UsageError (invalid options), NoInputError
// (missing input), DataError (malformed input, no pairs, fewer than
// kMinAtePairs between the trajectory aligned from and the ground truth),
// CantCreateError (an output cannot be written; then no output file is
// written). With align_with_path the report gains "alignment": the source
// path and the number of pairs the alignment was computed from.
AteResult RunEvalAte(const EvalAteOptions& options, std::ostream& out);

// Runs `rrslam-eval rpe`, with the same errors.
RpeResult RunEvalRpe(const EvalRpeOptions& options, std::ostream& out);

}  // namespace rrslam
