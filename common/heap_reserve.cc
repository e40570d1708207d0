#include "common/heap_reserve.h"

#include <malloc.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <vector>

namespace rrslam {
namespace {

constexpr size_t kBlockBytes = size_t{16} << 20;
constexpr size_t kMmapThreshold = size_t{32} << 20;
constexpr size_t kTrimSlack = size_t{64} << 20;

}  // namespace

size_t ReserveHeap(size_t bytes) {
  if (bytes == 0) return 0;
  mallopt(M_MMAP_THRESHOLD, static_cast<int>(kMmapThreshold));
  // mallopt takes an int: a threshold beyond 2 GB cannot be set, and a
  // capped one would give a larger reservation back to the system at the
  // first free (its advice lost with it), so trimming is then turned off
  // (-1, glibc's "never").
  const size_t trim = bytes + kTrimSlack;
  mallopt(M_TRIM_THRESHOLD, trim > static_cast<size_t>(INT32_MAX) ? -1 : static_cast<int>(trim));
  const uintptr_t page = static_cast<uintptr_t>(sysconf(_SC_PAGESIZE));
  std::vector<void*> blocks;
  size_t advised = 0;
  for (size_t done = 0; done < bytes; done += kBlockBytes) {
    void* block = std::malloc(kBlockBytes);
    if (block == nullptr) break;
    blocks.push_back(block);
    // The block's whole pages (madvise takes page-aligned ranges).
    const uintptr_t begin = (reinterpret_cast<uintptr_t>(block) + page - 1) & ~(page - 1);
    const uintptr_t end = (reinterpret_cast<uintptr_t>(block) + kBlockBytes) & ~(page - 1);
    if (end > begin && madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE) == 0) {
      advised += end - begin;
    }
  }
  // Freed in reverse, they merge back into the heap's top, which the trim
  // threshold keeps.
  for (auto it = blocks.rbegin(); it != blocks.rend(); ++it) std::free(*it);
  return advised;
}

}  // namespace rrslam
