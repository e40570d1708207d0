#include "common/trajectory.h"

#include <algorithm>
#include <cmath>
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
    v[0] = ParseTimestamp(fields[0], source, line);
    for (int i = 1; i < 8; ++i) v[i] = ParseDouble(fields[i], source, line);
    Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);
    if (q.norm() < 1e-9) {
      throw DataError(source + " line " + std::to_string(line) + ": zero quaternion");
    }
    StampedPose pose;
    pose.timestamp = v[0];
    // Components near the double range overflow the norm (1e200 squared):
    // normalized() would give a zero quaternion; stableNormalized() scales
    // first (and is kept to that case: it may round the last bit otherwise).
    const bool overflows = !std::isfinite(q.norm());
    const Eigen::Quaterniond unit =
        overflows ? Eigen::Quaterniond(q.coeffs().stableNormalized()) : q.normalized();
    pose.T_world_cam = Rigid3d(unit, Eigen::Vector3d(v[1], v[2], v[3]));
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
    auto print = [&](char* buffer, size_t size) {
      return std::snprintf(buffer, size, "%.6f %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n",
                           pose.timestamp, t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w());
    };
    // Fixed notation of a value near 1e300 has 300 digits: a line that does
    // not fit the buffer is printed again at its length (it was cut, and the
    // file lost its newline and fields).
    const int length = print(line, sizeof(line));
    if (length < static_cast<int>(sizeof(line))) {
      out.append(line, static_cast<size_t>(length));
    } else {
      std::string long_line(static_cast<size_t>(length) + 1, '\0');
      print(long_line.data(), long_line.size());
      out.append(long_line.data(), static_cast<size_t>(length));
    }
  }
  return out;
}

void WriteTumTrajectory(const std::filesystem::path& path, const Trajectory& trajectory) {
  WriteFileAtomically(path, FormatTumTrajectory(trajectory));
}

std::vector<std::optional<size_t>> MatchTimestamps(const std::vector<double>& queries,
                                                   const std::vector<double>& stamps,
                                                   double tolerance) {
  std::vector<size_t> order(stamps.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return stamps[a] < stamps[b]; });
  std::vector<std::optional<size_t>> result;
  result.reserve(queries.size());
  for (const double t : queries) {
    const auto it = std::lower_bound(order.begin(), order.end(), t - tolerance,
                                     [&](size_t i, double v) { return stamps[i] < v; });
    std::optional<size_t> best;
    for (auto j = it; j != order.end() && stamps[*j] <= t + tolerance; ++j) {
      if (!best || std::abs(stamps[*j] - t) < std::abs(stamps[*best] - t)) best = *j;
    }
    result.push_back(best);
  }
  return result;
}

}  // namespace rrslam
