// Test helpers: seeded synthetic maps that pass ValidateMapData, and edits
// that keep them consistent (used by the mapstore tests and the timing test).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "stages/mapstore/map_data.h"

namespace rrslam::testing {

struct TestMapOptions {
  int keyframes = 12;
  int keypoints = 50;  // Per keyframe.
  int map_points = 100;
  int min_observations = 2;  // Per map point (distinct keyframes).
  int max_observations = 4;
  int bow_words = 20;  // Per keyframe.
};

// A consistent random map: ids with gaps, random unit quaternions, points
// observed by distinct keyframes, covisibility from shared points, a spanning
// tree (parent of keyframe i is keyframe (i - 1) / 2), one loop edge between
// the second and the last keyframe.
inline MapData MakeTestMap(uint32_t seed, const TestMapOptions& o = {}) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::uniform_real_distribution<float> pixel(0.0f, 640.0f);
  MapData map;
  map.camera = {525, 525, 319.5, 239.5, 0.1,  -0.2, 0.001, 0.002, 0.05, 640,
                480, 40,  40,    5000,  1000, 1.2,  8,     20,    7};
  map.vocabulary = {0x0123456789abcdefull, 10, 6, 0, 0, 1000000, "voc.rrv"};
  map.bow_levels_up = 4;
  map.metadata = R"({"producer":"mapstore test","seed":)" + std::to_string(seed) + "}";
  const int n_kf = o.keyframes;
  map.keyframes.resize(n_kf);
  std::vector<std::vector<uint32_t>> free_slots(n_kf);
  for (int i = 0; i < n_kf; ++i) {
    KeyFrameRecord& kf = map.keyframes[i];
    kf.id = 3 * i + 1;
    kf.frame_id = 10 * i;
    kf.timestamp = 1000.0 + 0.5 * i;
    double q[4] = {unit(rng), unit(rng), unit(rng), unit(rng)};
    const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    kf.T_cam_world = {q[0] / norm, q[1] / norm, q[2] / norm, q[3] / norm,
                      unit(rng),   unit(rng),   unit(rng)};
    kf.keypoints.resize(o.keypoints);
    kf.descriptors.resize(o.keypoints);
    kf.map_point_ids.assign(o.keypoints, kNoId);
    for (int k = 0; k < o.keypoints; ++k) {
      Keypoint& p = kf.keypoints[k];
      p.pixel.x() = pixel(rng);
      p.pixel.y() = pixel(rng) * 0.75f;
      p.undistorted = {p.pixel.x() + 0.5f, p.pixel.y() - 0.25f};
      p.angle_deg = pixel(rng) * 0.5f;
      p.response = pixel(rng) * 0.01f;
      p.depth = k % 5 == 0 ? 0.0f : 0.5f + pixel(rng) * 0.01f;
      p.octave = static_cast<uint8_t>(rng() % 8);
      for (auto& b : kf.descriptors[k].bytes) b = static_cast<uint8_t>(rng());
    }
    free_slots[i].resize(o.keypoints);
    for (int k = 0; k < o.keypoints; ++k) free_slots[i][k] = k;
    std::shuffle(free_slots[i].begin(), free_slots[i].end(), rng);
    // Bag of words: distinct sorted words.
    std::vector<uint32_t> words;
    while (static_cast<int>(words.size()) < o.bow_words) {
      words.push_back(static_cast<uint32_t>(rng() % map.vocabulary.num_words));
      std::sort(words.begin(), words.end());
      words.erase(std::unique(words.begin(), words.end()), words.end());
    }
    for (uint32_t w : words) kf.bow.push_back({w, 0.01 + 0.001 * (rng() % 100)});
    // Feature vector: keypoints grouped by index modulo 7 under nodes 100..106.
    for (uint32_t g = 0; g < 7; ++g) {
      std::vector<uint32_t> indices;
      for (uint32_t k = g; k < static_cast<uint32_t>(o.keypoints); k += 7) indices.push_back(k);
      if (!indices.empty()) kf.feature_vector.push_back({100 + g, indices});
    }
    kf.parent = i == 0 ? kNoId : map.keyframes[(i - 1) / 2].id;
  }
  // Map points, each observed by distinct keyframes at free keypoints.
  std::vector<int> shared(n_kf * n_kf, 0);
  map.map_points.reserve(o.map_points);
  for (int j = 0; j < o.map_points; ++j) {
    MapPointRecord mp;
    mp.id = 5 * j + 2;
    for (int k = 0; k < 3; ++k) mp.position[k] = 5 * unit(rng);
    mp.normal[0] = 1;
    mp.min_distance = 0.5;
    mp.max_distance = 8;
    for (auto& b : mp.descriptor.bytes) b = static_cast<uint8_t>(rng());
    mp.visible = 10 + static_cast<int32_t>(rng() % 10);
    mp.found = 5;
    const int want = o.min_observations +
                     static_cast<int>(rng() % (o.max_observations - o.min_observations + 1));
    std::vector<int> kfs;
    for (int tries = 0; tries < 10 * want && static_cast<int>(kfs.size()) < want; ++tries) {
      const int i = static_cast<int>(rng() % n_kf);
      if (free_slots[i].empty() || std::find(kfs.begin(), kfs.end(), i) != kfs.end()) continue;
      kfs.push_back(i);
    }
    if (kfs.empty()) continue;  // Every keypoint is taken.
    std::sort(kfs.begin(), kfs.end());
    for (int i : kfs) {
      const uint32_t slot = free_slots[i].back();
      free_slots[i].pop_back();
      map.keyframes[i].map_point_ids[slot] = mp.id;
      mp.observations.push_back({map.keyframes[i].id, slot});
    }
    for (int a : kfs)
      for (int b : kfs)
        if (a != b) ++shared[a * n_kf + b];
    mp.reference_keyframe = mp.observations[kfs.size() / 2].first;
    mp.first_keyframe = mp.observations.front().first;
    map.map_points.push_back(std::move(mp));
  }
  for (int a = 0; a < n_kf; ++a) {
    for (int b = 0; b < n_kf; ++b) {
      if (shared[a * n_kf + b] > 0) {
        map.keyframes[a].connections.push_back({map.keyframes[b].id, shared[a * n_kf + b]});
      }
    }
  }
  if (n_kf >= 3) {
    map.keyframes[1].loop_edges.push_back(map.keyframes[n_kf - 1].id);
    map.keyframes[n_kf - 1].loop_edges.push_back(map.keyframes[1].id);
  }
  map.next_keyframe_id = n_kf == 0 ? 0 : map.keyframes.back().id + 3;
  map.next_map_point_id = map.map_points.empty() ? 0 : map.map_points.back().id + 1;
  return map;
}

