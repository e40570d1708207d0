// The optimizations of loop closing, in Ceres, as ORB-SLAM2 does them with
// g2o for RGB-D (scale fixed, so Sim(3) becomes SE(3)):
//  - OptimizeRelativePose: the transform between the loop keyframes from
//    their matched map points (ORB-SLAM2's OptimizeSim3);
//  - OptimizePoseGraph: a graph of keyframe poses and relative-pose edges;
//    MoveLoopNeighbourhood and EssentialGraphAdjuster: the loop correction
//    and its essential graph (ORB-SLAM2's OptimizeEssentialGraph) on it, in
//    collect / solve / apply phases;
//  - GlobalBundleAdjuster: every keyframe and map point (ORB-SLAM2's
//    GlobalBundleAdjustemnt), in collect / solve / apply phases like the
//    local bundle adjustment, so the map lock is not held while it solves.
// Iteration counts are g2o's (successful steps, see optimizer.h). All solves
// run on one thread: results are bit-identical run to run.
#pragma once

#include <array>
#include <atomic>
#include <vector>

#include "common/geometry.h"
#include "stages/track/data/keyframe.h"
#include "stages/track/data/map.h"
#include "stages/track/data/sensor_model.h"
#include "stages/track/optimize/optimizer.h"

namespace rrslam {

// Refines T_12 (maps kf2 camera coordinates to kf1's) from the matches
// `matches12` (per kf1 keypoint, kf2's map point or nullptr; both points
// held fixed in their cameras' coordinates): each match gives the
// reprojection of kf2's point into image 1 and of kf1's point into image 2,
// whitened by the keypoints' octave sigma, with a Huber loss of width
// sqrt(chi2). 5 steps, then matches with either error above chi2 are
// dropped from `matches12`, then 10 more steps (5 when none was dropped);
// matches still above chi2 are dropped. Returns the inliers left, 0 (T_12
// unchanged) when fewer than 10 matches survive the first classification.
int OptimizeRelativePose(const SensorModel& sensor, const KeyFrame& kf1, const KeyFrame& kf2,
                         std::vector<MapPoint*>* matches12, Rigid3d* T_12, double chi2 = 10.0,
                         SolveCounts* counts = nullptr);

// A graph of camera poses (T_cam_world) with relative-pose edges.
struct PoseGraph {
  struct Edge {
    int i, j;       // Vertex indices.
    Rigid3d T_j_i;  // Measured T_jw * T_iw^-1 (maps camera i to camera j).
  };
  std::vector<Rigid3d> poses;  // T_cam_world per vertex; optimized in place.
  std::vector<uint8_t> fixed;  // Per vertex.
  std::vector<Edge> edges;
  int AddVertex(const Rigid3d& T_cam_world, bool is_fixed) {
    poses.push_back(T_cam_world);
    fixed.push_back(is_fixed);
    return static_cast<int>(poses.size()) - 1;
  }
};

// Minimizes, over the free vertices, the sum over edges of |r|^2 with r the
// 6-vector (2 * vector part of the rotation error quaternion, translation
// error) of T_j_i * T_iw * T_jw^-1 (identity information, no robust loss:
// ORB-SLAM2's essential graph with its Sim(3) edges at fixed scale).
// `iterations` successful Levenberg-Marquardt steps (ORB-SLAM2: 20).
// Returns the Ceres summary's final cost.
double OptimizePoseGraph(PoseGraph* graph, int iterations = 20, SolveCounts* counts = nullptr);

struct GlobalBundleAdjustmentStats {
  int keyframes = 0;
  int points = 0;
  int observations = 0;
  bool aborted = false;
  double initial_cost = 0;
  double final_cost = 0;
  SolveCounts solves;
};

// "No keyframe": an unset entry of LoopCorrection::corrected_reference.
inline constexpr KeyFrameId kNoKeyFrameId = static_cast<KeyFrameId>(-1);

// The part of a loop correction (loop_closer.h, step 3) the essential graph
// starts from.
struct LoopCorrection {
  KeyFrame* keyframe = nullptr;        // The keyframe that closed the loop.
  const KeyFrame* matched = nullptr;   // Its loop keyframe: fixed in the graph.
  std::vector<KeyFrame*> moved;        // The keyframe and its covisible keyframes, by id.
  std::vector<Rigid3d> non_corrected;  // Their T_cam_world before the correction.
  // Per moved keyframe: the keyframes the loop connected it to.
  std::vector<std::vector<KeyFrame*>> loop_connections;
  // Per map point id (when the correction was made): the id of the moved
  // keyframe whose correction moved the point, or kNoKeyFrameId.
  std::vector<KeyFrameId> corrected_reference;
};

// The correction's first move (map locked): `keyframe`'s connections are
// updated, it is moved to `T_cam_world` and its covisible keyframes with it
// (each keeps its pose relative to it, and gets its connections updated);
// each of their points moves with the first of them (by id) observing it.
// Returns the moved keyframes, their poses before, and corrected_reference;
// loop_connections are left to the caller (one empty list per moved).
LoopCorrection MoveLoopNeighbourhood(const SensorModel& sensor, Map* map, KeyFrame* keyframe,
                                     const KeyFrame* matched, const Rigid3d& T_cam_world);

// The essential graph of a loop correction (ORB-SLAM2's
// OptimizeEssentialGraph with its Sim(3) at fixed scale), in three phases
// as GlobalBundleAdjuster, so that tracking goes on while Ceres solves (as
// in ORB-SLAM2, whose map lock is released for the optimization):
//   Collect (map locked): a vertex per keyframe at its current pose, the
//     loop's matched keyframe fixed; edges: the loop connections of weight
//     >= min_weight (the loop pair always) from the corrected poses; the
//     spanning tree, earlier loop edges and covisibility of weight >=
//     min_weight (each pair once) from the poses before the correction.
//   Solve (no map access): OptimizePoseGraph, `iterations` steps.
//   Apply (map locked): the keyframes get their optimized poses (keyframes
//     made since move with their spanning-tree parent); every point moves
//     with the keyframe whose correction moved it, else with its reference
//     keyframe, and gets its normal and depth range updated.
class EssentialGraphAdjuster {
 public:
  EssentialGraphAdjuster(const SensorModel& sensor, int min_weight, int iterations)
      : sensor_(sensor), min_weight_(min_weight), iterations_(iterations) {}

