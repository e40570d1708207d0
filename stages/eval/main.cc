// rrslam-eval: absolute trajectory error and relative pose error of an
// estimated camera trajectory against ground truth (TUM RGB-D benchmark
// definitions). See docs/eval.md.
#include <CLI/CLI.hpp>
#include <iostream>
#include <string>
#include <utility>
#include <vector>

#include "common/cli.h"
#include "stages/eval/compare.h"
#include "stages/eval/eval.h"
#include "stages/eval/summary.h"

namespace {

// A flag taking one of `choices`; --help shows them and the current value
// of `*target` as default.
template <typename Enum>
void AddChoice(CLI::App* command, const std::string& flag, Enum* target,
               const std::vector<std::pair<std::string, Enum>>& choices,
               const std::string& description) {
  std::vector<std::string> names;
  std::string default_name;
  for (const auto& [name, value] : choices) {
    names.push_back(name);
    if (value == *target) default_name = name;
  }
  command
      ->add_option_function<std::string>(
          flag,
          [target, choices](const std::string& given) {
            for (const auto& [name, value] : choices) {
              if (name == given) *target = value;
            }
          },
          description)
      ->check(CLI::IsMember(names))
      ->default_str(default_name);
}

void AddInputs(CLI::App* command, std::filesystem::path* gt, std::filesystem::path* est) {
  command
      ->add_option("--gt", *gt,
                   "Ground-truth trajectory, TUM format (timestamp tx ty tz qx qy qz qw)")
      ->required();
  command->add_option("--est", *est, "Estimated trajectory, TUM format (e.g. CameraTrajectory.txt)")
      ->required();
}

void BindAte(CLI::App* command, rrslam::EvalAteOptions* options) {
  AddInputs(command, &options->gt_path, &options->est_path);
  command
      ->add_option("--max-diff", options->ate.max_difference,
                   "Largest |t_gt - (t_est + offset)| for a pair, seconds (strictly smaller)")
      ->capture_default_str();
  command->add_option("--offset", options->ate.offset, "Seconds added to the estimate's stamps")
      ->capture_default_str();
  command->add_option("--scale", options->ate.scale, "Factor applied to the estimated positions")
      ->capture_default_str();
  command->add_flag("--correct-scale", options->ate.correct_scale,
                    "Estimate the scale too (Umeyama Sim(3) alignment, as evo's --correct_scale); "
                    "prints estimated_scale");
  command->add_option(
      "--align-with", options->align_with_path,
      "Compute the alignment from this trajectory (TUM format, same world frame as --est) "
      "instead of from --est, and apply it unchanged to --est. E.g. --align-with the mapping "
      "run's trajectory and --est a later localization run on that map: the error then shows "
      "where the localization puts the camera in the map's frame, offsets included, which "
      "aligning --est itself would hide. Pairing, --scale and --correct-scale apply to this "
      "trajectory as to --est in plain ATE; it needs at least 3 pairs with --gt, --est at "
      "least 1. Default: align --est itself");
  command->add_flag("--json", options->json, "Print the result as JSON instead of text");
  command->add_option("--out", options->report_path,
                      "Write the result (text or JSON) to this file instead of stdout");
  command->add_option("--plot", options->plot_path,
                      "Write a PNG top view of ground truth, aligned estimate and errors");
  AddChoice(command, "--plot-axes", &options->plot.axes,
            {{"auto", rrslam::PlotAxes::kAuto},
             {"xy", rrslam::PlotAxes::kXY},
             {"xz", rrslam::PlotAxes::kXZ},
             {"yz", rrslam::PlotAxes::kYZ}},
            "World axes of the plot: auto (the two of largest ground-truth extent), xy, xz, yz");
  command->add_option("--plot-width", options->plot.width_px, "Plot width, pixels [320, 8000]")
      ->capture_default_str();
  command->add_option("--plot-height", options->plot.height_px, "Plot height, pixels [240, 8000]")
      ->capture_default_str();
  command->add_option("--plot-title", options->plot.title,
                      "Text put before the RMSE in the plot's title (e.g. the sequence name)");
  command->add_option(
      "--save-associations", options->associations_path,
      "Write the pairs: gt_stamp gt_x gt_y gt_z est_stamp est_x est_y est_z (aligned)");
  command->add_option("--save-aligned", options->aligned_path,
                      "Write the whole estimate after scale and alignment, TUM format");
}

void BindRpe(CLI::App* command, rrslam::EvalRpeOptions* options) {
  AddInputs(command, &options->gt_path, &options->est_path);
  command
      ->add_option("--delta", options->rpe.delta,
                   "Distance between the poses of a pair, in --delta-unit (> 0; whole for frames)")
      ->capture_default_str();
  AddChoice(command, "--delta-unit", &options->rpe.delta_unit,
            {{"f", rrslam::DeltaUnit::kFrames}, {"s", rrslam::DeltaUnit::kSeconds}},
            "Unit of --delta: f (frames of the estimate) or s (seconds)");
  command
      ->add_option("--max-diff", options->rpe.max_difference,
                   "Largest |t_gt - (t_est + offset)| for a ground-truth lookup, seconds "
                   "(inclusive); 0: twice the median ground-truth interval, as evaluate_rpe.py")
      ->capture_default_str();
  command->add_option("--offset", options->rpe.offset, "Seconds added to the estimate's stamps")
      ->capture_default_str();
  command
      ->add_option("--scale", options->rpe.scale,
                   "Factor applied to the estimate's relative translations")
      ->capture_default_str();
  AddChoice(command, "--error-form", &options->rpe.error_form,
            {{"script", rrslam::RpeErrorForm::kTumScript}, {"paper", rrslam::RpeErrorForm::kPaper}},
            "script: E = P Q^-1 as evaluate_rpe.py computes; paper: E = Q^-1 P as the "
            "benchmark's paper writes (P, Q: estimated and true motion)");
  command->add_flag("--json", options->json, "Print the result as JSON instead of text");
  command->add_option("--out", options->report_path,
                      "Write the result (text or JSON) to this file instead of stdout");
  command->add_option(
      "--save-pairs", options->pairs_path,
      "Write one line per pair: est_t0 est_t1 gt_t0 gt_t1 trans_error_m rot_error_deg");
}

void BindSummary(CLI::App* command, rrslam::EvalSummaryOptions* options) {
  command
      ->add_option("runs", options->run_dirs,
                   "Run folders, each with ate.json (rrslam-eval ate --json) and optionally "
                   "run.json or track/run.json (rrslam-track); one with skipped.txt is listed "
                   "as skipped, one with neither as failed (first line of error.txt)")
      ->required();
  command->add_option("--out", options->out, "Write the table to this file instead of stdout");
  command->add_flag("--json", options->json, "JSON instead of a Markdown table");
  command->add_option("--reference", options->reference,
                      "CSV of another system's ATE per sequence (header "
                      "'sequence,ate_rmse_cm,source', e.g. pipelines/orbslam2_ate.csv): adds a "
                      "column with the figure of each run's sequence, empty where it has none");
  command
      ->add_option("--reference-name", options->reference_name,
                   "Name of that system, the heading of its column (e.g. ORB-SLAM2)")
      ->capture_default_str();
}

void BindCompare(CLI::App* command, std::vector<std::string>* column_specs,
                 rrslam::EvalCompareOptions* options) {
  command
      ->add_option("--column", *column_specs,
                   "A variant: NAME=DIR, DIR holding one run folder per sequence (ate.json from "
                   "rrslam-eval ate --json, track/run.json; error.txt when failed, skipped.txt "
                   "when skipped). Repeat for each column, in order; rows are the union of the "
                   "sequence folders, sorted")
      ->required()
      ->allow_extra_args(false);  // One NAME=DIR per --column.
  command->add_option("--baseline", options->baseline,
                      "Column every other column's change is computed against, "
                      "(cell - baseline) / baseline in percent. Default: the first --column");
  command->add_option("--out", options->out,
                      "Write the table (or JSON) to this file instead of stdout");
  command->add_flag("--json", options->json,
                    "JSON (inputs, options, every cell) instead of Markdown");
  command->add_option("--csv", options->csv_path,
                      "Also write one line per cell: "
                      "sequence,variant,ate_rmse_cm,change_pct,status,frames,tracked");
  command->add_option("--plot", options->plot_path,
                      "Also write a PNG grouped bar chart of the ATE RMSE (cm) per sequence and "
                      "variant");
  command->add_option("--plot-width", options->plot.width_px, "Chart width, pixels [320, 8000]")
      ->capture_default_str();
  command->add_option("--plot-height", options->plot.height_px, "Chart height, pixels [240, 8000]")
      ->capture_default_str();
  command->add_option("--title", options->title,
                      "Caption of the table (a bold line above it) and title of the chart");
}

}  // namespace

