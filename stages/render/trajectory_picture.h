// Pictures of camera trajectories (TUM files) against a ground truth: top,
// side and front projections with the error coloured along the path, and the
// error over time.
//
// Frames: with a ground truth, every estimate is aligned to it rigidly (the
// ATE alignment of stages/eval/ate.h, no scale: RGB-D) and drawn in the
// ground truth's world frame; without one, the estimates are drawn as they
// are, in their own (common) frame. The projections use world axes:
//   top    the two axes along which the reference (ground truth, else the
//          first estimate) extends most, in x, y, z order
//   front  the first of those two and the remaining axis
//   side   the second of those two and the remaining axis
// Keyframe trajectories (KeyFrameTrajectory.txt: a median interval above
// 0.1 s) are drawn with a marker at every pose, as the seed paper's
// Algorithm 6 plots them.
#pragma once

#include <nlohmann/json.hpp>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <string>
#include <vector>

#include "common/trajectory.h"
#include "stages/eval/ate.h"

namespace rrslam {

struct NamedTrajectory {
  std::string name;  // Legend text (e.g. the file name).
  Trajectory trajectory;
};

struct TrajectoryPictureOptions {
  int width_px = 1000;           // In [320, 8000].
  int height_px = 800;           // In [240, 8000].
  double max_difference = 0.02;  // Seconds; stamp association with the ground truth (ATE).
  std::string title;             // Put before each picture's title (e.g. the sequence name).

  bool Check(std::string* why) const;
  nlohmann::ordered_json ToJson() const;
};

enum class TrajectoryView { kTop, kSide, kFront };
std::string ToString(TrajectoryView view);

struct TrajectoryPictures {
  cv::Mat top, side, front;  // CV_8UC3 BGR.
  cv::Mat error;             // Error over time; empty without a ground truth.
  // The ATE of each estimate (empty without a ground truth), in input order.
  std::vector<AteResult> ate;
  // World axes of each view (0 = x, 1 = y, 2 = z), horizontal then vertical.
  std::pair<int, int> top_axes, side_axes, front_axes;
};

// Renders the pictures. Throws UsageError for invalid options or no
// estimate, DataError when an estimate cannot be aligned to the ground truth
// (no stamps associate, as rrslam-eval ate).
TrajectoryPictures RenderTrajectoryPictures(const std::vector<NamedTrajectory>& estimates,
                                            const std::optional<NamedTrajectory>& ground_truth,
                                            const TrajectoryPictureOptions& options);

}  // namespace rrslam
