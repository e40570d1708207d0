#include "stages/track/data/map_io.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <future>
#include <memory>
#include <optional>
#include <utility>

#include "common/errors.h"
#include "common/text.h"
#include "common/worker_pool.h"
#include "stages/mapstore/map_file.h"
#include "stages/mapstore/map_join.h"
#include "stages/track/data/frame.h"

namespace rrslam {
namespace {

std::string Number(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.10g", v);
  return buffer;
}

}  // namespace

MapCamera MapCameraFrom(const Settings& settings, int width, int height) {
  MapCamera c;
  c.fx = settings.fx;
  c.fy = settings.fy;
  c.cx = settings.cx;
  c.cy = settings.cy;
  c.k1 = settings.distortion.k1;
  c.k2 = settings.distortion.k2;
  c.p1 = settings.distortion.p1;
  c.p2 = settings.distortion.p2;
  c.k3 = settings.distortion.k3;
  c.width = width;
  c.height = height;
  c.bf = settings.bf;
  c.th_depth = settings.th_depth;
  c.depth_map_factor = settings.depth_map_factor;
  c.orb_features = settings.orb.n_features;
  c.orb_scale_factor = settings.orb.scale_factor;
  c.orb_levels = settings.orb.n_levels;
  c.orb_ini_th_fast = settings.orb.ini_th_fast;
  c.orb_min_th_fast = settings.orb.min_th_fast;
  return c;
}

MapVocabulary MapVocabularyFrom(const Vocabulary& vocabulary, const std::string& name) {
  MapVocabulary v;
  v.content_hash = vocabulary.content_hash();
  v.k = vocabulary.k();
  v.levels = vocabulary.levels();
  v.weighting = static_cast<int32_t>(vocabulary.weighting());
  v.scoring = static_cast<int32_t>(vocabulary.scoring());
  v.num_words = vocabulary.num_words();
  v.name = name;
  return v;
}

MapData ToMapData(const Map& map, const MapCamera& camera, const Vocabulary& vocabulary,
                  const std::string& vocabulary_name, int bow_levels_up,
                  const std::string& metadata) {
  MapData data;
  data.camera = camera;
  data.vocabulary = MapVocabularyFrom(vocabulary, vocabulary_name);
  data.bow_levels_up = bow_levels_up;
  data.next_keyframe_id = map.num_created_keyframes();
  data.next_map_point_id = map.num_created_map_points();
  data.metadata = metadata;

  const std::vector<KeyFrame*> keyframes = map.KeyFrames();
  const std::vector<MapPoint*> points = map.MapPoints();
  // In the map and not culled: only these appear in the file.
  std::vector<uint8_t> keyframe_kept(map.num_created_keyframes(), 0);
  std::vector<uint8_t> point_kept(map.num_created_map_points(), 0);
  for (const KeyFrame* kf : keyframes) keyframe_kept[kf->id()] = !kf->bad();
  for (const MapPoint* p : points) point_kept[p->id()] = !p->bad();
  auto kept_keyframe = [&](const KeyFrame* kf) {
    return kf != nullptr && kf->id() < keyframe_kept.size() && keyframe_kept[kf->id()];
  };

  data.keyframes.reserve(keyframes.size());
  for (KeyFrame* kf : keyframes) {
    if (!kept_keyframe(kf)) continue;
    KeyFrameRecord r;
    r.id = kf->id();
    r.frame_id = kf->frame_id();
    r.timestamp = kf->timestamp();
    r.T_cam_world = MapPoseOf(kf->T_cam_world());
    const FrameFeatures& f = kf->features();
    r.keypoints = f.keypoints;  // A loaded keyframe's view stays one (shared).
    r.map_point_ids.assign(f.size(), kNoId);
    for (size_t i = 0; i < f.size(); ++i) {
      const MapPoint* p = kf->map_point(i);
      if (p != nullptr && !p->bad() && point_kept[p->id()] &&
          p->IndexIn(kf) == static_cast<int>(i)) {
        r.map_point_ids[i] = p->id();
      }
    }
    r.descriptors = f.descriptors;
    if (!kf->has_bow()) kf->ComputeBow(vocabulary, bow_levels_up);
    r.bow.assign(kf->bow().entries.begin(), kf->bow().entries.end());
    r.feature_vector.assign(kf->feature_vector().entries.begin(),
                            kf->feature_vector().entries.end());
    for (const KeyFrame::Connection& c : kf->connections()) {
      if (kept_keyframe(c.keyframe)) r.connections.emplace_back(c.keyframe->id(), c.weight);
    }
    r.parent = kept_keyframe(kf->parent()) ? kf->parent()->id() : kNoId;
    for (const KeyFrame* l : kf->loop_edges()) {
      if (kept_keyframe(l)) r.loop_edges.push_back(l->id());
    }
    std::sort(r.loop_edges.begin(), r.loop_edges.end());
    data.keyframes.push_back(std::move(r));
  }

  data.map_points.reserve(points.size());
  for (const MapPoint* p : points) {
    if (p->bad()) continue;
    MapPointRecord r;
    r.id = p->id();
    for (int a = 0; a < 3; ++a) {
      r.position[a] = p->position_world()[a];
      r.normal[a] = p->normal()[a];
    }
    r.min_distance = p->min_distance();
    r.max_distance = p->max_distance();
    r.descriptor = p->descriptor();
    r.visible = p->visible();
    r.found = p->found();
    r.first_keyframe = p->first_keyframe_id();
    for (const MapPoint::Observation& o : p->observations()) {
      if (kept_keyframe(o.keyframe) && o.keyframe->map_point(o.index) == p) {
        r.observations.emplace_back(o.keyframe->id(), o.index);
      }
    }
    // A point whose observers all left the map has no place in the file.
    if (r.observations.empty()) continue;
    const KeyFrame* reference = p->reference_keyframe();
    r.reference_keyframe = kept_keyframe(reference) && p->IsObservedBy(reference)
                               ? reference->id()
                               : r.observations.front().first;
    data.map_points.push_back(std::move(r));
  }
  // Keypoints whose point was left out above lose their association too.
  std::vector<uint8_t> point_written(map.num_created_map_points(), 0);
  for (const MapPointRecord& r : data.map_points) point_written[r.id] = 1;
  for (KeyFrameRecord& r : data.keyframes) {
    for (uint64_t& id : r.map_point_ids) {
      if (id != kNoId && !point_written[id]) id = kNoId;
    }
  }
  return data;
}

void CheckMapCompatible(const MapData& data, const MapCamera& camera, const Vocabulary& vocabulary,
                        const std::string& source) {
  const MapVocabulary here = MapVocabularyFrom(vocabulary, "");
  if (!data.vocabulary.SameTree(here)) {
    throw DataError(source + ": built with vocabulary tree " + Hex64(data.vocabulary.content_hash) +
                    " (" + data.vocabulary.name + " k=" + std::to_string(data.vocabulary.k) +
                    " L=" + std::to_string(data.vocabulary.levels) +
                    " words=" + std::to_string(data.vocabulary.num_words) +
                    ") but --vocab is tree " + Hex64(here.content_hash) +
                    " (k=" + std::to_string(here.k) + " L=" + std::to_string(here.levels) +
                    " words=" + std::to_string(here.num_words) + ")");
  }
  const MapCamera& m = data.camera;
  const SettingPair fields[] = {
      {"Camera.fx", m.fx, camera.fx},
      {"Camera.fy", m.fy, camera.fy},
      {"Camera.cx", m.cx, camera.cx},
      {"Camera.cy", m.cy, camera.cy},
      {"Camera.k1", m.k1, camera.k1},
      {"Camera.k2", m.k2, camera.k2},
      {"Camera.p1", m.p1, camera.p1},
      {"Camera.p2", m.p2, camera.p2},
      {"Camera.k3", m.k3, camera.k3},
      {"image width", double(m.width), double(camera.width)},
      {"image height", double(m.height), double(camera.height)},
      {"Camera.bf", m.bf, camera.bf},
      {"ThDepth", m.th_depth, camera.th_depth},
      {"DepthMapFactor", m.depth_map_factor, camera.depth_map_factor},
      {"ORBextractor.nFeatures", double(m.orb_features), double(camera.orb_features)},
      {"ORBextractor.scaleFactor", m.orb_scale_factor, camera.orb_scale_factor},
      {"ORBextractor.nLevels", double(m.orb_levels), double(camera.orb_levels)},
      {"ORBextractor.iniThFAST", double(m.orb_ini_th_fast), double(camera.orb_ini_th_fast)},
      {"ORBextractor.minThFAST", double(m.orb_min_th_fast), double(camera.orb_min_th_fast)},
  };
  if (const SettingPair* d = FirstDifferentSetting(fields)) {
    throw DataError(source + ": built with " + d->key + " = " + Number(d->recorded) +
                    " but the settings give " + Number(d->given));
  }
}

HeapReservation ReserveHeapForLoadMap(const std::filesystem::path& path) {
  return ReserveHeapForMap(path, 4, 0.8);
}

void LoadMapData(MapData data, const SensorModel& sensor, const Vocabulary& vocabulary,
                 int bow_levels_up, Map* map, KeyFrameDatabase* database,
                 const std::string& source) {
  if (map->num_created_keyframes() > 0 || map->num_created_map_points() > 0) {
    throw DataError(source + ": cannot load a map into a map that is not empty");
  }
  // Ids index the map's arrays (Map::ReserveIds): the next ids must be in
  // proportion to the map before anything is allocated for them.
  CheckMapNextIds(data, source);
  const bool recompute_bow = data.bow_levels_up != bow_levels_up;
  if (recompute_bow) {
    spdlog::info("{}: feature vectors grouped {} levels up, this run groups {}; recomputing them",
                 source, data.bow_levels_up, bow_levels_up);
  }

  // Each keyframe's frame (features, pose, bag of words), then the
  // keyframes, in id order. Frames are independent: recomputed bags of words
  // (CPU-bound) are built on two threads; otherwise the work is mostly first
  // touches of fresh memory, which stays on this thread, whose heap
  // ReserveHeap prepared (track.cc). The result does not depend on the split.
  std::vector<std::optional<Frame>> frames(data.keyframes.size());
  WorkerPool pool(recompute_bow ? 2 : 1);
  pool.ParallelFor(frames.size(), [&](size_t k) {
    KeyFrameRecord& r = data.keyframes[k];
    // The keypoints and descriptors go to the frame as they are: views of
    // the map file stay views (no copy, no fresh memory: 62% of the file).
    Frame& frame = frames[k].emplace(
        r.frame_id, r.timestamp,
        BuildFrameFeatures(sensor, std::move(r.keypoints), std::move(r.descriptors)));
    frame.SetPose(RigidOf(r.T_cam_world));
    if (recompute_bow) {
      frame.ComputeBow(vocabulary, bow_levels_up);
    } else {
      BowVector bow;
      bow.entries = std::move(r.bow);
      FeatureVector fv;
      fv.entries = std::move(r.feature_vector);
      frame.SetBow(std::move(bow), std::move(fv));
    }
    // Freed now, not with `data`: the heap gives its memory (when it does
    // not view a file) to the next keyframes' frames instead of fresh pages
    // (a big map's load is mostly first touches of memory).
    r.map_point_ids = {};
  });
  std::vector<KeyFrame*> keyframes;
  keyframes.reserve(data.keyframes.size());
  for (size_t k = 0; k < frames.size(); ++k) {
    keyframes.push_back(map->CreateKeyFrameWithId(data.keyframes[k].id, std::move(*frames[k])));
  }
  frames.clear();
  auto keyframe = [&](uint64_t id) { return map->keyframe_by_id(id); };
  // The keyframe database's inverted file reads only the keyframes' bags of
  // words: built on a thread of its own meanwhile (the same postings).
  std::future<void> database_added =
      std::async(std::launch::async, [database, &keyframes] { database->AddAll(keyframes); });

  // Map points (their allocations on this thread), then their observations
  // (both sides) on two threads: each observation is one keyframe's keypoint
  // slot, of one point (ValidateMapData), and the points' lists have their
  // room already, so the threads share nothing they write. Mostly cache
  // misses on a big map (a random keyframe per observation).
  std::vector<MapPoint*> points;
  points.reserve(data.map_points.size());
  for (MapPointRecord& r : data.map_points) {
    MapPoint* p = map->CreateMapPointWithId(
        r.id, Eigen::Vector3d(r.position[0], r.position[1], r.position[2]),
        keyframe(r.reference_keyframe));
    p->SetNormalAndDistances(Eigen::Vector3d(r.normal[0], r.normal[1], r.normal[2]), r.min_distance,
                             r.max_distance);
    p->SetDescriptor(r.descriptor);
    p->RestoreSaved(r.visible, r.found, r.first_keyframe);
    p->ReserveObservations(r.observations.size());
    points.push_back(p);
  }
  constexpr size_t kPointsPerTask = 4096;
  WorkerPool observers(2);
  observers.ParallelFor((points.size() + kPointsPerTask - 1) / kPointsPerTask, [&](size_t t) {
    for (size_t i = t * kPointsPerTask; i < std::min(points.size(), (t + 1) * kPointsPerTask);
         ++i) {
      for (const auto& [kf_id, index] : data.map_points[i].observations) {
        map->AddObservation(points[i], keyframe(kf_id), index);
      }
    }
  });
  for (MapPointRecord& r : data.map_points) r.observations = {};  // As the links above.
  map->ReserveIds(data.next_keyframe_id, data.next_map_point_id);

  // Graph: covisibility, spanning tree, loop edges. The root (no parent)
  // enters the map first: it is the map's origin.
  for (size_t k = 0; k < keyframes.size(); ++k) {
    const KeyFrameRecord& r = data.keyframes[k];
    KeyFrame* kf = keyframes[k];
    std::vector<KeyFrame::Connection> connections;
    connections.reserve(r.connections.size());
    for (const auto& [id, weight] : r.connections) connections.push_back({keyframe(id), weight});
    kf->SetConnections(std::move(connections));
    if (r.parent != kNoId) kf->SetParent(keyframe(r.parent));
    for (uint64_t id : r.loop_edges) kf->AddLoopEdge(keyframe(id));
    // A keyframe without a parent other than the root is the root of a part
    // of the tree (Map::UpdateConnections): not connected, as it was saved.
    if (r.parent != kNoId) kf->set_connected();
  }
  for (size_t k = 0; k < keyframes.size(); ++k) {
    if (data.keyframes[k].parent == kNoId) map->AddKeyFrame(keyframes[k]);
  }
  if (map->root() != nullptr) map->root()->set_connected();
  for (KeyFrame* kf : keyframes) map->AddKeyFrame(kf);
  database_added.get();
  for (MapPoint* p : points) map->AddMapPoint(p);
}

}  // namespace rrslam
