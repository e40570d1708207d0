#include "stages/render/map_scene.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "common/dataset.h"
#include "common/errors.h"
#include "stages/eval/ate.h"
#include "stages/mapstore/map_file.h"

namespace rrslam {
namespace {

Rigid3d PoseOf(const MapPose& pose) {
  const Rigid3d T_cam_world(Eigen::Quaterniond(pose.qw, pose.qx, pose.qy, pose.qz).normalized(),
                            Eigen::Vector3d(pose.tx, pose.ty, pose.tz));
  return T_cam_world.Inverse();
}

// The loaded map's next ids from the metadata of a restore-mapping run, or
// nullopt (a map built from scratch, or metadata that is not such JSON).
std::optional<std::pair<uint64_t, uint64_t>> LoadedMapIds(const std::string& metadata) {
  const nlohmann::json json = nlohmann::json::parse(metadata, nullptr, /*allow_exceptions=*/false);
  if (!json.is_object() || !json.contains("loaded_map")) return std::nullopt;
  const nlohmann::json& loaded = json["loaded_map"];
  if (!loaded.is_object() || !loaded.contains("next_keyframe_id") ||
      !loaded.contains("next_map_point_id") || !loaded["next_keyframe_id"].is_number_unsigned() ||
      !loaded["next_map_point_id"].is_number_unsigned()) {
    return std::nullopt;
  }
  return std::make_pair(loaded["next_keyframe_id"].get<uint64_t>(),
                        loaded["next_map_point_id"].get<uint64_t>());
}

}  // namespace

std::optional<size_t> MapScene::FindKeyFrame(uint64_t id) const {
  const auto it = std::lower_bound(keyframes.begin(), keyframes.end(), id,
                                   [](const SceneKeyFrame& kf, uint64_t v) { return kf.id < v; });
  if (it == keyframes.end() || it->id != id) return std::nullopt;
  return static_cast<size_t>(it - keyframes.begin());
}

Trajectory MapScene::KeyFrameTrajectory() const {
  Trajectory trajectory;
  trajectory.reserve(keyframes.size());
  for (const SceneKeyFrame& kf : keyframes) trajectory.push_back({kf.timestamp, kf.T_world_cam});
  std::stable_sort(
      trajectory.begin(), trajectory.end(),
      [](const StampedPose& a, const StampedPose& b) { return a.timestamp < b.timestamp; });
  return trajectory;
}

MapScene MakeMapScene(const MapData& map, const std::string& source) {
  MapScene scene;
  scene.camera = map.camera;
  scene.source = source;
  const auto loaded_ids = LoadedMapIds(map.metadata);
  scene.has_loaded_part = loaded_ids.has_value();

  scene.keyframes.reserve(map.keyframes.size());
  for (const KeyFrameRecord& record : map.keyframes) {
    SceneKeyFrame kf;
    kf.id = record.id;
    kf.timestamp = record.timestamp;
    kf.T_world_cam = PoseOf(record.T_cam_world);
    kf.parent = record.parent;
    kf.connections = record.connections;
    kf.loop_edges = record.loop_edges;
    kf.loaded = loaded_ids && record.id < loaded_ids->first;
    scene.keyframes.push_back(std::move(kf));
  }
  scene.points.reserve(map.map_points.size());
  for (const MapPointRecord& record : map.map_points) {
    ScenePoint point;
    point.id = record.id;
    point.position = Eigen::Vector3d(record.position[0], record.position[1], record.position[2]);
    point.normal = Eigen::Vector3d(record.normal[0], record.normal[1], record.normal[2]);
    point.observations = static_cast<int>(record.observations.size());
    point.seen_at.reserve(record.observations.size());
    for (const auto& [keyframe, index] : record.observations) {
      // ValidateMapData (ReadMapFile) checked the keyframe and index exist.
      const auto it =
          std::lower_bound(map.keyframes.begin(), map.keyframes.end(), keyframe,
                           [](const KeyFrameRecord& kf, uint64_t id) { return kf.id < id; });
      if (it == map.keyframes.end() || it->id != keyframe || index >= it->keypoints.size()) {
        continue;
      }
      point.seen_at.push_back(
          {keyframe, it->keypoints[index].pixel.x(), it->keypoints[index].pixel.y()});
    }
    point.first_keyframe = record.first_keyframe;
    point.loaded = loaded_ids && record.id < loaded_ids->second;
    scene.points.push_back(point);
  }
  return scene;
}

std::vector<std::optional<size_t>> MatchKeyFrameTimestamps(
    const MapScene& scene, const std::vector<double>& rgb_timestamps) {
  std::vector<double> queries;
  for (const SceneKeyFrame& kf : scene.keyframes) queries.push_back(kf.timestamp);
  return MatchTimestamps(queries, rgb_timestamps, kKeyFrameTimestampTolerance);
}

std::vector<size_t> KeyFrameFrames(const MapScene& scene, const RgbdSequence& sequence) {
  std::vector<double> stamps;
  for (const RgbdFrameRef& frame : sequence.frames()) stamps.push_back(frame.rgb_timestamp);
  const std::vector<std::optional<size_t>> matched = MatchKeyFrameTimestamps(scene, stamps);
  std::vector<size_t> frames;
  std::optional<size_t> first_missing;
  size_t missing = 0;
  for (size_t k = 0; k < matched.size(); ++k) {
    if (matched[k]) {
      frames.push_back(*matched[k]);
    } else if (missing++ == 0) {
      first_missing = k;
    }
  }
  if (first_missing) {
    const SceneKeyFrame& keyframe = scene.keyframes[*first_missing];
    throw DataError(fmt::format(
        "{}: keyframe {} (t = {:.6f}) has no frame in {} ({} of {} keyframes have none: was the "
        "map built from this sequence and --associations?)",
        scene.source, keyframe.id, keyframe.timestamp, sequence.dir().string(), missing,
        matched.size()));
  }
  return frames;
}

MapScene LoadMapScene(const std::filesystem::path& path) {
  return MakeMapScene(ReadMapFile(path), path.string());
}

Trajectory ExpressInMapFrame(const Trajectory& other, const MapScene& scene,
                             const std::string& source) {
  const Trajectory keyframes = scene.KeyFrameTrajectory();
  AteAlignment alignment;
  try {
    alignment = ComputeAteAlignment(other, keyframes);
  } catch (const DataError& e) {
    throw DataError(source + ": cannot be aligned to the keyframes of " + scene.source + " (" +
                    e.what() + ")");
  }
  // T_gt_map maps the map's frame into the other's; the other's poses in the
  // map frame are T_map_gt * T_gt_cam.
  const Rigid3d T_map_other = alignment.T_gt_est.Inverse();
  Trajectory result;
  result.reserve(other.size());
  for (const StampedPose& pose : other) {
    result.push_back({pose.timestamp, T_map_other * pose.T_world_cam});
  }
  return result;
}

}  // namespace rrslam
