// libFuzzer target: the TUM trajectory reader (common/trajectory.h:
// ParseTumTrajectory, which ReadTumTrajectory calls on a file's text; ground
// truth, rrslam-track's output, eval's inputs).
//
// Any rrslam::Error is an accepted rejection; anything else (a crash, a
// sanitizer report, another exception, a broken property) is a finding.
// Properties of an accepted trajectory: finite timestamps and translations,
// unit quaternions; FormatTumTrajectory's text parses again (rrslam reads
// back what it writes) to as many poses, whose timestamps and translations
// format to the same text and whose quaternions are within the 9 decimals
// written.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "common/errors.h"
#include "common/fuzz/check.h"
#include "common/trajectory.h"

using rrslam::fuzz::Check;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  rrslam::Trajectory t;
  try {
    t = rrslam::ParseTumTrajectory(text, "fuzz-input");
  } catch (const rrslam::Error&) {
    return 0;
  }
  for (const rrslam::StampedPose& p : t) {
    Check(std::isfinite(p.timestamp) && p.T_world_cam.translation.allFinite());
    Check(std::fabs(p.T_world_cam.rotation.norm() - 1) < 1e-9);
  }
  // Outside the try: an error reading back what FormatTumTrajectory wrote is
  // a finding.
  const std::string formatted = rrslam::FormatTumTrajectory(t);
  const rrslam::Trajectory again = rrslam::ParseTumTrajectory(formatted, "formatted");
  Check(again.size() == t.size());
  // Quaternions come back within the 9 decimals written (they are
  // renormalized on reading, so their last digit may move); timestamps and
  // translations come back to the same text.
  rrslam::Trajectory mixed = again;
  for (size_t k = 0; k < t.size(); ++k) {
    const Eigen::Vector4d d =
        again[k].T_world_cam.rotation.coeffs() - t[k].T_world_cam.rotation.coeffs();
    Check(d.cwiseAbs().maxCoeff() < 2e-9);
    mixed[k].T_world_cam.rotation = t[k].T_world_cam.rotation;
  }
  Check(rrslam::FormatTumTrajectory(mixed) == formatted);
  return 0;
}
