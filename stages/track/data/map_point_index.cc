#include "stages/track/data/map_point_index.h"

#include <algorithm>
#include <array>
#include <bit>
#include <random>
#include <tuple>

#include "common/worker_pool.h"
#include "stages/track/data/keyframe.h"
#include "stages/track/data/map.h"
#include "stages/track/data/map_point.h"

namespace rrslam {

// One hash table: the key of a descriptor is `bits` of its 256 bits; the
// rows of each key stored contiguously, in key order (rows[offsets[r] ..
// offsets[r + 1]) for the r-th key present). A key is found by its rank
// among the keys present: one bit per possible key and, with each 64 of
// them, the number set before (16 bytes a block: 256 kB for 2^20 keys).
// Most of a search's probes are of absent keys, answered by the blocks from
// the cache; a present key costs one read of `offsets` (4 bytes a key)
// before its rows.
struct MapPointIndex::Table {
  std::vector<int> bits;
  // Key() a byte at a time: the descriptor bytes holding key bits, and for
  // each of them the key bits of its 256 values.
  std::vector<int> key_bytes;
  std::vector<std::array<uint32_t, 256>> key_of_byte;
  struct Block {
    uint64_t present = 0;  // Bit k: key 64 * block + k has rows.
    uint32_t before = 0;   // Keys present in the blocks before this one.
  };
  std::vector<Block> blocks;      // 2^bits.size() / 64, at least one.
  std::vector<uint32_t> offsets;  // Per key present, then the rows' count.
  std::vector<uint32_t> rows;

  // `bits` drawn: the byte tables; the blocks allocated empty.
  void Prepare() {
    key_bytes.clear();
    key_of_byte.clear();
    for (size_t b = 0; b < bits.size(); ++b) {
      const int byte = bits[b] >> 3;
      auto it = std::find(key_bytes.begin(), key_bytes.end(), byte);
      if (it == key_bytes.end()) {
        key_bytes.push_back(byte);
        key_of_byte.emplace_back().fill(0);
        it = key_bytes.end() - 1;
      }
      std::array<uint32_t, 256>& of = key_of_byte[static_cast<size_t>(it - key_bytes.begin())];
      for (uint32_t v = 0; v < 256; ++v) of[v] |= ((v >> (bits[b] & 7)) & 1u) << b;
    }
    blocks.assign(std::max<size_t>(1, (size_t{1} << bits.size()) / 64), {});
  }
  // Bit b of the key is bit bits[b] of `d`.
  uint32_t Key(const OrbDescriptor& d) const {
    uint32_t key = 0;
    for (size_t j = 0; j < key_bytes.size(); ++j) key |= key_of_byte[j][d.bytes[key_bytes[j]]];
    return key;
  }
  // The rank of `key` among the keys present; -1 when it is absent.
  int64_t Rank(uint32_t key) const {
    const Block& b = blocks[key >> 6];
    const uint64_t bit = uint64_t{1} << (key & 63);
    if ((b.present & bit) == 0) return -1;
    return b.before + std::popcount(b.present & (bit - 1));
  }
};

bool MapPointIndexOptions::Check(std::string* why) const {
  auto fail = [why](const std::string& message) {
    if (why != nullptr) *why = message;
    return false;
  };
  if (tables < 1 || tables > 64) {
    return fail("tables = " + std::to_string(tables) + "; must be in [1, 64]");
  }
  if (key_bits < 1 || key_bits > kMaxKeyBits) {
    return fail("key_bits = " + std::to_string(key_bits) + "; must be in [1, " +
                std::to_string(kMaxKeyBits) + "]");
  }
  if (probe_level < 0 || probe_level > 1) {
    return fail("probe_level = " + std::to_string(probe_level) + "; must be 0 or 1");
  }
  if (min_extra_distance < 1 || min_extra_distance > 256) {
    return fail("min_extra_distance = " + std::to_string(min_extra_distance) +
                "; must be in [1, 256]");
  }
  if (threads < 1 || threads > kMaxThreads) {
    return fail("threads = " + std::to_string(threads) + "; must be in [1, " +
                std::to_string(kMaxThreads) + "]");
  }
  return true;
}

MapPointIndex::MapPointIndex(const MapPointIndexOptions& options) : options_(options) {}
MapPointIndex::~MapPointIndex() = default;
MapPointIndex::MapPointIndex(MapPointIndex&&) noexcept = default;
MapPointIndex& MapPointIndex::operator=(MapPointIndex&&) noexcept = default;

void MapPointIndex::Build(const Map& map) {
  Snapshot(map);
  BuildTables();
}

void MapPointIndex::Snapshot(const Map& map) {
  TakePoints(map.MapPoints());
  built_created_ = map.num_created_map_points();
  built_count_ = map.num_map_points();
  built_from_map_ = true;
  AllocateTables();
}

void MapPointIndex::Build(const std::vector<MapPoint*>& points) {
  TakePoints(points);
  AllocateTables();
  BuildTables();
}

void MapPointIndex::TakePoints(const std::vector<MapPoint*>& points) {
  built_from_map_ = false;
  row_points_.clear();
  descriptors_.clear();
  tables_.clear();
  for (MapPoint* p : points) {
    if (p == nullptr || p->bad()) continue;
    row_points_.push_back(p);
    descriptors_.push_back(p->descriptor());
  }
  points_ = row_points_.size();
  TakeObservationDescriptors();
}

namespace {

// The descriptors of a point's observations, farthest first: each the one
// farthest from its representative and those taken before it (ties: the
// earlier observation), none nearer than `min_distance` bits to those.
// Scratch kept between points.
class FarthestFirst {
 public:
  explicit FarthestFirst(int min_distance) : min_distance_(min_distance) {}
  // Appends `point`'s to `out`.
  void Take(const MapPoint& point, std::vector<OrbDescriptor>* out) {
    candidates_.clear();
    words_.clear();
    nearest_taken_.clear();
    const DescriptorWords representative = ToWords(point.descriptor());
    for (const MapPoint::Observation& o : point.observations()) {
      candidates_.push_back(o.keyframe->features().descriptors[o.index]);
      words_.push_back(ToWords(candidates_.back()));
      nearest_taken_.push_back(HammingDistance(representative, words_.back()));
    }
    while (true) {
      const auto far = std::max_element(nearest_taken_.begin(), nearest_taken_.end());
      if (far == nearest_taken_.end() || *far < min_distance_) break;
      const size_t taken = static_cast<size_t>(far - nearest_taken_.begin());
      out->push_back(candidates_[taken]);
      for (size_t i = 0; i < words_.size(); ++i) {
        nearest_taken_[i] = std::min(nearest_taken_[i], HammingDistance(words_[taken], words_[i]));
      }
    }
  }

