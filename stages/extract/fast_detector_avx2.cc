// The AVX2 (32-lane) FAST score kernel. This file alone is compiled with
// -mavx2; fast_detector.cc calls it only on CPUs that report AVX2. It includes
// no library headers beyond the intrinsics (see fast_kernels.h).
#include <immintrin.h>

#include "stages/extract/fast_kernels.h"

namespace rrslam::fast_internal {
namespace {

struct Avx2Ops {
  using V = __m256i;
  static constexpr int kLanes = 32;
  static V Load(const uint8_t* p) { return _mm256_loadu_si256(reinterpret_cast<const V*>(p)); }
  static void Store(uint8_t* p, V v) { _mm256_storeu_si256(reinterpret_cast<V*>(p), v); }
  static V Zero() { return _mm256_setzero_si256(); }
  static V Set1(int v) { return _mm256_set1_epi8(static_cast<char>(v)); }
  static V SubSat(V a, V b) { return _mm256_subs_epu8(a, b); }
  static V Min(V a, V b) { return _mm256_min_epu8(a, b); }
  static V Max(V a, V b) { return _mm256_max_epu8(a, b); }
  static bool AllZero(V v) { return _mm256_testz_si256(v, v) != 0; }
  // `value` where `mask` is non-zero, 0 elsewhere.
  static V KeepWhereNonZero(V mask, V value) {
    return _mm256_andnot_si256(_mm256_cmpeq_epi8(mask, Zero()), value);
  }
};

}  // namespace

void ScoreRowAvx2(const uint8_t* row, const ptrdiff_t* offset, int count, int threshold,
                  uint8_t* out) {
  ScoreRow<Avx2Ops>(row, offset, count, threshold, out);
}

}  // namespace rrslam::fast_internal
