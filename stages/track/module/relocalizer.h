// Relocalization: finds the pose of a frame that lost track (or a cold start
// on a loaded map) against the whole map, in up to two stages.
//
// The bag-of-words stage (ORB-SLAM2's Tracking::Relocalization, written anew):
//  1. Candidates: the keyframe database's relocalization candidates for the
//     frame's bag of words (shared words, covisibility-group scores).
//  2. Per candidate: BoW matching of the frame's keypoints to the
//     candidate's map points (ratio 0.75, rotation histogram); at least 15.
//  3. PnP RANSAC on those 2D-3D matches (SolvePnpRansac below), then pose
//     optimization; fewer than 10 inliers rejects the candidate.
//  4. Verification: with fewer than 50 inliers, the candidate's other map
//     points are projected with that pose and matched in a 10 px window
//     (distance <= 100), the pose optimized again; between 30 and 50
//     inliers, once more in a 3 px window (distance <= 64). 50 inliers
//     relocalize the frame.
// Candidates are tried in the database's order (by id); the first that
// reaches 50 inliers wins. (ORB-SLAM2 interleaves 5 RANSAC iterations per
// candidate in turns; running each candidate's RANSAC to its end instead
// keeps batch runs bit-identical with a seeded generator and, since the
// winner needs 50 inliers either way, finds the same poses.)
//
// The direct stage (not in ORB-SLAM2; after Active Search, Sattler et al.,
// TPAMI 2017, with depth): where no keyframe shortlist reaches the view, the
// frame's descriptors are matched to every map point's descriptor through an
// LSH index (data/map_point_index.h): the nearest point within
// `max_distance` bits that passes the ratio test against the second nearest
// (a second nearest within `same_point_radius` of the first is the same
// place seen twice and does not count), one keypoint per point, the most
// distinctive `max_matches` kept. The strongest `first_queries` keypoints
// are searched first; the rest only when their pose is not accepted. A RANSAC over these fits the
// pose from three keypoints with depth (solve/absolute_pose_ransac.h), or by PnP (SolvePnpRansac)
// when fewer than min_inliers have depth. The inliers then seed a search of their local map
// (LocalMapVerifyOptions: the keyframes observing them and their covisible ones, as the tracker
// searches after a relocalization); 50 inliers relocalize the frame. The map-point index is
// deterministic (its own seeded LSH), so batch runs stay bit-identical.
//
// `bow_covisible` widens the BoW stage as ORB-SLAM3's place recognition:
// each candidate's matches joined by those of its best covisible keyframes,
// the pose verified against their local map.
//
// `method` picks the stages: bow (ORB-SLAM2), direct, or bow+direct (the
// direct stage when the BoW stage finds no pose). A frame that has a pose of
// its own (localization mode's visual odometry, which tries to relocalize on
// every frame and lets a relocalization win) gets the BoW stage alone under
// bow+direct: the direct stage is for frames with no pose, and from views
// far from the mapped ones its pose is less accurate than visual odometry's
// (docs/track.md, "Direct relocalization").
//
// Thread-safety: the caller holds Map::mutex().
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <future>
#include <string>
#include <vector>

#include "common/geometry.h"
#include "stages/track/data/frame.h"
#include "stages/track/data/keyframe.h"
#include "stages/track/data/keyframe_database.h"
#include "stages/track/data/map.h"
#include "stages/track/data/map_point_index.h"
#include "stages/track/data/sensor_model.h"
#include "stages/track/optimize/optimizer.h"
#include "stages/track/solve/absolute_pose_ransac.h"