 private:
  int min_distance_;
  std::vector<OrbDescriptor> candidates_;
  std::vector<DescriptorWords> words_;  // Of candidates_.
  std::vector<int> nearest_taken_;
};

}  // namespace

void MapPointIndex::TakeObservationDescriptors() {
  if (options_.max_rows <= points_) return;
  // Each point's candidates, flat: point r's in extra[begin[r], begin[r + 1]).
  size_t observations = 0;
  for (size_t r = 0; r < points_; ++r) observations += row_points_[r]->observations().size();
  std::vector<OrbDescriptor> extra;
  extra.reserve(observations);
  std::vector<size_t> begin(points_ + 1, 0);
  FarthestFirst farthest(options_.min_extra_distance);
  size_t rounds = 0;
  for (size_t r = 0; r < points_; ++r) {
    farthest.Take(*row_points_[r], &extra);
    begin[r + 1] = extra.size();
    rounds = std::max(rounds, begin[r + 1] - begin[r]);
  }
  // Round k: every point's (k+1)-th, in point order, while the budget lasts.
  const size_t rows = std::min(options_.max_rows, points_ + extra.size());
  row_points_.reserve(rows);
  descriptors_.reserve(rows);
  for (size_t k = 0; k < rounds; ++k) {
    for (size_t r = 0; r < points_ && row_points_.size() < rows; ++r) {
      if (begin[r] + k >= begin[r + 1]) continue;
      row_points_.push_back(row_points_[r]);
      descriptors_.push_back(extra[begin[r] + k]);
    }
  }
}

void MapPointIndex::AllocateTables() {
  tables_.clear();
  // The same bits for every build: searches are reproducible.
  std::mt19937_64 rng(options_.seed);
  std::vector<int> all(8 * sizeof(OrbDescriptor));
  for (size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  tables_.resize(static_cast<size_t>(options_.tables));
  for (Table& table : tables_) {
    std::shuffle(all.begin(), all.end(), rng);
    table.bits.assign(all.begin(), all.begin() + options_.key_bits);
    table.Prepare();
    table.rows.resize(descriptors_.size());
  }
}

void MapPointIndex::BuildTables() {
  if (options_.threads > 1 && !pool_) pool_ = std::make_unique<WorkerPool>(options_.threads);
  // Tables are independent once their bits are drawn: on the pool's threads.
  const auto fill = [this](size_t t) { FillTable(&tables_[t]); };
  if (pool_) {
    pool_->ParallelFor(tables_.size(), fill);
  } else {
    for (size_t t = 0; t < tables_.size(); ++t) fill(t);
  }
}

void MapPointIndex::FillTable(Table* table_out) const {
  Table& table = *table_out;
  // Rows sorted by key (then row), each key's rows one bucket.
  const std::vector<std::pair<uint32_t, uint32_t>> keyed = SortedByKey(table);
  table.offsets.clear();
  for (size_t begin = 0, end = 0; begin < keyed.size(); begin = end) {
    for (end = begin; end < keyed.size() && keyed[end].first == keyed[begin].first; ++end) {
      table.rows[end] = keyed[end].second;
    }
    const uint32_t key = keyed[begin].first;
    table.blocks[key >> 6].present |= uint64_t{1} << (key & 63);
    table.offsets.push_back(static_cast<uint32_t>(begin));
  }
  table.offsets.push_back(static_cast<uint32_t>(keyed.size()));
  uint32_t before = 0;
  for (Table::Block& block : table.blocks) {
    block.before = before;
    before += static_cast<uint32_t>(std::popcount(block.present));
  }
}

std::vector<std::pair<uint32_t, uint32_t>> MapPointIndex::SortedByKey(const Table& table) const {
  const size_t n = descriptors_.size();
  std::vector<std::pair<uint32_t, uint32_t>> keyed(n), scratch(n);
  for (size_t r = 0; r < n; ++r) keyed[r] = {table.Key(descriptors_[r]), static_cast<uint32_t>(r)};
  // A least-significant-digit radix sort, kRadixBits of the key a pass: as
  // stable as counting, so rows stay in increasing order within a key (the
  // pairs' order), in time linear in the rows whatever their number (a
  // comparison sort costs n log n, one counting pass 2^key_bits counters).
  constexpr int kRadixBits = 11;
  constexpr uint32_t kDigits = 1u << kRadixBits;
  for (int shift = 0; shift < options_.key_bits; shift += kRadixBits) {
    std::vector<uint32_t> start(kDigits + 1, 0);
    for (const auto& [key, row] : keyed) ++start[((key >> shift) & (kDigits - 1)) + 1];
    for (size_t d = 1; d <= kDigits; ++d) start[d] += start[d - 1];
    for (const auto& pair : keyed) scratch[start[(pair.first >> shift) & (kDigits - 1)]++] = pair;
    keyed.swap(scratch);
  }
  return keyed;
}

bool MapPointIndex::IsCurrent(const Map& map) const {
  return built_from_map_ && built_created_ == map.num_created_map_points() &&
         built_count_ == map.num_map_points();
}

std::vector<DescriptorNeighbours> MapPointIndex::Search(
    const std::vector<OrbDescriptor>& queries) const {
  std::vector<DescriptorNeighbours> out(queries.size());
  if (row_points_.empty()) return out;
  // Queries are independent: chunks of them, on the pool's threads.
  constexpr size_t kChunk = 64;
  const size_t chunks = (queries.size() + kChunk - 1) / kChunk;
  auto chunk = [&](size_t c) {
    SearchRange(queries, c * kChunk, std::min(queries.size(), (c + 1) * kChunk), &out);
  };
  if (pool_) {
    pool_->ParallelFor(chunks, chunk);
  } else {
    for (size_t c = 0; c < chunks; ++c) chunk(c);
  }
  return out;
}

void MapPointIndex::SearchRange(const std::vector<OrbDescriptor>& queries, size_t begin, size_t end,
                                std::vector<DescriptorNeighbours>* out) const {
  std::vector<Probe> probes;
  std::vector<uint32_t> rows;
  for (size_t q = begin; q < end; ++q) {
    CandidateRows(queries[q], &probes, &rows);
    KeepTwoNearest(ToWords(queries[q]), rows, &(*out)[q]);
  }
}

// On a big map every offset and row a query reads is a cache miss: the reads
// are issued as prefetches in passes (the probes' offsets, then their rows,
// compared by KeepTwoNearest), so that the misses overlap instead of
// following one another.
void MapPointIndex::CandidateRows(const OrbDescriptor& query, std::vector<Probe>* probes,
                                  std::vector<uint32_t>* rows) const {
  // The query's bucket in each table, then (probe level 1) those one key
  // bit away.
  const int flips = options_.probe_level > 0 ? options_.key_bits : 0;
  // Every probed key first, its block prefetched (12 tables of 21 probes
  // over 3 MB of blocks, beyond the L2 cache), then their ranks.
  probes->clear();
  for (const Table& table : tables_) {
    const uint32_t key = table.Key(query);
    for (int flip = -1; flip < flips; ++flip) {
      const uint32_t probed = flip < 0 ? key : key ^ (1u << flip);
      __builtin_prefetch(&table.blocks[probed >> 6]);
      probes->push_back({&table, probed});
    }
  }
  size_t kept = 0;
  for (const Probe& probe : *probes) {
    const int64_t rank = probe.table->Rank(probe.rank);
    if (rank < 0) continue;
    (*probes)[kept++] = {probe.table, static_cast<uint32_t>(rank)};
    __builtin_prefetch(&probe.table->offsets[static_cast<size_t>(rank)]);
  }
  probes->resize(kept);
  rows->clear();
  for (const Probe& probe : *probes) {
    const uint32_t* offset = &probe.table->offsets[probe.rank];
    for (uint32_t i = offset[0]; i < offset[1]; ++i) {
      const uint32_t row = probe.table->rows[i];
      rows->push_back(row);
      __builtin_prefetch(&descriptors_[row]);
    }
  }
}

// The rows are compared in the order a plain walk visits them (table, probe,
// row), so ties resolve alike. A row found again (in another table) is
// compared again, from the cache: cheaper than a table of rows seen, which
// costs a miss of its own per row. A point's other rows (its observations'
// descriptors) bring it nearer, never make it both first and second.
void MapPointIndex::KeepTwoNearest(const DescriptorWords& query, const std::vector<uint32_t>& rows,
                                   DescriptorNeighbours* n) const {
  constexpr uint32_t kNoRow = UINT32_MAX;
  // Rows of the two nearest so far (the rows that gave their distances).
  uint32_t first_row = kNoRow, second_row = kNoRow;
  for (const uint32_t row : rows) {
    if (row == first_row || row == second_row) continue;
    const int d = HammingDistance(query, ToWords(descriptors_[row]));
    const bool first = d < n->first_distance || (d == n->first_distance && n->first == nullptr);
    if (!first && !(d < n->second_distance || (d == n->second_distance && n->second == nullptr))) {
      continue;
    }
    // Only now the point itself (a cache miss per row on a big map).
    MapPoint* p = row_points_[row];
    if (p->bad()) continue;
    if (p == n->first) {
      if (d < n->first_distance) std::tie(first_row, n->first_distance) = std::tie(row, d);
    } else if (p == n->second) {
      if (d < n->second_distance) std::tie(second_row, n->second_distance) = std::tie(row, d);
      if (n->second_distance < n->first_distance) {
        std::swap(first_row, second_row);
        std::swap(n->first, n->second);
        std::swap(n->first_distance, n->second_distance);
      }
    } else if (first) {
      std::tie(second_row, n->second, n->second_distance) =
          std::tie(first_row, n->first, n->first_distance);
      std::tie(first_row, n->first, n->first_distance) = std::make_tuple(row, p, d);
    } else {
      std::tie(second_row, n->second, n->second_distance) = std::make_tuple(row, p, d);
    }
  }
}

}  // namespace rrslam
