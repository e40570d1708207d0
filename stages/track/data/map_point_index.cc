#include "stages/track/data/map_point_index.h"

#include <flann/flann.hpp>

#include "stages/track/data/map.h"
#include "stages/track/data/map_point.h"

namespace rrslam {

struct MapPointIndex::Flann {
  flann::Index<flann::Hamming<unsigned char>> index;
};

bool MapPointIndexOptions::Check(std::string* why) const {
  auto fail = [why](const std::string& message) {
    if (why != nullptr) *why = message;
    return false;
  };
  if (tables < 1 || tables > 64) {
    return fail("tables = " + std::to_string(tables) + "; must be in [1, 64]");
  }
  // FLANN's LSH keys are 32-bit.
  if (key_bits < 1 || key_bits > 32) {
    return fail("key_bits = " + std::to_string(key_bits) + "; must be in [1, 32]");
  }
  if (probe_level < 0 || probe_level > 3) {
    return fail("probe_level = " + std::to_string(probe_level) + "; must be in [0, 3]");
  }
  return true;
}

MapPointIndex::MapPointIndex(const MapPointIndexOptions& options) : options_(options) {}
MapPointIndex::~MapPointIndex() = default;
MapPointIndex::MapPointIndex(MapPointIndex&&) noexcept = default;
MapPointIndex& MapPointIndex::operator=(MapPointIndex&&) noexcept = default;

void MapPointIndex::Build(const Map& map) {
  Build(map.MapPoints());
  built_created_ = map.num_created_map_points();
  built_count_ = map.num_map_points();
  built_from_map_ = true;
}

void MapPointIndex::Build(const std::vector<MapPoint*>& points) {
  built_from_map_ = false;
  points_.clear();
  descriptors_.clear();
  flann_.reset();
  for (MapPoint* p : points) {
    if (p == nullptr || p->bad()) continue;
    points_.push_back(p);
    descriptors_.push_back(p->descriptor());
  }
  if (points_.empty()) return;
  const flann::Matrix<unsigned char> rows(descriptors_.front().bytes, descriptors_.size(),
                                          sizeof(OrbDescriptor));
  flann_.reset(new Flann{flann::Index<flann::Hamming<unsigned char>>(
      rows, flann::LshIndexParams(options_.tables, options_.key_bits, options_.probe_level))});
  flann_->index.buildIndex();
}

bool MapPointIndex::IsCurrent(const Map& map) const {
  return built_from_map_ && built_created_ == map.num_created_map_points() &&
         built_count_ == map.num_map_points();
}

std::vector<DescriptorNeighbours> MapPointIndex::Search(
    const std::vector<OrbDescriptor>& queries) const {
  std::vector<DescriptorNeighbours> out(queries.size());
  if (flann_ == nullptr || queries.empty()) return out;
  // A few more than two: culled points and repeats are skipped.
  const size_t k = std::min<size_t>(4, points_.size());
  std::vector<OrbDescriptor> query_rows(queries);
  const flann::Matrix<unsigned char> query(query_rows.front().bytes, query_rows.size(),
                                           sizeof(OrbDescriptor));
  std::vector<std::vector<size_t>> indices;
  std::vector<std::vector<unsigned int>> distances;
  flann_->index.knnSearch(query, indices, distances, k, flann::SearchParams());
  for (size_t q = 0; q < queries.size(); ++q) {
    DescriptorNeighbours& n = out[q];
    for (size_t j = 0; j < indices[q].size(); ++j) {
      MapPoint* p = points_[indices[q][j]];
      // FLANN's LSH may list a point once per table that holds it.
      if (p->bad() || p == n.first) continue;
      const int d = static_cast<int>(distances[q][j]);
      if (n.first == nullptr) {
        n.first = p;
        n.first_distance = d;
      } else {
        n.second = p;
        n.second_distance = d;
        break;
      }
    }
  }
  return out;
}

}  // namespace rrslam
