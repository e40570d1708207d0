#include "stages/mapstore/map_diff.h"

#include <algorithm>
#include <cmath>
#include <flann/flann.hpp>
#include <iterator>
#include <stdexcept>

namespace rrslam {
namespace {

// Points of `query` with no point of `reference` within `radius`.
std::vector<MapDiffPoint> Unmatched(const std::vector<MapPointRecord>& query,
                                    const std::vector<MapPointRecord>& reference, double radius) {
  std::vector<MapDiffPoint> out;
  auto emit = [&](const MapPointRecord& p) {
    MapDiffPoint d;
    d.id = p.id;
    std::copy(p.position, p.position + 3, d.position);
    out.push_back(d);
  };
  if (reference.empty()) {
    out.reserve(query.size());
    for (const MapPointRecord& p : query) emit(p);
    return out;
  }
  if (query.empty()) return out;
  std::vector<double> ref(3 * reference.size()), qry(3 * query.size());
  for (size_t i = 0; i < reference.size(); ++i) {
    std::copy(reference[i].position, reference[i].position + 3, &ref[3 * i]);
  }
  for (size_t i = 0; i < query.size(); ++i) {
    std::copy(query[i].position, query[i].position + 3, &qry[3 * i]);
  }
  // A single exact kd-tree (KDTreeSingleIndex) is exact for k = 1; leaf size
  // 10 is FLANN's default and fast for 3-D points.
  const flann::Matrix<double> ref_matrix(ref.data(), reference.size(), 3);
  flann::Index<flann::L2_Simple<double>> index(ref_matrix, flann::KDTreeSingleIndexParams(10));
  index.buildIndex();
  const flann::Matrix<double> query_matrix(qry.data(), query.size(), 3);
  std::vector<size_t> nearest(query.size());
  std::vector<double> distances(query.size());  // Squared (L2_Simple).
  flann::Matrix<size_t> nearest_matrix(nearest.data(), query.size(), 1);
  flann::Matrix<double> distance_matrix(distances.data(), query.size(), 1);
  flann::SearchParams params;
  params.checks = flann::FLANN_CHECKS_UNLIMITED;
  params.cores = 1;
  index.knnSearch(query_matrix, nearest_matrix, distance_matrix, 1, params);
  const double r2 = radius * radius;
  for (size_t i = 0; i < query.size(); ++i) {
    if (!(distances[i] <= r2)) emit(query[i]);
  }
  return out;
}

std::vector<uint64_t> IdsNotIn(const std::vector<KeyFrameRecord>& x,
                               const std::vector<KeyFrameRecord>& y) {
  std::vector<uint64_t> xs, ys, out;
  xs.reserve(x.size());
  ys.reserve(y.size());
  for (const auto& k : x) xs.push_back(k.id);
  for (const auto& k : y) ys.push_back(k.id);
  std::sort(xs.begin(), xs.end());
  std::sort(ys.begin(), ys.end());
  std::set_difference(xs.begin(), xs.end(), ys.begin(), ys.end(), std::back_inserter(out));
  return out;
}

}  // namespace

MapDiff DiffMaps(const MapData& a, const MapData& b, double radius) {
  if (!(radius > 0) || !std::isfinite(radius)) {
    throw std::invalid_argument("DiffMaps: radius must be positive and finite");
  }
  MapDiff d;
  d.radius = radius;
  d.a_keyframes = a.keyframes.size();
  d.b_keyframes = b.keyframes.size();
  d.a_map_points = a.map_points.size();
  d.b_map_points = b.map_points.size();
  d.added_points = Unmatched(b.map_points, a.map_points, radius);
  d.removed_points = Unmatched(a.map_points, b.map_points, radius);
  auto by_id = [](const MapDiffPoint& p, const MapDiffPoint& q) { return p.id < q.id; };
  std::sort(d.added_points.begin(), d.added_points.end(), by_id);
  std::sort(d.removed_points.begin(), d.removed_points.end(), by_id);
  d.added_keyframes = IdsNotIn(b.keyframes, a.keyframes);
  d.removed_keyframes = IdsNotIn(a.keyframes, b.keyframes);
  return d;
}

}  // namespace rrslam
