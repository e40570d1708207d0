#include "stages/cluster/hkmeans.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cstring>
#include <deque>
#include <functional>
#include <limits>
#include <numeric>
#include <thread>

#include "common/errors.h"
#include "common/worker_pool.h"

namespace rrslam {
namespace {

constexpr int kMaxK = 31;

// ---------------------------------------------------------------------------
// Random numbers: SplitMix64 (Steele, Lea, Flood 2014), and Lemire's unbiased
// bounded integers, so the tree depends on nothing but the seed (no
// implementation-defined std:: distributions).

uint64_t SplitMix64(uint64_t* state) {
  uint64_t z = (*state += 0x9e3779b97f4a7c15ULL);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

class Rng {
 public:
  explicit Rng(uint64_t seed) : state_(seed) {}
  uint64_t Next() { return SplitMix64(&state_); }
  // Uniform in [0, n), n > 0.
  uint64_t Below(uint64_t n) {
    unsigned __int128 m = static_cast<unsigned __int128>(Next()) * n;
    uint64_t low = static_cast<uint64_t>(m);
    if (low < n) {
      const uint64_t threshold = (0 - n) % n;
      while (low < threshold) {
        m = static_cast<unsigned __int128>(Next()) * n;
        low = static_cast<uint64_t>(m);
      }
    }
    return static_cast<uint64_t>(m >> 64);
  }

 private:
  uint64_t state_;
};

// The random stream of a node is a function of its parent's and of its index
// among its siblings: of (seed, path from the root), never of scheduling.
uint64_t ChildSeed(uint64_t node_seed, uint32_t child) {
  uint64_t state = node_seed ^ (0xd1b54a32d192ed03ULL * (uint64_t{child} + 1));
  return SplitMix64(&state);
}

uint64_t RootSeed(uint64_t seed) {
  uint64_t state = seed;
  return SplitMix64(&state);
}

// ---------------------------------------------------------------------------
// Nearest centre by Hamming distance (common/orb_descriptor.h).

inline int Nearest(const DescriptorWords* centres, int k, const DescriptorWords& q) {
  int best = 0;
  int best_d = HammingDistance(q, centres[0]);
  for (int c = 1; c < k; ++c) {
    const int d = HammingDistance(q, centres[c]);
    if (d < best_d) {
      best_d = d;
      best = c;
    }
  }
  return best;
}

// ---------------------------------------------------------------------------
// Per-bit counting for majority centres, the hot spot of binary k-means.
// Each descriptor byte is widened by table lookup to eight one-byte lanes
// (lane j = bit j) and added to a 64-bit accumulator: 32 additions count all
// 256 bits of a descriptor. Lanes are flushed to 32-bit counts before they can
// overflow (every 255 additions).

struct LaneTable {
  uint64_t lanes[256];
  constexpr LaneTable() : lanes() {
    for (int v = 0; v < 256; ++v) {
      uint64_t x = 0;
      for (int j = 0; j < 8; ++j) x |= uint64_t((v >> j) & 1) << (8 * j);
      lanes[v] = x;
    }
  }
};
constexpr LaneTable kLaneTable;

class BitCounter {
 public:
  BitCounter() {}  // Members are set by Reset().

  void Reset(int k) {
    k_ = k;
    std::memset(acc_, 0, sizeof(acc_[0]) * k);
    std::memset(pending_, 0, sizeof(pending_[0]) * k);
    std::memset(flushed_, 0, sizeof(flushed_[0]) * k);
    std::memset(sizes_, 0, sizeof(sizes_[0]) * k);
  }

  void Add(int c, const OrbDescriptor& d) {
    uint64_t* a = acc_[c];
    for (int b = 0; b < 32; ++b) a[b] += kLaneTable.lanes[d.bytes[b]];
    ++sizes_[c];
    if (++pending_[c] == 255) Flush(c);
  }

  uint64_t size(int c) const { return sizes_[c]; }

  // Adds (sign +1) or subtracts (sign -1) the per-bit counts of cluster c
  // to / from out[256] (modulo 2^64, so partial sums may wrap).
  void AccumulateCounts(int c, uint64_t* out, int sign = 1) const {
    const uint64_t s = static_cast<uint64_t>(static_cast<int64_t>(sign));
    if (flushed_[c]) {
      for (int i = 0; i < 256; ++i) out[i] += s * counts_[c][i];
    }
    for (int b = 0; b < 32; ++b) {
      const uint64_t a = acc_[c][b];
      for (int j = 0; j < 8; ++j) out[8 * b + j] += s * ((a >> (8 * j)) & 0xff);
    }
  }

 private:
  void Flush(int c) {
    if (!flushed_[c]) {
      std::memset(counts_[c], 0, sizeof(counts_[c]));
      flushed_[c] = 1;
    }
    for (int b = 0; b < 32; ++b) {
      const uint64_t a = acc_[c][b];
      for (int j = 0; j < 8; ++j)
        counts_[c][8 * b + j] += static_cast<uint32_t>((a >> (8 * j)) & 0xff);
      acc_[c][b] = 0;
    }
    pending_[c] = 0;
  }

  int k_ = 0;
  uint64_t acc_[kMaxK][32];
  uint32_t counts_[kMaxK][256];
  uint32_t pending_[kMaxK];
  uint8_t flushed_[kMaxK];
  uint64_t sizes_[kMaxK];
};

OrbDescriptor MajorityFromCounts(const uint64_t* counts, uint64_t size) {
  OrbDescriptor centre;
  for (int i = 0; i < 256; ++i) {
    if (2 * counts[i] >= size) centre.bytes[i >> 3] |= uint8_t(1u << (i & 7));
  }
  return centre;
}

// ---------------------------------------------------------------------------
// One node's k-means on data[0, n), n > k. Work is cut into chunks of fixed
// size; every reduction over chunks is an integer sum, so the result is the
// same whatever the number of chunks or threads.

struct SplitWorkspace {
  OrbDescriptor* scratch;  // n descriptors, for the final reordering.
  uint8_t* assign;         // n cluster indices.
  uint32_t* min_dist2;     // n squared distances, for seeding.
  std::vector<BitCounter>* counters;
};

struct SplitResult {
  std::vector<OrbDescriptor> centres;
  std::vector<uint64_t> sizes;  // data[0, n) is grouped by cluster in this order.
  int iterations = 0;
  bool converged = false;
};

constexpr size_t kChunk = 8192;

// How a node's descriptors [0, n) are cut into chunks, and who runs them:
// all threads of `pool`, or the calling thread alone (pool == nullptr, one
// chunk). Results never depend on the cut: reductions are integer sums.
struct Chunking {
  Chunking(size_t n, WorkerPool* pool)
      : n(n),
        pool(pool),
        chunks(pool != nullptr ? (n + kChunk - 1) / kChunk : 1),
        chunk_size(pool != nullptr ? kChunk : n) {}
  std::pair<size_t, size_t> Range(size_t ch) const {
    const size_t b = ch * chunk_size;
    return {b, std::min(n, b + chunk_size)};
  }
  void Run(const std::function<void(size_t)>& fn) const {
    if (pool != nullptr) {
      pool->ParallelFor(chunks, fn);
    } else {
      for (size_t ch = 0; ch < chunks; ++ch) fn(ch);
    }
  }
  size_t n;
  WorkerPool* pool;
  size_t chunks;
  size_t chunk_size;
};

// k-means++ seeding with D^2 sampling (Arthur and Vassilvitskii 2007):
// indices of up to k seeds. `min_dist2` is scratch for n values.
std::vector<size_t> SeedIndices(const OrbDescriptor* data, int k, uint64_t seed,
                                const Chunking& chunking, uint32_t* min_dist2) {
  Rng rng(seed);
  std::vector<size_t> seeds{static_cast<size_t>(rng.Below(chunking.n))};
  std::vector<uint64_t> chunk_sum(chunking.chunks, 0);
  // Updates min_dist2 with the newest seed and sums it per chunk.
  auto update = [&](bool first) {
    const DescriptorWords last = ToWords(data[seeds.back()]);
    chunking.Run([&](size_t ch) {
      const auto [b, e] = chunking.Range(ch);
      uint64_t sum = 0;
      for (size_t i = b; i < e; ++i) {
        uint32_t m = first ? std::numeric_limits<uint32_t>::max() : min_dist2[i];
        if (m > 0) {
          const uint32_t d = static_cast<uint32_t>(HammingDistance(ToWords(data[i]), last));
          if (d * d < m) m = min_dist2[i] = d * d;
        }
        sum += m;
      }
      chunk_sum[ch] = sum;
    });
  };
  update(true);
  while (static_cast<int>(seeds.size()) < k) {
    const uint64_t total = std::accumulate(chunk_sum.begin(), chunk_sum.end(), uint64_t{0});
    if (total == 0) break;  // Fewer distinct descriptors than k.
    uint64_t target = rng.Below(total);
    size_t ch = 0;
    while (target >= chunk_sum[ch]) target -= chunk_sum[ch++];
    size_t pick = chunking.Range(ch).first;
    for (uint64_t acc = min_dist2[pick]; acc <= target; acc += min_dist2[pick]) ++pick;
    seeds.push_back(pick);
    if (static_cast<int>(seeds.size()) < k) update(false);
  }
  return seeds;
}

SplitResult SplitNode(OrbDescriptor* data, size_t n, int k, uint64_t seed, int max_iterations,
                      WorkerPool* pool, const SplitWorkspace& ws) {
  const Chunking chunking(n, pool);
  const size_t chunks = chunking.chunks;
  auto chunk_range = [&](size_t ch) { return chunking.Range(ch); };
  auto parallel = [&](const std::function<void(size_t)>& fn) { chunking.Run(fn); };

  std::vector<DescriptorWords> centres;
  for (size_t index : SeedIndices(data, k, seed, chunking, ws.min_dist2)) {
    centres.push_back(ToWords(data[index]));
  }
  const int kc = static_cast<int>(centres.size());

  // Lloyd iterations: assign, then majority centres, until no assignment
  // changes. Per-bit counts of every cluster are kept across rounds and
  // updated with the descriptors that moved only: after the first rounds few
  // do, and counting costs more than the distances.
  std::vector<BitCounter>& counters = *ws.counters;  // Per chunk: added, removed.
  if (counters.size() < 2 * chunks) counters.resize(2 * chunks);
  std::vector<uint8_t> chunk_changed(chunks, 0);
  SplitResult result;
  std::vector<uint64_t> counts(static_cast<size_t>(kc) * 256, 0);
  std::vector<uint64_t> sizes(kc, 0);
  while (true) {
    const bool first_round = result.iterations == 0;
    parallel([&](size_t ch) {
      const auto [b, e] = chunk_range(ch);
      BitCounter& added = counters[2 * ch];
      BitCounter& removed = counters[2 * ch + 1];
      added.Reset(kc);
      removed.Reset(kc);
      bool changed = false;
      for (size_t i = b; i < e; ++i) {
        const int c = Nearest(centres.data(), kc, ToWords(data[i]));
        if (first_round) {
          added.Add(c, data[i]);
        } else if (ws.assign[i] != c) {
          removed.Add(ws.assign[i], data[i]);
          added.Add(c, data[i]);
          changed = true;
        }
        ws.assign[i] = static_cast<uint8_t>(c);
      }
      chunk_changed[ch] = changed;
    });
    ++result.iterations;
    const bool changed = first_round || std::any_of(chunk_changed.begin(), chunk_changed.end(),
                                                    [](uint8_t c) { return c != 0; });
    for (int c = 0; c < kc; ++c) {
      uint64_t* cluster_counts = counts.data() + 256 * static_cast<size_t>(c);
      for (size_t ch = 0; ch < chunks; ++ch) {
        const BitCounter& added = counters[2 * ch];
        const BitCounter& removed = counters[2 * ch + 1];
        sizes[c] += added.size(c) - removed.size(c);
        if (added.size(c) > 0) added.AccumulateCounts(c, cluster_counts, 1);
        if (removed.size(c) > 0) removed.AccumulateCounts(c, cluster_counts, -1);
      }
    }
    if (!changed) {
      result.converged = true;
      break;
    }
    if (result.iterations >= max_iterations) break;
    for (int c = 0; c < kc; ++c) {
      // An emptied cluster keeps its centre.
      if (sizes[c] > 0) {
        centres[c] =
            ToWords(MajorityFromCounts(counts.data() + 256 * static_cast<size_t>(c), sizes[c]));
      }
    }
  }

  // Keep non-empty clusters in order, and group data[0, n) by cluster
  // (stable counting sort, so the order within a child is deterministic).
  std::vector<int> remap(kc, -1);
  std::vector<size_t> offset(kc, 0);
  size_t running = 0;
  for (int c = 0; c < kc; ++c) {
    if (sizes[c] == 0) continue;
    remap[c] = static_cast<int>(result.centres.size());
    OrbDescriptor centre;
    std::memcpy(centre.bytes, centres[c].w, 32);
    result.centres.push_back(centre);
    result.sizes.push_back(sizes[c]);
    offset[c] = running;
    running += sizes[c];
  }
  for (size_t i = 0; i < n; ++i) ws.scratch[offset[ws.assign[i]]++] = data[i];
  std::memcpy(static_cast<void*>(data), ws.scratch, n * sizeof(OrbDescriptor));
  return result;
}

// ---------------------------------------------------------------------------
// The tree under construction. Nodes of the top levels (split with all
// threads working on each node) live in one arena; every smaller subtree is
// built by one thread in an arena of its own. The final pass renumbers all
// nodes in DBoW2 order.

struct BuildNode {
  OrbDescriptor centre;
  uint64_t count = 0;
  uint32_t first_child = 0;  // Index in the same arena (or in the task's arena, see task).
  uint16_t num_children = 0;
  uint8_t level = 0;
  int32_t task = -1;  // Top arena only: this node's subtree is built by task #task.
};

struct PendingNode {
  uint32_t node;  // Index in its arena.
  size_t begin;   // Its descriptors: data[begin, begin + n).
  size_t n;
  int level;
  uint64_t seed;
};

struct ChildSpec {
  OrbDescriptor centre;
  size_t begin;
  size_t n;
};

class TreeBuilder {
 public:
  TreeBuilder(std::vector<OrbDescriptor>& data, const HkmeansParams& params, ProgressBar* progress)
      : data_(data), params_(params), progress_(progress) {}

  VocabTree Build() {
    const size_t n = data_.size();
    const int threads = params_.threads > 0
                            ? params_.threads
                            : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
    WorkerPool pool(threads);
    scratch_.resize(n);
    assign_.resize(n);
    min_dist2_.resize(n);
    // Nodes this large are split by all threads together; smaller subtrees
    // are handed out whole, one per thread.
    const size_t parallel_threshold = threads > 1 ? std::max<size_t>(32768, n / (16 * threads))
                                                  : std::numeric_limits<size_t>::max();

    BuildNode root;
    root.count = n;
    top_.push_back(root);
    std::deque<PendingNode> big;
    const PendingNode root_pending{0, 0, n, 0, RootSeed(params_.seed)};
    if (n >= parallel_threshold) {
      big.push_back(root_pending);
    } else {
      top_[0].task = 0;
      tasks_.push_back(root_pending);
    }
    std::vector<BitCounter> big_counters;
    while (!big.empty()) {
      const PendingNode x = big.front();
      big.pop_front();
      const std::vector<ChildSpec> children = Split(x, &pool, &big_counters);
      top_[x.node].first_child = static_cast<uint32_t>(top_.size());
      top_[x.node].num_children = static_cast<uint16_t>(children.size());
      for (size_t j = 0; j < children.size(); ++j) {
        const uint32_t index = static_cast<uint32_t>(top_.size());
        BuildNode child;
        child.centre = children[j].centre;
        child.count = children[j].n;
        child.level = static_cast<uint8_t>(x.level + 1);
        top_.push_back(child);
        const PendingNode pending{index, children[j].begin, children[j].n, x.level + 1,
                                  ChildSeed(x.seed, static_cast<uint32_t>(j))};
        if (!ShouldSplit(pending)) {
          if (progress_ != nullptr) progress_->Advance(pending.n);
        } else if (pending.n >= parallel_threshold) {
          big.push_back(pending);
        } else {
          top_[index].task = static_cast<int32_t>(tasks_.size());
          tasks_.push_back(pending);
        }
      }
    }

    // Subtrees, largest first so that the last ones to finish are small.
    std::vector<size_t> order(tasks_.size());
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(),
                     [&](size_t a, size_t b) { return tasks_[a].n > tasks_[b].n; });
    task_arenas_.resize(tasks_.size());
    task_roots_.resize(tasks_.size());
    pool.ParallelFor(order.size(), [&](size_t i) {
      const size_t t = order[i];
      std::vector<BitCounter> counters(2);
      task_roots_[t] = BuildSerial(tasks_[t], &task_arenas_[t], &counters);
    });

    spdlog::debug("hkmeans: {} k-means splits, {} stopped by the iteration cap, {} rounds",
                  splits_.load(), capped_.load(), rounds_.load());
    if (capped_ > 0) {
      spdlog::info("hkmeans: {} of {} node splits stopped at --max-iterations {}", capped_.load(),
                   splits_.load(), params_.max_iterations);
    }
    return Renumber();
  }

 private:
  bool ShouldSplit(const PendingNode& x) const {
    return x.level < params_.levels && (x.n > 1 || x.level == 0);
  }

  std::vector<ChildSpec> Split(const PendingNode& x, WorkerPool* pool,
                               std::vector<BitCounter>* counters) {
    std::vector<ChildSpec> children;
    if (x.n <= static_cast<size_t>(params_.k)) {
      // Trivial clustering: one child per descriptor (DBoW2's rule).
      for (size_t i = 0; i < x.n; ++i) children.push_back({data_[x.begin + i], x.begin + i, 1});
      return children;
    }
    const SplitWorkspace ws{scratch_.data() + x.begin, assign_.data() + x.begin,
                            min_dist2_.data() + x.begin, counters};
    const SplitResult r =
        SplitNode(data_.data() + x.begin, x.n, params_.k, x.seed, params_.max_iterations, pool, ws);
    ++splits_;
    rounds_ += r.iterations;
    if (!r.converged) ++capped_;
    size_t begin = x.begin;
    for (size_t c = 0; c < r.centres.size(); ++c) {
      children.push_back({r.centres[c], begin, r.sizes[c]});
      begin += r.sizes[c];
    }
    return children;
  }

  // Splits x and, recursively, its descendants on this thread. Appends the
  // descendants to `arena`; returns (first child, number of children).
  std::pair<uint32_t, uint16_t> BuildSerial(const PendingNode& x, std::vector<BuildNode>* arena,
                                            std::vector<BitCounter>* counters) {
    const std::vector<ChildSpec> children = Split(x, nullptr, counters);
    const uint32_t first = static_cast<uint32_t>(arena->size());
    for (const ChildSpec& c : children) {
      BuildNode child;
      child.centre = c.centre;
      child.count = c.n;
      child.level = static_cast<uint8_t>(x.level + 1);
      arena->push_back(child);
    }
    for (size_t j = 0; j < children.size(); ++j) {
      const PendingNode pending{first + static_cast<uint32_t>(j), children[j].begin, children[j].n,
                                x.level + 1, ChildSeed(x.seed, static_cast<uint32_t>(j))};
      if (ShouldSplit(pending)) {
        const auto [grand_first, count] = BuildSerial(pending, arena, counters);
        (*arena)[first + j].first_child = grand_first;
        (*arena)[first + j].num_children = count;
      } else if (progress_ != nullptr) {
        progress_->Advance(pending.n);
      }
    }
    return {first, static_cast<uint16_t>(children.size())};
  }

  // DBoW2 numbering: when a node is visited (pre-order), its children get the
  // next consecutive ids; then they are visited in order.
  VocabTree Renumber() {
    size_t total = 1 + top_.size() - 1;
    for (const auto& arena : task_arenas_) total += arena.size();
    if (total > kMaxTreeNodes) {
      throw AlgorithmError("the tree would have " + std::to_string(total) +
                           " nodes, more than the supported " + std::to_string(kMaxTreeNodes));
    }
    VocabTree tree;
    tree.k = params_.k;
    tree.levels = params_.levels;
    tree.parent.reserve(total);
    tree.level.reserve(total);
    tree.centre.reserve(total);
    tree.count.reserve(total);
    tree.parent.push_back(-1);
    tree.level.push_back(0);
    tree.centre.push_back(OrbDescriptor{});
    tree.count.push_back(top_[0].count);
    Visit(&top_, 0, 0, &tree);
    return tree;
  }

  void Visit(const std::vector<BuildNode>* arena, uint32_t index, int32_t id, VocabTree* tree) {
    const BuildNode& node = (*arena)[index];
    const std::vector<BuildNode>* child_arena = arena;
    uint32_t first = node.first_child;
    uint32_t count = node.num_children;
    if (arena == &top_ && node.task >= 0) {
      child_arena = &task_arenas_[static_cast<size_t>(node.task)];
      first = task_roots_[static_cast<size_t>(node.task)].first;
      count = task_roots_[static_cast<size_t>(node.task)].second;
    }
    const int32_t first_id = static_cast<int32_t>(tree->parent.size());
    for (uint32_t j = 0; j < count; ++j) {
      const BuildNode& child = (*child_arena)[first + j];
      tree->parent.push_back(id);
      tree->level.push_back(child.level);
      tree->centre.push_back(child.centre);
      tree->count.push_back(child.count);
    }
    for (uint32_t j = 0; j < count; ++j) {
      Visit(child_arena, first + j, first_id + static_cast<int32_t>(j), tree);
    }
  }

  std::vector<OrbDescriptor>& data_;
  const HkmeansParams& params_;
  ProgressBar* progress_;
  std::vector<OrbDescriptor> scratch_;
  std::vector<uint8_t> assign_;
  std::vector<uint32_t> min_dist2_;
  std::vector<BuildNode> top_;
  std::vector<PendingNode> tasks_;
  std::vector<std::vector<BuildNode>> task_arenas_;
  std::vector<std::pair<uint32_t, uint16_t>> task_roots_;
  std::atomic<uint64_t> splits_{0}, capped_{0}, rounds_{0};
};

}  // namespace

OrbDescriptor MajorityCentre(std::span<const OrbDescriptor> descriptors) {
  if (descriptors.empty()) return OrbDescriptor{};
  BitCounter counter;
  counter.Reset(1);
  for (const OrbDescriptor& d : descriptors) counter.Add(0, d);
  std::vector<uint64_t> counts(256, 0);
  counter.AccumulateCounts(0, counts.data());
  return MajorityFromCounts(counts.data(), descriptors.size());
}

std::vector<uint32_t> KMeansPlusPlusSeeds(std::span<const OrbDescriptor> descriptors, int k,
                                          uint64_t seed) {
  if (descriptors.empty() || k <= 0) return {};
  std::vector<uint32_t> min_dist2(descriptors.size());
  const std::vector<size_t> seeds = SeedIndices(
      descriptors.data(), k, seed, Chunking(descriptors.size(), nullptr), min_dist2.data());
  return {seeds.begin(), seeds.end()};
}

BinaryKMeansResult BinaryKMeans(std::span<const OrbDescriptor> descriptors, int k, uint64_t seed,
                                int max_iterations) {
  if (k < 1 || k > kMaxK) throw std::invalid_argument("BinaryKMeans: k out of [1, 31]");
  BinaryKMeansResult out;
  const size_t n = descriptors.size();
  if (n == 0) return out;
  // SplitNode groups its input by cluster; run it on a tagged copy to recover
  // the assignment of every input descriptor.
  std::vector<OrbDescriptor> data(descriptors.begin(), descriptors.end());
  std::vector<OrbDescriptor> scratch(n);
  std::vector<uint8_t> assign(n);
  std::vector<uint32_t> min_dist2(n);
  std::vector<BitCounter> counters(2);
  const SplitResult r = SplitNode(data.data(), n, k, seed, std::max(1, max_iterations), nullptr,
                                  {scratch.data(), assign.data(), min_dist2.data(), &counters});
  out.centres = r.centres;
  out.iterations = r.iterations;
  out.converged = r.converged;
  out.assignment.resize(n);
  std::vector<DescriptorWords> centres;
  for (const OrbDescriptor& c : r.centres) centres.push_back(ToWords(c));
  for (size_t i = 0; i < n; ++i) {
    out.assignment[i] = static_cast<uint32_t>(
        Nearest(centres.data(), static_cast<int>(centres.size()), ToWords(descriptors[i])));
  }
  return out;
}

VocabTree BuildVocabTree(std::vector<OrbDescriptor>& descriptors, const HkmeansParams& params,
                         ProgressBar* progress) {
  if (descriptors.empty()) throw AlgorithmError("no training descriptors to cluster");
  if (descriptors.size() > std::numeric_limits<uint32_t>::max()) {
    throw AlgorithmError("more than 2^32 training descriptors; use --max-descriptors");
  }
  if (params.k < 2 || params.k > 20 || params.levels < 1 || params.levels > 10) {
    throw std::invalid_argument("BuildVocabTree: k or levels out of range");
  }
  TreeBuilder builder(descriptors, params, progress);
  return builder.Build();
}

}  // namespace rrslam