// Removes map point `id` and its references from the keyframes.
inline void RemoveTestPoint(MapData* map, uint64_t id) {
  for (KeyFrameRecord& kf : map->keyframes) {
    for (uint64_t& m : kf.map_point_ids) {
      if (m == id) m = kNoId;
    }
  }
  std::erase_if(map->map_points, [&](const MapPointRecord& p) { return p.id == id; });
}

// Adds a map point at `position`, observed by the first keyframe with a free
// keypoint; returns its id.
inline uint64_t AddTestPoint(MapData* map, const double position[3]) {
  for (KeyFrameRecord& kf : map->keyframes) {
    for (uint32_t k = 0; k < kf.map_point_ids.size(); ++k) {
      if (kf.map_point_ids[k] != kNoId) continue;
      MapPointRecord mp;
      mp.id = map->next_map_point_id++;
      std::copy(position, position + 3, mp.position);
      mp.reference_keyframe = mp.first_keyframe = kf.id;
      mp.observations.push_back({kf.id, k});
      kf.map_point_ids[k] = mp.id;
      map->map_points.push_back(std::move(mp));
      return map->map_points.back().id;
    }
  }
  return kNoId;
}

// Adds a keyframe (a copy of the last one without map points or edges) as a
// child of the root; returns its id.
inline uint64_t AddTestKeyframe(MapData* map) {
  KeyFrameRecord kf = map->keyframes.back();
  kf.id = map->next_keyframe_id++;
  kf.map_point_ids.assign(kf.keypoints.size(), kNoId);
  kf.connections.clear();
  kf.loop_edges.clear();
  kf.parent = map->keyframes.front().id;
  map->keyframes.push_back(std::move(kf));
  return map->keyframes.back().id;
}

}  // namespace rrslam::testing
