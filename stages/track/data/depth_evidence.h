// Restore mapping's change evidence: what a frame's depth image says about a
// map point predicted visible at a pixel and not matched there. A point not
// matched is no evidence of change (blur, lighting, another viewing angle
// keep ORB from finding it); the depth image is: a surface measured at the
// point's depth says it is still there, and depths clearly beyond it all
// round its pixel say the camera sees through where it was.
//
// Units: depths in metres along the camera's z axis; pixels are real image
// pixels (distorted, as the depth image is stored; PinholeCamera::
// ProjectDistorted), (0, 0) the centre of the top-left pixel.
#pragma once

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

namespace rrslam {

enum class DepthEvidence {
  kNone,        // No say: too few valid depths there, or something in front (occluded).
  kPresent,     // A depth within the gap of the point's: a surface is still there.
  kSeenThrough  // Every valid depth round the pixel lies beyond the point by more than the gap.
};

// The depth gap (metres) that counts as "clearly beyond" a point at depth z:
// max(10 cm, 15% of z). Kinect-like sensors' noise grows with depth (about
// 1.5e-3 z^2 m, 1.4 cm at 3 m), so the relative part keeps far points from
// being seen through by noise; the fixed part covers mixed pixels at edges.
double DepthEvidenceGap(double z);

// The depth difference (metres) within which a map point at depth z accounts
// for a keypoint measured near its pixel, i.e. the map already has that
// surface: max(3 cm, 3% of z), about twice the Kinect's noise at 3 m plus
// the map point's own error. Tighter than DepthEvidenceGap: a new object
// standing 10 cm before a wall is new, yet not a reason to cull the wall.
double DepthCoverGap(double z);

// The evidence of `depth_metres` (CV_32F; 0 or not finite = no depth) in the
// 5 x 5 window round `pixel` about a point at depth `z` (> 0). A window with
// fewer than half its pixels valid, off the image, or with any depth short
// of the point by more than the gap (an occluder or a depth edge) says
// nothing; any depth within the gap says present.
DepthEvidence DepthEvidenceAt(const cv::Mat& depth_metres, const Eigen::Vector2d& pixel, double z);

}  // namespace rrslam
