#include "common/heap_reserve.h"

#include <malloc.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cstdlib>
#include <thread>
#include <vector>

#ifndef MADV_POPULATE_WRITE
#define MADV_POPULATE_WRITE 23  // Linux >= 5.14; older kernels refuse it (EINVAL).
#endif

namespace rrslam {
namespace {

constexpr size_t kBlockBytes = size_t{16} << 20;
constexpr size_t kMmapThreshold = size_t{32} << 20;
constexpr size_t kTrimSlack = size_t{64} << 20;
// Pages made resident per madvise call of the prefault thread (between two
// looks at its stop flag).
constexpr size_t kPrefaultStep = size_t{8} << 20;

// The advised part of a reservation: [begin, end) of whole pages.
struct AdvisedRange {
  uintptr_t begin = 0, end = 0;
  size_t advised = 0;
};

AdvisedRange Reserve(size_t bytes) {
  AdvisedRange range;
  if (bytes == 0) return range;
  mallopt(M_MMAP_THRESHOLD, static_cast<int>(kMmapThreshold));
  // mallopt takes an int: a threshold beyond 2 GB cannot be set, and a
  // capped one would give a larger reservation back to the system at the
  // first free (its advice lost with it), so trimming is then turned off
  // (-1, glibc's "never").
  const size_t trim = bytes + kTrimSlack;
  mallopt(M_TRIM_THRESHOLD, trim > static_cast<size_t>(INT32_MAX) ? -1 : static_cast<int>(trim));
  const uintptr_t page = static_cast<uintptr_t>(sysconf(_SC_PAGESIZE));
  std::vector<void*> blocks;
  for (size_t done = 0; done < bytes; done += kBlockBytes) {
    void* block = std::malloc(kBlockBytes);
    if (block == nullptr) break;
    blocks.push_back(block);
    // The block's whole pages (madvise takes page-aligned ranges).
    const uintptr_t begin = (reinterpret_cast<uintptr_t>(block) + page - 1) & ~(page - 1);
    const uintptr_t end = (reinterpret_cast<uintptr_t>(block) + kBlockBytes) & ~(page - 1);
    if (end > begin && madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE) == 0) {
      range.advised += end - begin;
      range.begin = range.begin == 0 ? begin : std::min(range.begin, begin);
      range.end = std::max(range.end, end);
    }
  }
  // Freed in reverse, they merge back into the heap's top, which the trim
  // threshold keeps.
  for (auto it = blocks.rbegin(); it != blocks.rend(); ++it) std::free(*it);
  return range;
}

}  // namespace

size_t ReserveHeap(size_t bytes) { return Reserve(bytes).advised; }

struct HeapReservation::Prefault {
  std::atomic<bool> stop{false};
  std::atomic<size_t> done{0};
  std::thread thread;
};

HeapReservation::HeapReservation(size_t bytes, size_t prefault_bytes) {
  const AdvisedRange range = Reserve(bytes);
  advised_ = range.advised;
  // Only a reservation that was advised is one heap range the next
  // allocations come from (not under a sanitizer's allocator).
  if (advised_ == 0 || prefault_bytes == 0) return;
  const uintptr_t end = std::min(range.end, range.begin + prefault_bytes);
  prefault_ = std::make_unique<Prefault>();
  prefault_->thread = std::thread([p = prefault_.get(), begin = range.begin, end] {
    // MADV_POPULATE_WRITE faults the pages in as writes would, without
    // touching their bytes: safe while the heap hands them out. An error
    // (an old kernel, memory given back) ends it; the caller only loses
    // the head start.
    for (uintptr_t at = begin; at < end && !p->stop.load(std::memory_order_relaxed);) {
      const size_t step = std::min<uintptr_t>(kPrefaultStep, end - at);
      if (madvise(reinterpret_cast<void*>(at), step, MADV_POPULATE_WRITE) != 0) return;
      at += step;
      p->done.store(at - begin, std::memory_order_relaxed);
    }
  });
}

HeapReservation::~HeapReservation() {
  if (!prefault_) return;
  prefault_->stop = true;
  prefault_->thread.join();
}

HeapReservation::HeapReservation(HeapReservation&&) noexcept = default;

size_t HeapReservation::prefaulted() const { return prefault_ ? prefault_->done.load() : 0; }

}  // namespace rrslam
