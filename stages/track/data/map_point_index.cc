#include "stages/track/data/map_point_index.h"

#include <algorithm>
#include <array>
#include <random>
#include <tuple>

#include "common/worker_pool.h"
#include "stages/track/data/keyframe.h"
#include "stages/track/data/map.h"
#include "stages/track/data/map_point.h"

namespace rrslam {

// One hash table: the key of a descriptor is `bits` of its 256 bits; the
// rows of each key stored contiguously (rows[offset .. offset + count)),
// found through an open-addressing table of the keys (linear probing, at
// most three quarters full). A key's home slot is the top bits of its mix,
// a bijection of the key's bits, so that rows sorted by mix fill the slots
// in order (FillTable: a pass through memory instead of a miss per key).
struct MapPointIndex::Table {
  struct Slot {
    uint32_t key = 0;
    uint32_t offset = 0;
    uint32_t count = 0;  // 0: empty.
  };
  std::vector<int> bits;
  // Key() a byte at a time: the descriptor bytes holding key bits, and for
  // each of them the key bits of its 256 values.
  std::vector<int> key_bytes;
  std::vector<std::array<uint32_t, 256>> key_of_byte;
  uint32_t key_mask = 0;    // The low `bits.size()` bits.
  int home_shift = 0;       // bits.size() - log2(slots.size()).
  std::vector<Slot> slots;  // A power of two, at most 2^bits.size().
  std::vector<uint32_t> rows;
  // One bit per possible key, set for the keys in `slots` (keys of up to
  // kPresenceMaxBits; empty for longer ones): most of a search's probes are
  // of absent keys, answered by this small array (2^20 keys: 128 kB) from
  // the cache instead of by a miss into `slots`.
  std::vector<uint64_t> present;

  // Odd, so that multiplying by it permutes the keys modulo 2^bits; and its
  // inverse modulo 2^32.
  static constexpr uint32_t kMix = 0x9E3779B1u;
  static constexpr uint32_t kUnmix = [] {
    uint32_t inverse = kMix;  // Newton's iteration doubles the correct bits.
    for (int i = 0; i < 5; ++i) inverse *= 2u - kMix * inverse;
    return inverse;
  }();

  // `bits` drawn: the byte tables, the mask; `capacity` slots (a power of
  // two, at most 2^bits) allocated empty.
  void Prepare(size_t capacity) {
    key_mask = bits.size() >= 32 ? ~0u : (1u << bits.size()) - 1;
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
    slots.assign(capacity, {});
    home_shift = static_cast<int>(bits.size());
    for (size_t c = capacity; c > 1; c >>= 1) --home_shift;
  }
  bool MayHave(uint32_t key) const {
    return present.empty() || (present[key >> 6] >> (key & 63) & 1) != 0;
  }
  // Bit b of the key is bit bits[b] of `d`.
  uint32_t Key(const OrbDescriptor& d) const {
    uint32_t key = 0;
    for (size_t j = 0; j < key_bytes.size(); ++j) key |= key_of_byte[j][d.bytes[key_bytes[j]]];
    return key;
  }
  uint32_t Mix(uint32_t key) const { return (key * kMix) & key_mask; }
  uint32_t Unmix(uint32_t mixed) const { return (mixed * kUnmix) & key_mask; }
  size_t Home(uint32_t key) const { return Mix(key) >> home_shift; }
  Slot& Insert(uint32_t key) {
    size_t i = Home(key);
    while (slots[i].count != 0 && slots[i].key != key) i = (i + 1) & (slots.size() - 1);
    slots[i].key = key;
    return slots[i];
  }
  const Slot* Find(uint32_t key) const {
    for (size_t i = Home(key);; i = (i + 1) & (slots.size() - 1)) {
      if (slots[i].count == 0) return nullptr;
      if (slots[i].key == key) return &slots[i];
    }
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
  if (key_bits < 1 || key_bits > 32) {
    return fail("key_bits = " + std::to_string(key_bits) + "; must be in [1, 32]");
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
  // At most three quarters full (rows bound the keys): linear probing's
  // misses, most of a search's probes, stay within a cache line or two.
  // No more slots than keys: a key's home is the top bits of its mix.
  size_t capacity = 2;
  while (3 * capacity < 4 * descriptors_.size()) capacity *= 2;
  capacity = std::min<uint64_t>(capacity, uint64_t{1} << options_.key_bits);
  tables_.resize(static_cast<size_t>(options_.tables));
  for (Table& table : tables_) {
    std::shuffle(all.begin(), all.end(), rng);
    table.bits.assign(all.begin(), all.begin() + options_.key_bits);
    table.Prepare(capacity);
    table.rows.resize(descriptors_.size());
    if (options_.key_bits <= kPresenceMaxBits) {
      table.present.assign(((size_t{1} << options_.key_bits) + 63) / 64, 0);
    }
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
  // Rows sorted by mixed key (then row), each key's rows one bucket, the
  // buckets' slots in increasing order of their homes.
  const std::vector<std::pair<uint32_t, uint32_t>> mixed = SortedByMixedKey(table);
  for (size_t begin = 0, end = 0; begin < mixed.size(); begin = end) {
    for (end = begin; end < mixed.size() && mixed[end].first == mixed[begin].first; ++end) {
      table.rows[end] = mixed[end].second;
    }
    const uint32_t key = table.Unmix(mixed[begin].first);
    Table::Slot& slot = table.Insert(key);
    slot.offset = static_cast<uint32_t>(begin);
    slot.count = static_cast<uint32_t>(end - begin);
    if (!table.present.empty()) table.present[key >> 6] |= uint64_t{1} << (key & 63);
  }
}

std::vector<std::pair<uint32_t, uint32_t>> MapPointIndex::SortedByMixedKey(
    const Table& table) const {
  const size_t n = descriptors_.size();
  std::vector<std::pair<uint32_t, uint32_t>> keyed(n), scratch(n);
  for (size_t r = 0; r < n; ++r) {
    keyed[r] = {table.Mix(table.Key(descriptors_[r])), static_cast<uint32_t>(r)};
  }
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

// On a big map every slot and row a query reads is a cache miss: the reads
// are issued as prefetches in passes (the probes' slots, then their rows,
// compared by KeepTwoNearest), so that the misses overlap instead of
// following one another.
void MapPointIndex::CandidateRows(const OrbDescriptor& query, std::vector<Probe>* probes,
                                  std::vector<uint32_t>* rows) const {
  // The query's bucket in each table, then (probe level 1) those one key
  // bit away.
  const int flips = options_.probe_level > 0 ? options_.key_bits : 0;
  probes->clear();
  for (const Table& table : tables_) {
    const uint32_t key = table.Key(query);
    for (int flip = -1; flip < flips; ++flip) {
      const uint32_t probe = flip < 0 ? key : key ^ (1u << flip);
      if (!table.MayHave(probe)) continue;
      probes->push_back({&table, probe});
      __builtin_prefetch(&table.slots[table.Home(probe)]);
    }
  }
  rows->clear();
  for (const Probe& probe : *probes) {
    const Table::Slot* slot = probe.table->Find(probe.key);
    if (slot == nullptr) continue;
    for (uint32_t i = slot->offset; i < slot->offset + slot->count; ++i) {
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