namespace rrslam {

class Matcher;

struct PnpRansacOptions {
  // ORB-SLAM2's PnPsolver::SetRansacParameters(0.99, 10, 300, 4, 0.5, 5.991).
  double probability = 0.99;  // Of drawing one all-inlier minimal set.
  int min_inliers = 10;       // And at least min_inlier_ratio of the matches.
  double min_inlier_ratio = 0.5;
  int max_iterations = 300;
  // Inlier: squared reprojection error below chi2 * sigma^2 of the keypoint's
  // octave (5.991: 95% for two degrees of freedom).
  double chi2 = 5.991;
};

struct PnpResult {
  bool ok = false;
  Rigid3d T_cam_world;
  std::vector<uint8_t> inlier;  // Per correspondence.
  int inliers = 0;
  int iterations = 0;
};

// Camera pose from 2D-3D correspondences with outliers: RANSAC over minimal
// sets of 4 correspondences solved by EPnP (OpenCV's cv::solvePnP with
// SOLVEPNP_EPNP), each hypothesis scored by the correspondences within their
// octave's chi-square bound; the best hypothesis is refitted by EPnP on its
// inliers and rescored. The iteration count adapts to the inlier ratio, as
// ORB-SLAM2's PnPsolver does. (Not cv::solvePnPRansac: it has one pixel
// threshold for all correspondences, where ORB-SLAM2 scales it with each
// keypoint's octave.) `pixels` are ideal (undistorted) pixels of the camera
// `K`; `sigma2` the squared pixel sigma of each. Deterministic for a `seed`.
PnpResult SolvePnpRansac(const std::vector<Eigen::Vector3d>& points_world,
                         const std::vector<Eigen::Vector2d>& pixels,
                         const std::vector<double>& sigma2, const Eigen::Matrix3d& K,
                         const PnpRansacOptions& options, uint64_t seed);

enum class RelocalizationMethod { kBow, kBowDirect, kDirect };
// "bow", "bow+direct", "direct" (the --relocalization values).
std::string ToString(RelocalizationMethod method);
// The three names, in that order.
std::vector<std::string> RelocalizationMethodNames();
// False when `name` is none of them.
bool ParseRelocalizationMethod(const std::string& name, RelocalizationMethod* method);

struct DirectMatchOptions {
  int max_distance = 50;            // Bits (ORB-SLAM2's TH_LOW).
  double ratio = 0.8;               // Nearest / second nearest distance.
  double same_point_radius = 0.05;  // Metres.
  int max_matches = 400;            // The most distinctive, into the RANSAC.
  // Prioritised search: the `first_queries` strongest keypoints (those with
  // depth first, then by corner response) are searched first, and the pose
  // from their matches tried; only when it is not accepted are the rest
  // searched and the pose tried again from all matches. The search is the
  // stage's cost, bound by memory latency on a large map. 0: all at once.
  int first_queries = 500;
  AbsolutePoseRansacOptions ransac;
  MapPointIndexOptions index;
};

// Verification of a pose against its local map (the direct stage's, and
// the BoW stage's with a covisible window): the keyframes observing the
// pose's inlier points and their best covisible ones, up to `keyframes`;
// their points projected and matched in the tracker's window after a
// relocalization (`search_radius` x the scale of the predicted level),
// `rounds` times, the pose optimized after each.
struct LocalMapVerifyOptions {
  int keyframes = 30;
  double search_radius = 5.0;
  int rounds = 2;
};

struct RelocalizationOptions {
  RelocalizationMethod method = RelocalizationMethod::kBowDirect;
  double bow_ratio = 0.75;
  int min_bow_matches = 15;
  // Each candidate's BoW matches joined by those of its best covisible
  // keyframes, up to this many (ORB-SLAM3's place recognition matches a
  // candidate's covisible window; 0: the candidate alone, as ORB-SLAM2).
  int bow_covisible = 0;
  int min_pose_inliers = 10;  // After the first pose optimization.
  int min_inliers = 50;       // To accept the pose.
  PnpRansacOptions ransac;
  DirectMatchOptions direct;
  LocalMapVerifyOptions local_map;
  // Names the first field out of range.
  bool Check(std::string* why) const;
};

// What one attempt did (run.json's relocalization attempts).
struct RelocalizationAttempt {
  std::string stage;       // "bow" or "direct": the stage that found the pose; "" none.
  int bow_candidates = 0;  // Keyframes the database proposed.
  int direct_matches = 0;  // Correspondences into the direct stage's (last) RANSAC.
  int direct_queries = 0;  // Keypoints the direct stage searched the index for.
  // After verification: of the accepted pose; when none was accepted, the
  // most that any verified pose reached.
  int inliers = 0;
  double bow_query_ms = 0;  // The keyframe database's query for the BoW candidates.
  double bow_stage_ms = 0;  // The whole BoW stage: the query and its candidates' checks.
  double index_ms = 0;  // Waiting for the map-point index, or rebuilding it, when this attempt did.
  double ms = 0;        // The whole attempt (the tracker times it).
  double timestamp = 0;  // The frame's (the tracker sets it).
};

class Relocalizer {
 public:
  // References must outlive the relocalizer.
  Relocalizer(const SensorModel& sensor, const KeyFrameDatabase& database, const Map& map,
              const RelocalizationOptions& options = {})
      : sensor_(sensor),
        database_(database),
        map_(map),
        options_(options),
        index_(options.direct.index) {}

