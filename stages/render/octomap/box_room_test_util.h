// Test helper: depth images of a box room, rendered exactly by casting each
// pixel's ray against axis-aligned boxes (the room from inside, a table from
// outside), from cameras at the room's centre turning round and looking a
// little down. Frame: the floor frame (z up, floor at z = 0), metres.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/core/mat.hpp>
#include <vector>

#include "common/geometry.h"
#include "stages/render/keyframe_images.h"

namespace rrslam::testing {

struct BoxRoom {
  Eigen::AlignedBox3d room{Eigen::Vector3d(-2, -1.5, 0), Eigen::Vector3d(2, 1.5, 2.5)};
  Eigen::AlignedBox3d table{Eigen::Vector3d(0.8, -0.4, 0), Eigen::Vector3d(1.4, 0.4, 0.75)};
  KeyFrameCamera camera{100, 100, 80, 60, 160, 120};
  double camera_height = 1.2;

  // Camera k of n: at (0, 0, camera_height), heading 2 pi k / n, 20 degrees down.
  Rigid3d CameraPose(int k, int n) const {
    const double heading = 2 * M_PI * k / n, tilt = 20 * M_PI / 180;
    const Eigen::Vector3d forward(std::cos(heading) * std::cos(tilt),
                                  std::sin(heading) * std::cos(tilt), -std::sin(tilt));
    const Eigen::Vector3d right(std::sin(heading), -std::cos(heading), 0);
    Eigen::Matrix3d R_floor_cam;
    R_floor_cam << right, forward.cross(right), forward;
    return Rigid3d(Eigen::Quaterniond(R_floor_cam), Eigen::Vector3d(0, 0, camera_height));
  }

  // Distance along the ray to where it leaves the room or enters the table.
  double Hit(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir) const {
    double exit = std::numeric_limits<double>::infinity();
    for (int a = 0; a < 3; ++a) {
      if (dir[a] > 0) exit = std::min(exit, (room.max()[a] - origin[a]) / dir[a]);
      if (dir[a] < 0) exit = std::min(exit, (room.min()[a] - origin[a]) / dir[a]);
    }
    double enter = 0, leave = std::numeric_limits<double>::infinity();
    for (int a = 0; a < 3; ++a) {
      if (dir[a] == 0) {
        if (origin[a] < table.min()[a] || origin[a] > table.max()[a]) leave = -1;
        continue;
      }
      double t0 = (table.min()[a] - origin[a]) / dir[a], t1 = (table.max()[a] - origin[a]) / dir[a];
      if (t0 > t1) std::swap(t0, t1);
      enter = std::max(enter, t0);
      leave = std::min(leave, t1);
    }
    return enter <= leave && enter > 0 ? std::min(exit, enter) : exit;
  }

  // The depth image (metres along the optical axis) of a camera at T_floor_cam.
  cv::Mat Depth(const Rigid3d& T_floor_cam) const {
    cv::Mat depth(camera.height, camera.width, CV_32FC1);
    const Eigen::Matrix3d R = T_floor_cam.RotationMatrix();
    for (int v = 0; v < camera.height; ++v) {
      for (int u = 0; u < camera.width; ++u) {
        const Eigen::Vector3d ray_cam((u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy, 1);
        depth.at<float>(v, u) =
            static_cast<float>(Hit(T_floor_cam.translation, R * ray_cam));  // z = 1 per unit.
      }
    }
    return depth;
  }
};

}  // namespace rrslam::testing
