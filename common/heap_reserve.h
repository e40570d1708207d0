// Preparing the heap for a burst of many small allocations (loading a map).
//
// First touches of fresh memory are page faults, and on virtual machines each
// costs several microseconds: loading a 6.5 MB map (some 20 000 vectors)
// spent most of its ~45 ms in them. ReserveHeap makes the next `bytes` of the
// calling thread's heap transparent-huge-page memory, so the same touches
// fault once per 2 MB instead of once per 4 kB (the kitchen map then loads in
// about 20 ms; docs/mapstore.md). Where transparent huge pages are disabled
// (`/sys/kernel/mm/transparent_hugepage/enabled` = never) it changes nothing
// but the allocator settings below, and costs nothing.
//
// How: blocks of at most 16 MB are allocated from the top of glibc's main
// heap, advised MADV_HUGEPAGE, and freed again; they stay in the heap for the
// allocations that follow because the trim threshold is raised to keep them.
// Process-wide effects, from the first call on: glibc's mmap threshold is set
// to 32 MB (its own adaptive threshold's ceiling: blocks below it come from
// the heap) and its trim threshold to 64 MB above the reservation (freed heap
// tops below that are kept; no trimming at all when that exceeds 2 GB, the
// largest threshold glibc takes). Memory is only advised, not touched: pages
// become resident when used. Allocations of other threads use other arenas
// and do not benefit, so the burst should run on the calling thread.
#pragma once

#include <cstddef>
#include <memory>

namespace rrslam {

// Returns the number of bytes advised for huge pages (0 when the advice was
// refused, e.g. transparent huge pages not built into the kernel, or under a
// sanitizer's allocator). Never throws; failures only lose the speed-up.
size_t ReserveHeap(size_t bytes);

// ReserveHeap(bytes), and the first `prefault_bytes` of the reservation made
// resident by a thread of its own while the caller allocates: the first
// touches of fresh memory (the kernel zeroing pages, on a virtual machine
// the host's faults too: most of a big map's load) move off the caller's
// thread onto an idle core, ahead of the caller's allocations, which come
// from the reservation in address order. The pages are faulted in with
// MADV_POPULATE_WRITE (Linux >= 5.14), which does not write their bytes, so
// it is safe while the heap hands them out; on older kernels, or when
// nothing was advised, no thread starts. Prefaulted pages are resident
// whether used or not: give about what the burst will allocate. The thread
// stops (and is joined) when the object goes. Never throws.
class HeapReservation {
 public:
  HeapReservation(size_t bytes, size_t prefault_bytes);
  ~HeapReservation();
  HeapReservation(HeapReservation&&) noexcept;
  HeapReservation& operator=(HeapReservation&&) = delete;
  HeapReservation(const HeapReservation&) = delete;
  HeapReservation& operator=(const HeapReservation&) = delete;

  size_t advised() const { return advised_; }
  // Bytes made resident so far.
  size_t prefaulted() const;

 private:
  struct Prefault;
  size_t advised_ = 0;
  std::unique_ptr<Prefault> prefault_;
};

}  // namespace rrslam
