#include "common/trajectory.h"

#include <cstdio>
#include <sstream>

#include "common/atomic_file.h"
#include "common/errors.h"
#include "common/text.h"

namespace rrslam {

Trajectory ParseTumTrajectory(const std::string& text, const std::string& source) {
  Trajectory trajectory;
  ForEachDataLine(text, source, [&](const std::vector<std::string_view>& fields, int line) {
    if (fields.size() != 8) {
      throw DataError(source + " line " + std::to_string(line) +
                      ": expected 8 fields 'timestamp tx ty tz qx qy qz qw', got " +
                      std::to_string(fields.size()));
    }
    double v[8];
    for (int i = 0; i < 8; ++i) v[i] = ParseDouble(fields[i], source, line);
    Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);
    if (q.norm() < 1e-9) {
      throw DataError(source + " line " + std::to_string(line) + ": zero quaternion");
    }
    StampedPose pose;
    pose.timestamp = v[0];
    pose.T_world_cam = Rigid3d(q.normalized(), Eigen::Vector3d(v[1], v[2], v[3]));
    trajectory.push_back(pose);
  });
  return trajectory;
}

Trajectory ReadTumTrajectory(const std::filesystem::path& path) {
  return ParseTumTrajectory(ReadFileToString(path), path.string());
}

std::string FormatTumTrajectory(const Trajectory& trajectory) {
  std::string out;
  out.reserve(trajectory.size() * 100);
  char line[256];
  for (const StampedPose& pose : trajectory) {
    const Eigen::Quaterniond& q = pose.T_world_cam.rotation;
    const Eigen::Vector3d& t = pose.T_world_cam.translation;
    std::snprintf(line, sizeof(line), "%.6f %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n", pose.timestamp,
                  t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w());
    out += line;
  }
  return out;
}

void WriteTumTrajectory(const std::filesystem::path& path, const Trajectory& trajectory) {
  WriteFileAtomically(path, FormatTumTrajectory(trajectory));
}

}  // namespace rrslam