  void Collect(const Map& map, LoopCorrection correction);
  void Solve();
  void Apply(Map* map);

  int vertices() const { return static_cast<int>(graph_.poses.size()); }
  int edges() const { return static_cast<int>(graph_.edges.size()); }
  const SolveCounts& solves() const { return solves_; }

 private:
  const SensorModel& sensor_;
  int min_weight_;
  int iterations_;
  std::vector<KeyFrame*> keyframes_;  // One per vertex, in vertex order.
  std::vector<Rigid3d> initial_;      // Per vertex: the pose collected.
  PoseGraph graph_;
  std::vector<KeyFrameId> corrected_reference_;
  SolveCounts solves_;
};

// Global bundle adjustment (ORB-SLAM2's GlobalBundleAdjustemnt with
// nIterations = 10): every keyframe of the map (the root fixed) and every
// map point, plain squared reprojection errors (u, v, u_R with depth): no
// robust loss (ORB-SLAM2's loop closing calls it with bRobust = false) and
// no outlier removal.
//   Collect (map locked): snapshot of the keyframes' poses, the points'
//     positions and the observations (point, keyframe, keypoint index).
//   Solve (no map access but the keyframes' features, which never change):
//     the observations' measurements, then `iterations` successful steps,
//     or until `abort`.
//   Apply (map locked): keyframes of the snapshot get their optimized
//     poses; keyframes made since are moved with their spanning-tree parent
//     (their pose relative to it kept); points of the snapshot get their
//     optimized positions, later points move with their reference keyframe.
//     Objects culled meanwhile are skipped.
class GlobalBundleAdjuster {
 public:
  explicit GlobalBundleAdjuster(const SensorModel& sensor, int iterations = 10)
      : sensor_(sensor), iterations_(iterations) {}

  void Collect(const Map& map);
  void Solve(const std::atomic<bool>* abort = nullptr);
  void Apply(Map* map);

  const GlobalBundleAdjustmentStats& stats() const { return stats_; }

 private:
  struct Observation {  // Indices; Solve reads the measurement (MeasurementOf).
    uint32_t point;
    uint32_t keyframe;
    uint32_t keypoint;
  };

  const SensorModel& sensor_;
  int iterations_;
  std::vector<KeyFrame*> keyframes_;
  std::vector<uint8_t> keyframe_fixed_;
  std::vector<std::array<double, 7>> poses_;
  std::vector<MapPoint*> points_;
  std::vector<Eigen::Vector3d> positions_;
  std::vector<Observation> observations_;
  GlobalBundleAdjustmentStats stats_;
};

}  // namespace rrslam
