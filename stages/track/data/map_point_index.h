// Map points by descriptor: an index over the representative ORB descriptor
// of every map point, for relocalization's direct 2D-3D matching
// (module/relocalizer.h). Multi-probe LSH for binary descriptors (Hamming
// distance; Lv et al., VLDB 2007), the scheme of FLANN's LshIndex: `tables`
// hash tables, each keyed by `key_bits` of the 256 bits, and the buckets
// within `probe_level` bits of the query's key searched too; the candidates
// are compared exactly. Written here rather than taken from FLANN because
// FLANN 1.9's LshTable draws its key bits from std::random_device: every
// build differed, and so did the matches and relocalizations of a batch run.
// Here the bits come from `seed`.
//
// Each point is indexed by its representative descriptor (the one
// ORB-SLAM2 matches by) and, within a budget of rows, by the descriptors of
// the keyframes observing it: ORB descriptors change with the viewpoint,
// and a frame seen from elsewhere than the median view is often far from the
// representative and near one keyframe's descriptor (Active Search indexes
// every observation's descriptor for the same reason). See `max_rows`.
//
// The index is a snapshot: Build() takes the map's good points, and
// IsCurrent() tells whether the map has created or removed points since
// (points culled since are skipped at search time; a descriptor that changed
// keeps its old value until the next build). The relocalizer rebuilds it at
// the first attempt after a change; a loaded map in localization-only mode
// builds it once.
//
// Thread-safety: none of its own; build and search under Map::mutex().
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "common/orb_descriptor.h"

namespace rrslam {

class Map;
class MapPoint;
class WorkerPool;

struct MapPointIndexOptions {
  static constexpr int kMaxKeyBits = 24;
  // FLANN's LshIndexParams() defaults (OpenCV's FLANN users pick the same),
  // but one probe level where FLANN has 2: on the kitchen map (5.6k points,
  // 1000 keypoints a frame) level 2 found 1.9x the matches in 4x the time
  // (48-62 ms a frame against 12-14 ms), and level 1 relocalized the same
  // frames (docs/track.md, "Direct relocalization").
  int tables = 12;
  int key_bits = 20;    // At most kMaxKeyBits (a table holds a bit per key).
  int probe_level = 1;  // 0 or 1.
  uint64_t seed = 1;    // Of the key bits.
  // Threads a search runs on, the caller's included (the same answers for
  // any number). A search is bound by memory latency, not by arithmetic: on
  // the 10k-keyframe map (557 000 points) one frame's took 23 ms on one
  // thread; a relocalizing tracker has nothing else to do meanwhile.
  int threads = 2;
  // The most rows (indexed descriptors), unless the points alone are more:
  // every good point's representative descriptor first; then, while the
  // rows stay within `max_rows`, a round at a time, each point's next observation
  // descriptor (the one farthest in Hamming distance from those it has
  // already, at least `min_extra_distance` bits). A map whose points reach
  // the budget is indexed by representatives alone. 2^19 rows keep the index
  // within the size and build time of a 10k-keyframe map's representatives
  // (582 660 points: 0.07-0.11 s beside tracking, ~80 MB): on the kitchen's
  // map (5 395 points, 36 675 descriptors, built in 8-10 ms) cold starts from later
  // frames relocalized at once 45 of 50 times against 38 with
  // representatives alone (docs/track.md, "Direct relocalization").
  // 0: representatives alone.
  size_t max_rows = size_t{1} << 19;
  int min_extra_distance = 1;  // Bits; 1: any different descriptor.
  // False, with the reason in `why`, when a field is out of range.
  bool Check(std::string* why) const;
};

// The two nearest indexed points of one query descriptor.
struct DescriptorNeighbours {
  MapPoint* first = nullptr;   // nullptr: nothing found.
  MapPoint* second = nullptr;  // nullptr: only one found.
  int first_distance = 256;    // Hamming distances, bits.
  int second_distance = 256;
};

class MapPointIndex {
 public:
  explicit MapPointIndex(const MapPointIndexOptions& options = {});
  ~MapPointIndex();
  MapPointIndex(MapPointIndex&&) noexcept;
  MapPointIndex& operator=(MapPointIndex&&) noexcept;

  // Indexes every good point of `map` (its descriptor as it is now):
  // Snapshot(map), then BuildTables().
  void Build(const Map& map);
  // The two parts of Build(map): the points and their descriptors taken from
  // the map, and the tables' memory allocated (under Map::mutex(); tens of
  // ms on a big map, on the caller's heap), then the hash tables filled from
  // those descriptors alone (no map access: may run on another thread, with
  // no search meanwhile). Searches are valid after both.
  void Snapshot(const Map& map);
  void BuildTables();
  // Indexes `points` (tests; bad points are skipped).
  void Build(const std::vector<MapPoint*>& points);
  // Whether `map` has the points it had at the last Build(map).
  bool IsCurrent(const Map& map) const;
  // Indexed points, and indexed descriptors (rows: size() or more).
  size_t size() const { return points_; }
  size_t rows() const { return row_points_.size(); }

  // The two nearest indexed points of each of `queries` (approximate: LSH
  // may miss the true nearest), two different points, each at the distance
  // of its nearest indexed descriptor. Points culled since the build are
  // skipped.
  std::vector<DescriptorNeighbours> Search(const std::vector<OrbDescriptor>& queries) const;

 private:
  struct Table;
  // A bucket to read: that of the `rank`-th key present in `table` (while
  // CandidateRows gathers them, the key probed).
  struct Probe {
    const Table* table;
    uint32_t rank;
  };
  // The good ones of `points` and their descriptors as the rows (tables
  // cleared), then their observations' descriptors within the budget.
  void TakePoints(const std::vector<MapPoint*>& points);
  // Rows for the observations' descriptors of the first `points_` rows'
  // points, a round at a time, up to options_.max_rows rows in all.
  void TakeObservationDescriptors();
  // Search() of queries [begin, end) into out[begin, end).
  void SearchRange(const std::vector<OrbDescriptor>& queries, size_t begin, size_t end,
                   std::vector<DescriptorNeighbours>* out) const;
  // The rows in the buckets `query` probes (`probes`: scratch), in table,
  // probe and bucket order; a row in several tables appears once per table.
  void CandidateRows(const OrbDescriptor& query, std::vector<Probe>* probes,
                     std::vector<uint32_t>* rows) const;
  // The two nearest good points among `rows` into `n` (initially empty).
  void KeepTwoNearest(const DescriptorWords& query, const std::vector<uint32_t>& rows,
                      DescriptorNeighbours* n) const;
  // Each table's key bits drawn, its key bitmap (empty) and rows allocated.
  void AllocateTables();
  // The bitmap, offsets and rows of `table` (allocated, its bits drawn) from
  // descriptors_.
  void FillTable(Table* table) const;
  // (key, row) of every row in `table`, sorted.
  std::vector<std::pair<uint32_t, uint32_t>> SortedByKey(const Table& table) const;
  MapPointIndexOptions options_;
  size_t points_ = 0;                       // Rows [0, points_): one per point.
  std::vector<MapPoint*> row_points_;       // The point of each row.
  std::vector<OrbDescriptor> descriptors_;  // Parallel to row_points_.
  std::vector<Table> tables_;
  std::unique_ptr<WorkerPool> pool_;  // With options_.threads > 1, from the first build.
  // The map's state at the last build: points created and points in the map.
  size_t built_created_ = 0;
  size_t built_count_ = 0;
  bool built_from_map_ = false;
};

}  // namespace rrslam