int main(int argc, char** argv) {
  rrslam::EvalAteOptions ate_options;
  rrslam::EvalRpeOptions rpe_options;
  rrslam::EvalSummaryOptions summary_options;
  rrslam::EvalCompareOptions compare_options;
  std::vector<std::string> compare_columns;
  CLI::App* ate = nullptr;
  CLI::App* rpe = nullptr;
  CLI::App* summary = nullptr;
  CLI::App* compare = nullptr;
  return rrslam::RunTool(
      argc, argv,
      {"eval",
       "Evaluates an estimated camera trajectory against ground truth as the TUM RGB-D "
       "benchmark does: absolute trajectory error (ate) or relative pose error (rpe); "
       "summary tabulates many evaluated runs, compare the ATE of several variants per "
       "sequence. The result is printed on stdout (text, or "
       "JSON with --json) or written to --out."},
      [&](CLI::App& app) {
        app.require_subcommand(1);
        ate = app.add_subcommand("ate", "Absolute trajectory error after rigid (Horn) alignment");
        BindAte(ate, &ate_options);
        ate->fallthrough();  // --quiet / --verbose after the command name.
        rpe = app.add_subcommand("rpe", "Relative pose error over a fixed delta");
        BindRpe(rpe, &rpe_options);
        rpe->fallthrough();
        summary = app.add_subcommand("summary", "One table over many evaluated runs");
        BindSummary(summary, &summary_options);
        summary->fallthrough();
        compare = app.add_subcommand(
            "compare", "ATE RMSE of several variants side by side: table, CSV, bar chart");
        BindCompare(compare, &compare_columns, &compare_options);
        compare->fallthrough();
      },
      [&] {
        if (ate->parsed()) {
          rrslam::RunEvalAte(ate_options, std::cout);
        } else if (rpe->parsed()) {
          rrslam::RunEvalRpe(rpe_options, std::cout);
        } else if (summary->parsed()) {
          rrslam::RunEvalSummary(summary_options, std::cout);
        } else {
          for (const std::string& spec : compare_columns) {
            compare_options.columns.push_back(rrslam::ParseCompareColumn(spec));
          }
          rrslam::RunEvalCompare(compare_options, std::cout);
        }
      });
}
