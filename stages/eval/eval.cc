#include "stages/eval/eval.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cctype>
#include <fstream>
#include <memory>
#include <string_view>
#include <vector>

#include "common/atomic_file.h"
#include "common/cli.h"
#include "common/errors.h"
#include "common/image_io.h"
#include "common/json_text.h"
#include "common/output_path.h"
#include "common/text.h"
#include "common/trajectory.h"

namespace rrslam {
namespace fs = std::filesystem;
namespace {

constexpr const char* kStage = "eval";

// The same file, as far as can be told before it exists.
Trajectory ReadTrajectory(const fs::path& path, const char* what) {
  Trajectory trajectory = ReadTumTrajectory(path);
  spdlog::info("{}: {} poses from {}", what, trajectory.size(), path.string());
  return trajectory;
}

// An output file prepared under its temporary name, committed later.
class PendingOutput {
 public:
  PendingOutput(const fs::path& path, std::string content)
      : output_(std::make_unique<AtomicOutput>(path)), content_(std::move(content)) {}

  void Write() {
    std::ofstream stream(output_->temp_path(), std::ios::binary | std::ios::trunc);
    if (!stream) throw CantCreateError(output_->temp_path().string() + ": cannot open for writing");
    stream.write(content_.data(), static_cast<std::streamsize>(content_.size()));
    stream.flush();
    if (!stream) throw CantCreateError(output_->temp_path().string() + ": write failed");
  }
  void Commit() {
    output_->Commit();
    spdlog::info("wrote {}", output_->final_path().string());
  }

