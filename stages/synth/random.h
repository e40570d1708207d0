// Reproducible random numbers for synthetic data.
//
// Everything random in rrslam-synth (textures, depth noise, holes, exposure)
// comes from these generators, never from std::uniform_*_distribution, whose
// output is implementation-defined: the same seed must give byte-identical
// files with any standard library. Per-pixel noise uses counter-based hashing
// (HashKeys), so a pixel's value depends only on its keys, never on which
// thread computed it or in which order.
#pragma once

#include <cmath>
#include <cstdint>

namespace rrslam::synth {

// SplitMix64's finalizer: a bijective, well-mixing map of 64-bit words.
constexpr uint64_t Mix64(uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

// A hash of up to four keys (seed, stream, frame, pixel...). Order matters.
constexpr uint64_t HashKeys(uint64_t a, uint64_t b, uint64_t c = 0, uint64_t d = 0) {
  return Mix64(Mix64(Mix64(Mix64(a) ^ b) ^ c) ^ d);
}

// The top 53 bits of `bits` as a double in [0, 1).
constexpr double UnitFromBits(uint64_t bits) {
  return static_cast<double>(bits >> 11) * (1.0 / 9007199254740992.0);
}

// A standard normal deviate from two independent words (Box-Muller).
inline double NormalFromBits(uint64_t bits1, uint64_t bits2) {
  const double u1 = 1.0 - UnitFromBits(bits1);  // (0, 1]: log is finite.
  const double u2 = UnitFromBits(bits2);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(6.283185307179586 * u2);
}

// A sequential generator (SplitMix64). Cheap to copy; not thread-safe.
class Rng {
 public:
  explicit Rng(uint64_t seed) : state_(seed) {}

  uint64_t Next() {
    state_ += 0x9e3779b97f4a7c15ULL;
    uint64_t z = state_;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }
  // Uniform in [0, 1).
  double Uniform() { return UnitFromBits(Next()); }
  // Uniform in [lo, hi).
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }
  // Uniform integer in [lo, hi] (hi >= lo).
  int UniformInt(int lo, int hi) {
    const uint64_t span = static_cast<uint64_t>(hi - lo) + 1;
    return lo + static_cast<int>(Next() % span);  // Bias < 2^-40 for small spans.
  }
  // Log-uniform in [lo, hi), lo > 0: every octave equally likely.
  double LogUniform(double lo, double hi) { return lo * std::exp(std::log(hi / lo) * Uniform()); }
  bool Bernoulli(double p) { return Uniform() < p; }
  double Normal() { return NormalFromBits(Next(), Next()); }

 private:
  uint64_t state_;
};

}  // namespace rrslam::synth
