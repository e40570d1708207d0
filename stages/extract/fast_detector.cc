#include "stages/extract/fast_detector.h"

#include <algorithm>
#include <stdexcept>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "stages/extract/fast_kernels.h"

namespace rrslam::fast_internal {
#if defined(RRSLAM_HAVE_AVX2_KERNEL)
// fast_detector_avx2.cc (compiled with -mavx2).
void ScoreRowAvx2(const uint8_t* row, const ptrdiff_t* offset, int count, int threshold,
                  uint8_t* out);
#endif
}  // namespace rrslam::fast_internal

namespace rrslam {
namespace {

// The Bresenham circle of radius 3, in circular order (clockwise from the top).
constexpr int kCircle[16][2] = {{0, -3}, {1, -3},  {2, -2},  {3, -1}, {3, 0},  {3, 1},
                                {2, 2},  {1, 3},   {0, 3},   {-1, 3}, {-2, 2}, {-3, 1},
                                {-3, 0}, {-3, -1}, {-2, -2}, {-1, -3}};

// Score (or 0) of the pixel at `p`, given the circle's offsets in bytes.
int ScoreAt(const uint8_t* p, const ptrdiff_t* offset, int threshold) {
  const int c = p[0];
  int brighter[16], darker[16];
  for (int k = 0; k < 16; ++k) {
    const int v = p[offset[k]];
    brighter[k] = std::max(v - c, 0);
    darker[k] = std::max(c - v, 0);
  }
  // Any arc of 9 holds one pixel of each antipodal pair (k, k + 8).
  bool may_be_brighter = true, may_be_darker = true;
  for (int k = 0; k < 8; ++k) {
    may_be_brighter = may_be_brighter && std::max(brighter[k], brighter[k + 8]) > threshold;
    may_be_darker = may_be_darker && std::max(darker[k], darker[k + 8]) > threshold;
  }
  if (!may_be_brighter && !may_be_darker) return 0;
  int best = 0;
  for (int k = 0; k < 16; ++k) {
    int min_brighter = 255, min_darker = 255;
    for (int j = 0; j < 9; ++j) {
      min_brighter = std::min(min_brighter, brighter[(k + j) & 15]);
      min_darker = std::min(min_darker, darker[(k + j) & 15]);
    }
    best = std::max(best, std::max(min_brighter, min_darker));
  }
  return best > threshold ? best - 1 : 0;
}

void ScoreRowScalar(const uint8_t* row, const ptrdiff_t* offset, int count, int threshold,
                    uint8_t* out) {
  for (int i = 0; i < count; ++i)
    out[i] = static_cast<uint8_t>(ScoreAt(row + i, offset, threshold));
}

#if defined(__SSE2__)

struct Sse2Ops {
  using V = __m128i;
  static constexpr int kLanes = 16;
  static V Load(const uint8_t* p) { return _mm_loadu_si128(reinterpret_cast<const V*>(p)); }
  static void Store(uint8_t* p, V v) { _mm_storeu_si128(reinterpret_cast<V*>(p), v); }
  static V Zero() { return _mm_setzero_si128(); }
  static V Set1(int v) { return _mm_set1_epi8(static_cast<char>(v)); }
  static V SubSat(V a, V b) { return _mm_subs_epu8(a, b); }
  static V Min(V a, V b) { return _mm_min_epu8(a, b); }
  static V Max(V a, V b) { return _mm_max_epu8(a, b); }
  static bool AllZero(V v) { return _mm_movemask_epi8(_mm_cmpeq_epi8(v, Zero())) == 0xFFFF; }
  // `value` where `mask` is non-zero, 0 elsewhere.
  static V KeepWhereNonZero(V mask, V value) {
    return _mm_andnot_si128(_mm_cmpeq_epi8(mask, Zero()), value);
  }
};

#endif

bool CpuHasAvx2() {
#if defined(RRSLAM_HAVE_AVX2_KERNEL)
  static const bool has = __builtin_cpu_supports("avx2");
  return has;
#else
  return false;
#endif
}

void ScoreRow(FastKernel kernel, const uint8_t* row, const ptrdiff_t* offset, int count,
              int threshold, uint8_t* out) {
#if defined(RRSLAM_HAVE_AVX2_KERNEL)
  if (kernel == FastKernel::kAvx2 && count >= 32) {
    fast_internal::ScoreRowAvx2(row, offset, count, threshold, out);
    return;
  }
#endif
#if defined(__SSE2__)
  if (kernel != FastKernel::kScalar && count >= 16) {
    fast_internal::ScoreRow<Sse2Ops>(row, offset, count, threshold, out);
    return;
  }
#endif
  ScoreRowScalar(row, offset, count, threshold, out);
}

// Is the score at `s` larger than its 8 neighbours in the map (row stride `w`)?
inline bool IsLocalMax(const uint8_t* s, ptrdiff_t w) {
  const int v = s[0];
  return v > s[-1] && v > s[1] && v > s[-w - 1] && v > s[-w] && v > s[-w + 1] && v > s[w - 1] &&
         v > s[w] && v > s[w + 1];
}

}  // namespace

bool FastKernelAvailable(FastKernel kernel) {
  switch (kernel) {
    case FastKernel::kScalar:
      return true;
    case FastKernel::kSse2:
#if defined(__SSE2__)
      return true;
#else
      return false;
#endif
    case FastKernel::kAvx2:
      return CpuHasAvx2();
  }
  return false;
}

FastKernel BestFastKernel() {
  if (FastKernelAvailable(FastKernel::kAvx2)) return FastKernel::kAvx2;
  if (FastKernelAvailable(FastKernel::kSse2)) return FastKernel::kSse2;
  return FastKernel::kScalar;
}

int FastScore(const cv::Mat& image, int x, int y, int threshold) {
  ptrdiff_t offset[16];
  const ptrdiff_t step = static_cast<ptrdiff_t>(image.step1());
  for (int k = 0; k < 16; ++k) offset[k] = kCircle[k][1] * step + kCircle[k][0];
  return ScoreAt(image.ptr<uint8_t>(y) + x, offset, threshold);
}

void DetectFastCorners(const cv::Mat& image, const cv::Rect& box, int threshold,
                       std::vector<FastCorner>* corners, std::vector<uint8_t>* scratch,
                       FastKernel kernel) {
  if (!FastKernelAvailable(kernel)) kernel = BestFastKernel();
  if (image.type() != CV_8UC1 || threshold < 1 || threshold > 255 || box.x < 4 || box.y < 4 ||
      box.x + box.width + 4 > image.cols || box.y + box.height + 4 > image.rows) {
    throw std::invalid_argument("DetectFastCorners: 8-bit image with 4 px around the box needed");
  }
  if (box.width <= 0 || box.height <= 0) return;
  ptrdiff_t offset[16];
  const ptrdiff_t step = static_cast<ptrdiff_t>(image.step1());
  for (int k = 0; k < 16; ++k) offset[k] = kCircle[k][1] * step + kCircle[k][0];

  // Score map of the box grown by one pixel (the suppression neighbours).
  const int w = box.width + 2;
  const int h = box.height + 2;
  scratch->resize(static_cast<size_t>(w) * h);
  uint8_t* map = scratch->data();
  for (int r = 0; r < h; ++r) {
    ScoreRow(kernel, image.ptr<uint8_t>(box.y - 1 + r) + (box.x - 1), offset, w, threshold,
             map + r * w);
  }

  for (int r = 1; r + 1 < h; ++r) {
    const uint8_t* s = map + r * w;
    const int y = box.y - 1 + r;
    int i = 1;
#if defined(__SSE2__)
    const __m128i zero = _mm_setzero_si128();
    for (; i + 16 <= w - 1; i += 16) {
      const __m128i v = _mm_loadu_si128(reinterpret_cast<const __m128i*>(s + i));
      if (_mm_movemask_epi8(_mm_cmpeq_epi8(v, zero)) == 0xFFFF) continue;
      // v > n for every neighbour n <=> min over n of sat(v - n) > 0.
      __m128i keep = _mm_subs_epu8(v, _mm_loadu_si128(reinterpret_cast<const __m128i*>(s + i - 1)));
      const ptrdiff_t neighbours[7] = {1, -w - 1, -w, -w + 1, w - 1, w, w + 1};
      for (ptrdiff_t n : neighbours) {
        keep = _mm_min_epu8(
            keep, _mm_subs_epu8(v, _mm_loadu_si128(reinterpret_cast<const __m128i*>(s + i + n))));
      }
      unsigned mask =
          ~static_cast<unsigned>(_mm_movemask_epi8(_mm_cmpeq_epi8(keep, zero))) & 0xFFFFu;
      while (mask != 0) {
        const int bit = __builtin_ctz(mask);
        mask &= mask - 1;
        corners->push_back({box.x - 1 + i + bit, y, s[i + bit]});
      }
    }
#endif
    for (; i < w - 1; ++i) {
      if (s[i] != 0 && IsLocalMax(s + i, w)) corners->push_back({box.x - 1 + i, y, s[i]});
    }
  }
}

}  // namespace rrslam