 private:
  std::unique_ptr<AtomicOutput> output_;
  std::string content_;
};

std::string Header(const nlohmann::ordered_json& run, const std::string& columns) {
  return "# " + Producer(kStage) + " " + DumpJson(run) + "\n# " + columns + "\n";
}

// Prefixes a data or algorithm error of the computation with the files it
// concerns (and `role`, when given, e.g. the flag that named `est`).
template <typename Fn>
auto WithFiles(const fs::path& gt, const fs::path& est, Fn&& fn, const std::string& role = "") {
  try {
    return fn();
  } catch (const DataError& e) {
    throw DataError(role + est.string() + " against " + gt.string() + ": " + e.what());
  } catch (const AlgorithmError& e) {
    throw AlgorithmError(role + est.string() + " against " + gt.string() + ": " + e.what());
  }
}

// The report of `command` (ate or rpe): JSON with the producer, the inputs,
// the options and `results`, or `text` as it is.
std::string Report(bool json, const char* command, const fs::path& gt, const fs::path& est,
                   nlohmann::ordered_json options, const nlohmann::ordered_json& results,
                   std::string text) {
  if (!json) return text;
  nlohmann::ordered_json j = {{"producer", Producer(kStage)},
                              {"command", command},
                              {"gt", gt.string()},
                              {"est", est.string()},
                              {"options", std::move(options)}};
  j.update(results);
  return DumpJson(j, 2) + "\n";
}

}  // namespace

void WriteOutputFiles(std::vector<std::pair<fs::path, std::string>> files) {
  std::vector<PendingOutput> pending;
  pending.reserve(files.size());
  for (auto& [path, content] : files) pending.emplace_back(path, std::move(content));
  for (PendingOutput& output : pending) output.Write();
  for (PendingOutput& output : pending) output.Commit();
}

bool EvalAteOptions::Check(std::string* why) const {
  if (gt_path.empty()) {
    *why = "the ground truth (--gt) is required";
    return false;
  }
  if (est_path.empty()) {
    *why = "the estimate (--est) is required";
    return false;
  }
  if (!ate.Check(why) || !plot.Check(why)) return false;
  if (!plot_path.empty() && AsciiLowercase(plot_path.extension().string()) != ".png") {
    *why = "plot " + plot_path.string() + " must be a .png file";
    return false;
  }
  std::vector<NamedPath> inputs = {{"ground-truth", gt_path}, {"estimate", est_path}};
  if (!align_with_path.empty()) inputs.emplace_back("--align-with", align_with_path);
  return CheckOutputs({{"--out", report_path},
                       {"--plot", plot_path},
                       {"--save-associations", associations_path},
                       {"--save-aligned", aligned_path}},
                      inputs, why);
}

nlohmann::ordered_json EvalAteOptions::ToJson() const {
  nlohmann::ordered_json j = {{"gt", gt_path.string()},
                              {"est", est_path.string()},
                              {"ate", ate.ToJson()},
                              {"json", json},
                              {"out", report_path.string()},
                              {"plot", plot_path.string()},
                              {"save_associations", associations_path.string()},
                              {"save_aligned", aligned_path.string()}};
  if (!plot_path.empty()) j["plot_options"] = plot.ToJson();
  // Only when given, so that plain ATE's outputs stay as they were.
  if (!align_with_path.empty()) j["align_with"] = align_with_path.string();
  return j;
}

bool EvalRpeOptions::Check(std::string* why) const {
  if (gt_path.empty()) {
    *why = "the ground truth (--gt) is required";
    return false;
  }
  if (est_path.empty()) {
    *why = "the estimate (--est) is required";
    return false;
  }
  if (!rpe.Check(why)) return false;
  return CheckOutputs({{"--out", report_path}, {"--save-pairs", pairs_path}},
                      {{"ground-truth", gt_path}, {"estimate", est_path}}, why);
}

nlohmann::ordered_json EvalRpeOptions::ToJson() const {
  return {{"gt", gt_path.string()},      {"est", est_path.string()},
          {"rpe", rpe.ToJson()},         {"json", json},
          {"out", report_path.string()}, {"save_pairs", pairs_path.string()}};
}

AteResult RunEvalAte(const EvalAteOptions& options, std::ostream& out) {
  std::string why;
  if (!options.Check(&why)) throw UsageError(why);
  const Trajectory gt = ReadTrajectory(options.gt_path, "ground truth");
  const Trajectory est = ReadTrajectory(options.est_path, "estimate");
  const bool align_with = !options.align_with_path.empty();
  // Plain ATE aligns the estimate itself; --align-with aligns that trajectory
  // and evaluates the estimate under its alignment.
  const fs::path& source_path = align_with ? options.align_with_path : options.est_path;
  Trajectory align_with_trajectory;
  if (align_with) align_with_trajectory = ReadTrajectory(source_path, "alignment source");
  const Trajectory& source = align_with ? align_with_trajectory : est;
  const AteAlignment alignment = WithFiles(
      options.gt_path, source_path, [&] { return ComputeAteAlignment(gt, source, options.ate); },
      align_with ? "alignment (--align-with) " : "");
  if (align_with) {
    spdlog::info("alignment from {}: {} of {} poses paired with ground truth", source_path.string(),
                 alignment.pairs, alignment.est_poses);
    if (alignment.est_duplicates > 0) {
      spdlog::warn("{}: {} repeated timestamp(s); each keeps its last pose, as TUM's tools do",
                   source_path.string(), alignment.est_duplicates);
    }
  }
  const AteResult result = WithFiles(options.gt_path, options.est_path,
                                     [&] { return EvaluateAte(gt, est, alignment, options.ate); });
  if (result.gt_duplicates > 0) {
    spdlog::warn("{}: {} repeated timestamp(s); each keeps its last pose, as TUM's tools do",
                 options.gt_path.string(), result.gt_duplicates);
  }
  if (result.est_duplicates > 0) {
    spdlog::warn("{}: {} repeated timestamp(s); each keeps its last pose, as TUM's tools do",
                 options.est_path.string(), result.est_duplicates);
  }
  spdlog::info("{} of {} estimated poses paired with ground truth", result.pairs.size(),
               result.est_poses);

  const nlohmann::ordered_json run = {{"command", "ate"}, {"options", options.ToJson()}};
  std::vector<std::pair<fs::path, std::string>> files;
  if (!options.associations_path.empty()) {
    files.emplace_back(options.associations_path,
                       Header(run,
                              "gt_stamp gt_x gt_y gt_z est_stamp est_x est_y est_z "
                              "(estimate aligned to the ground truth, metres)") +
                           FormatAteAssociations(result));
  }
  if (!options.aligned_path.empty()) {
    files.emplace_back(options.aligned_path,
                       Header(run,
                              "timestamp tx ty tz qx qy qz qw (estimate aligned to the "
                              "ground truth: T_gt_est * T_world_cam)") +
                           FormatTumTrajectory(result.est_aligned));
  }
  if (!options.plot_path.empty()) {
    const std::vector<uint8_t> png = EncodePng(
        RenderAtePlot(gt, result, options.plot), kPlotPngCompression,
        {{"Software", Producer(kStage)},
         {"Comment", DumpJson(nlohmann::ordered_json{{"run", run},
                                                     {"ate_m", ErrorStatsToJson(result.error)},
                                                     {"pairs", result.pairs.size()}})}});
    files.emplace_back(options.plot_path, std::string(png.begin(), png.end()));
  }
  nlohmann::ordered_json results = AteResultToJson(result);
  std::string text = FormatAteReport(result);
  if (align_with) {
    results["alignment"] = {{"source", source_path.string()}, {"pairs", alignment.pairs}};
    text += "alignment_source " + source_path.string() + "\nalignment_pose_pairs " +
            std::to_string(alignment.pairs) + " pairs\n";
  }
  const std::string report = Report(options.json, "ate", options.gt_path, options.est_path,
                                    options.ate.ToJson(), results, std::move(text));
  if (!options.report_path.empty()) files.emplace_back(options.report_path, report);
  WriteOutputFiles(std::move(files));
  if (options.report_path.empty()) {
    out << report;
    out.flush();
  }
  return result;
}

RpeResult RunEvalRpe(const EvalRpeOptions& options, std::ostream& out) {
  std::string why;
  if (!options.Check(&why)) throw UsageError(why);
  const Trajectory gt = ReadTrajectory(options.gt_path, "ground truth");
  const Trajectory est = ReadTrajectory(options.est_path, "estimate");
  const RpeResult result = WithFiles(options.gt_path, options.est_path,
                                     [&] { return ComputeRpe(gt, est, options.rpe); });
  spdlog::info("{} pose pairs compared ({} left out without ground truth within {:.6f} s)",
               result.pairs.size(), result.skipped_pairs, result.max_difference);

  const std::string report =
      Report(options.json, "rpe", options.gt_path, options.est_path, options.rpe.ToJson(),
             RpeResultToJson(result), FormatRpeReport(result));
  std::vector<std::pair<fs::path, std::string>> files;
  if (!options.pairs_path.empty()) {
    const nlohmann::ordered_json run = {{"command", "rpe"}, {"options", options.ToJson()}};
    files.emplace_back(options.pairs_path, Header(run,
                                                  "est_stamp_0 est_stamp_1 gt_stamp_0 gt_stamp_1 "
                                                  "translational_error_m rotational_error_deg") +
                                               FormatRpePairs(result));
  }
  if (!options.report_path.empty()) files.emplace_back(options.report_path, report);
  WriteOutputFiles(std::move(files));
  if (options.report_path.empty()) {
    out << report;
    out.flush();
  }
  return result;
}

}  // namespace rrslam
