// Seeded random numbers that do not depend on the standard library's distributions (which differ
// between implementations) nor on thread scheduling: a sequential generator for building the
// world and a counter-based hash for per-ray noise.
#pragma once

#include <cmath>
#include <cstdint>
#include <numbers>

#include "core/geometry.hpp"

namespace insalign::sim {

constexpr std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

/// Hash of a tuple of counters: the same inputs give the same number on every thread.
inline std::uint64_t hash_counters(std::uint64_t a, std::uint64_t b, std::uint64_t c = 0, std::uint64_t d = 0) {
  return splitmix64(splitmix64(splitmix64(splitmix64(a) ^ b) ^ c) ^ d);
}

/// Uniform in [0, 1) from 64 random bits.
inline double unit_from_bits(std::uint64_t bits) { return static_cast<double>(bits >> 11) * 0x1.0p-53; }

/// Standard normal from two sets of random bits (Box-Muller).
inline double normal_from_bits(std::uint64_t bits1, std::uint64_t bits2) {
  const double u1 = 1.0 - unit_from_bits(bits1);  // (0, 1]
  const double u2 = unit_from_bits(bits2);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
}

/// Sequential generator (splitmix64 stream).
class Rng {
 public:
  explicit Rng(std::uint64_t seed) : state_(splitmix64(seed ^ 0x5EEDull)) {}
  std::uint64_t bits() { return splitmix64(state_++); }
  double uniform(double lo = 0.0, double hi = 1.0) { return lo + (hi - lo) * unit_from_bits(bits()); }
  int uniform_int(int lo, int hi_inclusive) {
    return lo + static_cast<int>(unit_from_bits(bits()) * (hi_inclusive - lo + 1));
  }
  double normal(double sigma = 1.0) {
    const std::uint64_t a = bits();
    return sigma * normal_from_bits(a, bits());
  }
  Vec3 unit_vector() {
    for (;;) {
      const Vec3 v(uniform(-1, 1), uniform(-1, 1), uniform(-1, 1));
      const double n = v.norm();
      if (n > 1e-3 && n <= 1.0) return v / n;
    }
  }

 private:
  std::uint64_t state_;
};

}  // namespace insalign::sim
