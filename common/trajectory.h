// Camera trajectories in the TUM RGB-D benchmark's text format.
//
// One pose per line: `timestamp tx ty tz qx qy qz qw`, the camera pose
// T_world_cam (camera-to-world: translation is the camera centre in the world
// frame), timestamp in seconds. Lines starting with '#' and blank lines are
// comments. Readers accept spaces, tabs or commas between fields, as TUM's
// tools do; writers print the timestamp with 6 decimals and the pose with 9,
// as ORB-SLAM2 and the benchmark's tools do.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "common/geometry.h"

namespace rrslam {

struct StampedPose {
  double timestamp = 0;  // Seconds.
  Rigid3d T_world_cam;   // Camera pose: maps camera coordinates to world coordinates.
};

using Trajectory = std::vector<StampedPose>;

// Reads a TUM trajectory. Quaternions are normalized. Throws NoInputError when
// the file is missing, DataError (with file and line) on a malformed line or
// a zero quaternion.
Trajectory ReadTumTrajectory(const std::filesystem::path& path);

// Parses TUM trajectory text; `source` names it in errors.
Trajectory ParseTumTrajectory(const std::string& text, const std::string& source);

// Formats a trajectory as TUM text (no header comment).
std::string FormatTumTrajectory(const Trajectory& trajectory);

// Writes a trajectory atomically. Throws CantCreateError.
void WriteTumTrajectory(const std::filesystem::path& path, const Trajectory& trajectory);

// For each of `queries` (seconds), the index in `stamps` of the nearest stamp
// within `tolerance`, or nullopt when none is (neither needs to be sorted).
std::vector<std::optional<size_t>> MatchTimestamps(const std::vector<double>& queries,
                                                   const std::vector<double>& stamps,
                                                   double tolerance);

}  // namespace rrslam