  // Tries to relocalize `frame` (its bag of words computed when the method
  // has the BoW stage). On success sets its pose and its map points (inliers
  // only) and returns the keyframe that gave the pose; otherwise returns
  // nullptr and leaves the frame's map points empty. `solves` (may be null)
  // counts the pose optimizations; `attempt` (may be null) says what
  // happened (all but ms). `has_pose`: the frame is tracked otherwise (no
  // direct stage after the BoW stage).
  KeyFrame* Relocalize(Frame* frame, SolveCounts* solves = nullptr,
                       RelocalizationAttempt* attempt = nullptr, bool has_pose = false);
  // An attempt as the tracker makes and times it: the frame's bag of words
  // (`vocabulary`, feature vector `bow_levels_up` levels up) computed when
  // the method has the BoW stage, then Relocalize(); `attempt->ms` (not null)
  // is the whole of both.
  KeyFrame* RelocalizeTimed(Frame* frame, const Vocabulary& vocabulary, int bow_levels_up,
                            SolveCounts* solves, RelocalizationAttempt* attempt,
                            bool has_pose = false);
  // Builds the direct stage's map-point index now, unless the method has no
  // direct stage or it is current (waiting first for a build started by
  // PrepareIndexInBackground); returns the ms this call spent waiting and
  // building (0 when it did neither).
  double PrepareIndex();
  // A map just loaded: the index's points taken now (call under the map's
  // mutex), its tables built on a thread of their own while tracking starts;
  // the first direct attempt waits for them (the same index, so the same
  // poses, as a build in place). Nothing without a direct stage.
  void PrepareIndexInBackground();
  // Waits for a build started by PrepareIndexInBackground; the ms of the
  // last build started that way (snapshot and tables), 0 when none was.
  double WaitForBackgroundIndex();

 private:
  KeyFrame* RelocalizeByBow(Frame* frame, SolveCounts* solves, RelocalizationAttempt* attempt);
  // The BoW matches of `frame`'s keypoints with `kf`'s map points (and its
  // covisible keyframes', RelocalizationOptions::bow_covisible): one map
  // point or nullptr per keypoint; the number matched.
  int BowMatches(const Matcher& matcher, const KeyFrame& kf, const Frame& frame,
                 std::vector<MapPoint*>* matches) const;
  KeyFrame* RelocalizeDirect(Frame* frame, SolveCounts* solves, RelocalizationAttempt* attempt);
  // The frame's keypoints in the direct stage's search order: with depth
  // first, then by corner response (strongest first), then by index.
  static std::vector<uint32_t> QueryOrder(const Frame& frame);
  // The index's nearest points of keypoints order[begin, end) into
  // `nearest` (one entry per keypoint of the frame).
  void SearchIndex(const Frame& frame, const std::vector<uint32_t>& order, size_t begin, size_t end,
                   std::vector<DescriptorNeighbours>* nearest) const;
  // The frame's map points matched among `nearest`, with their RANSAC inputs.
  std::vector<PoseCorrespondence> DirectMatches(const Frame& frame,
                                                const std::vector<DescriptorNeighbours>& nearest,
                                                std::vector<MapPoint*>* points,
                                                std::vector<uint32_t>* keypoints) const;
  // The pose from `nearest`'s matches, verified against its local map: the
  // keyframe observing most inliers when accepted, else nullptr (matches
  // cleared).
  KeyFrame* DirectPose(Frame* frame, const std::vector<DescriptorNeighbours>& nearest,
                       SolveCounts* solves, RelocalizationAttempt* attempt);
  // The direct stage's pose from `matches`: the 3D-3D RANSAC, or PnP when
  // fewer than min_inliers matches have depth; false when neither finds one.
  bool SolveDirectPose(const std::vector<PoseCorrespondence>& matches, uint64_t seed,
                       std::vector<uint8_t>* inlier, Rigid3d* T) const;
  // A pose found from a frame's inlier matches (set with the pose), against
  // `keyframe`: optimized, completed by projection; the inliers it ends with
  // (0 when below min_pose_inliers after the first optimization).
  int Verify(Frame* frame, const KeyFrame& keyframe, SolveCounts* solves) const;
  // Verification against the local map (LocalMapVerifyOptions) of a pose
  // found from a frame's inlier matches; the inliers it ends with (0 when
  // below min_pose_inliers after the first optimization).
  int VerifyByLocalMap(Frame* frame, SolveCounts* solves) const;
  // Pose optimization of the frame's matches; drops the outliers; the inliers.
  int OptimizeInliers(Frame* frame, SolveCounts* solves) const;

  const SensorModel& sensor_;
  const KeyFrameDatabase& database_;
  const Map& map_;
  RelocalizationOptions options_;
  MapPointIndex index_;  // Rebuilt at the first direct attempt after the map changed.
  // PrepareIndexInBackground's tables under way (their ms when done); after
  // index_, so that it is joined before index_ goes.
  std::future<double> background_index_;
  double background_index_ms_ = 0;
};

}  // namespace rrslam
