// Internal to fast_detector.cc and fast_detector_avx2.cc: the FAST score of a
// row of pixels, written once over a vector-operations policy `Ops` and
// compiled for SSE2 (16 lanes) and AVX2 (32 lanes).
//
// Every function here is a template over a policy that the including file
// declares in an anonymous namespace, so the instantiations have internal
// linkage and code compiled with -mavx2 cannot leak into SSE2 callers. For the
// same reason this header uses no standard-library templates.
#pragma once

#include <cstddef>
#include <cstdint>

namespace rrslam::fast_internal {

// max over k of min(x[k], ..., x[k + 8]) (indices mod 16), lane by lane: the
// best arc of 9 by a doubling sliding-window minimum.
template <class Ops>
inline typename Ops::V BestArc(const typename Ops::V* x) {
  using V = typename Ops::V;
  V m2[16], m4[16];
  for (int k = 0; k < 16; ++k) m2[k] = Ops::Min(x[k], x[(k + 1) & 15]);
  for (int k = 0; k < 16; ++k) m4[k] = Ops::Min(m2[k], m2[(k + 2) & 15]);
  V best = Ops::Zero();
  for (int k = 0; k < 16; ++k) {
    const V m8 = Ops::Min(m4[k], m4[(k + 4) & 15]);
    best = Ops::Max(best, Ops::Min(m8, x[(k + 8) & 15]));
  }
  return best;
}

// Scores (or 0) of Ops::kLanes consecutive pixels at `p`, given the byte
// offsets of the 16 circle pixels. All values are unsigned bytes: saturated
// differences turn "I_k - c > t" into "sat(I_k - c) > t".
template <class Ops>
inline typename Ops::V ScoreBlock(const uint8_t* p, const ptrdiff_t* offset,
                                  typename Ops::V threshold) {
  using V = typename Ops::V;
  const V c = Ops::Load(p);
  // First test on the four compass pixels: any arc of 9 holds one pixel of
  // each antipodal pair (k, k + 8), beyond the threshold on the arc's side.
  {
    const V v0 = Ops::Load(p + offset[0]), v4 = Ops::Load(p + offset[4]);
    const V v8 = Ops::Load(p + offset[8]), v12 = Ops::Load(p + offset[12]);
    const V bright = Ops::Min(Ops::Max(Ops::SubSat(v0, c), Ops::SubSat(v8, c)),
                              Ops::Max(Ops::SubSat(v4, c), Ops::SubSat(v12, c)));
    const V dark = Ops::Min(Ops::Max(Ops::SubSat(c, v0), Ops::SubSat(c, v8)),
                            Ops::Max(Ops::SubSat(c, v4), Ops::SubSat(c, v12)));
    if (Ops::AllZero(Ops::SubSat(Ops::Max(bright, dark), threshold))) return Ops::Zero();
  }
  V brighter[16], darker[16];
  for (int k = 0; k < 16; ++k) {
    const V v = Ops::Load(p + offset[k]);
    brighter[k] = Ops::SubSat(v, c);
    darker[k] = Ops::SubSat(c, v);
  }
  // The same test on all eight antipodal pairs.
  V pairs_brighter = Ops::Max(brighter[0], brighter[8]);
  V pairs_darker = Ops::Max(darker[0], darker[8]);
  for (int k = 1; k < 8; ++k) {
    pairs_brighter = Ops::Min(pairs_brighter, Ops::Max(brighter[k], brighter[k + 8]));
    pairs_darker = Ops::Min(pairs_darker, Ops::Max(darker[k], darker[k + 8]));
  }
  if (Ops::AllZero(Ops::SubSat(Ops::Max(pairs_brighter, pairs_darker), threshold))) {
    return Ops::Zero();
  }
  const V best = Ops::Max(BestArc<Ops>(brighter), BestArc<Ops>(darker));
  // Corner (best > t): score best - 1 (>= t >= 1); otherwise 0.
  return Ops::KeepWhereNonZero(Ops::SubSat(best, threshold), Ops::SubSat(best, Ops::Set1(1)));
}

// out[i] = score (or 0) of row[i] for i in [0, count); count >= Ops::kLanes.
template <class Ops>
void ScoreRow(const uint8_t* row, const ptrdiff_t* offset, int count, int threshold, uint8_t* out) {
  const typename Ops::V t = Ops::Set1(threshold);
  for (int i = 0;; i += Ops::kLanes) {
    // The last block is moved back to end at the row's end (it recomputes a
    // few pixels to the same values).
    const int start = i < count - Ops::kLanes ? i : count - Ops::kLanes;
    Ops::Store(out + start, ScoreBlock<Ops>(row + start, offset, t));
    if (start == count - Ops::kLanes) break;
  }
}

}  // namespace rrslam::fast_internal
