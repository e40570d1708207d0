#include "common/heap_reserve.h"

#include <gtest/gtest.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace rrslam {
namespace {

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr bool kSanitizerAllocator = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
constexpr bool kSanitizerAllocator = true;
#else
constexpr bool kSanitizerAllocator = false;
#endif
#else
constexpr bool kSanitizerAllocator = false;
#endif

// The mappings of this process advised for transparent huge pages ("hg" in
// their VmFlags, /proc/self/smaps), as [begin, end) address ranges.
std::vector<std::pair<uintptr_t, uintptr_t>> HugePageMappings() {
  std::vector<std::pair<uintptr_t, uintptr_t>> out;
  std::ifstream smaps("/proc/self/smaps");
  std::string line;
  uintptr_t begin = 0, end = 0;
  while (std::getline(smaps, line)) {
    uintptr_t b = 0, e = 0;
    char dash = 0;
    std::istringstream header(line);
    if (header >> std::hex >> b >> dash >> e && dash == '-') {
      begin = b;
      end = e;
    } else if (line.rfind("VmFlags:", 0) == 0 && (line + " ").find(" hg ") != std::string::npos) {
      out.emplace_back(begin, end);
    }
  }
  return out;
}

TEST(ReserveHeap, NothingToReserve) { EXPECT_EQ(ReserveHeap(0), 0u); }

// A burst of allocations after the reservation, on this thread, lands in
// memory advised for transparent huge pages. (Not every block: one may reuse
// a free chunk from before.)
TEST(ReserveHeap, ABurstOfAllocationsLandsInHugePageMemory) {
  if (kSanitizerAllocator) GTEST_SKIP() << "a sanitizer's allocator ignores glibc's settings";
  const size_t advised = ReserveHeap(size_t{32} << 20);
  if (advised == 0) GTEST_SKIP() << "this kernel refuses MADV_HUGEPAGE";
  EXPECT_GE(advised, size_t{31} << 20);
  // Sizes a map load makes: a keyframe's keypoints, a map point's list.
  std::vector<void*> blocks;
  for (int i = 0; i < 400; ++i) {
    for (const size_t bytes : {size_t{36000}, size_t{160}}) blocks.push_back(std::malloc(bytes));
  }
  const auto ranges = HugePageMappings();
  size_t inside = 0;
  for (void* p : blocks) {
    ASSERT_NE(p, nullptr);
    const auto a = reinterpret_cast<uintptr_t>(p);
    for (const auto& [begin, end] : ranges) inside += begin <= a && a < end;
  }
  for (void* p : blocks) std::free(p);
  EXPECT_GE(inside, blocks.size() * 9 / 10) << "of " << blocks.size();
}

// A reservation beyond 2 GB (a building-scale map) stays in the heap: glibc
// takes no trim threshold that large, and with one capped at 2 GB the blocks'
// own frees gave most of it back to the system at once, advice and all.
TEST(ReserveHeap, AReservationBeyondTwoGigabytesIsKept) {
  if (kSanitizerAllocator) GTEST_SKIP() << "a sanitizer's allocator ignores glibc's settings";
  const size_t bytes = size_t{3} << 30;  // Address space only: nothing is touched.
  const size_t advised = ReserveHeap(bytes);
  if (advised == 0) GTEST_SKIP() << "this kernel refuses MADV_HUGEPAGE";
  std::free(std::malloc(64));  // A free, where glibc would trim.
  size_t huge = 0;
  for (const auto& [begin, end] : HugePageMappings()) huge += end - begin;
  EXPECT_GE(huge, bytes - (size_t{16} << 20));
}

// Whether every page of [p, p + bytes) is resident (mincore).
bool Resident(const void* p, size_t bytes) {
  const uintptr_t page = static_cast<uintptr_t>(sysconf(_SC_PAGESIZE));
  const uintptr_t begin = reinterpret_cast<uintptr_t>(p) & ~(page - 1);
  const uintptr_t end = reinterpret_cast<uintptr_t>(p) + bytes;
  std::vector<unsigned char> flags((end - begin + page - 1) / page);
  if (mincore(reinterpret_cast<void*>(begin), end - begin, flags.data()) != 0) return false;
  for (const unsigned char f : flags) {
    if (!(f & 1)) return false;
  }
  return true;
}

// The prefault thread makes the reservation's first pages resident before
// anything touches them, and the allocations that follow land there.
TEST(HeapReservation, PrefaultedMemoryIsResidentBeforeItIsTouched) {
  if (kSanitizerAllocator) GTEST_SKIP() << "a sanitizer's allocator ignores glibc's settings";
  const size_t prefault = size_t{32} << 20;
  const HeapReservation heap(size_t{64} << 20, prefault);
  if (heap.advised() == 0) GTEST_SKIP() << "this kernel refuses MADV_HUGEPAGE";
  for (int i = 0; i < 500 && heap.prefaulted() < prefault; ++i) usleep(10000);
  if (heap.prefaulted() == 0) GTEST_SKIP() << "this kernel has no MADV_POPULATE_WRITE";
  EXPECT_EQ(heap.prefaulted(), prefault);
  // A burst of 24 MB, not touched by the test: resident because the thread
  // faulted it in (but a block or two that reuse free chunks from before).
  std::vector<void*> blocks;
  int resident = 0;
  for (int i = 0; i < 24; ++i) {
    blocks.push_back(std::malloc(size_t{1} << 20));
    ASSERT_NE(blocks.back(), nullptr);
    resident += Resident(blocks.back(), size_t{1} << 20);
  }
  for (void* p : blocks) std::free(p);
  EXPECT_GE(resident, 20);
}

// Nothing to prefault, or a reservation that is destroyed at once: the
// thread is stopped and joined, and the reservation is still made.
TEST(HeapReservation, StopsWhenItGoes) {
  { const HeapReservation none(size_t{16} << 20, 0); }
  const HeapReservation moved = [] {
    HeapReservation heap(size_t{256} << 20, size_t{256} << 20);
    return heap;
  }();
  EXPECT_LE(moved.prefaulted(), size_t{256} << 20);
}

}  // namespace
}  // namespace rrslam
