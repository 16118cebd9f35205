#include "recording/crc32.hpp"

#include <zlib.h>

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define INSALIGN_CRC32_CLMUL 1
#endif

namespace insalign::io::bag {

namespace {

#ifdef INSALIGN_CRC32_CLMUL

constexpr std::size_t kFoldBytes = 64;  // four 128-bit lanes folded in parallel

// One 128-bit lane folded forward by the distance the constants k (low, high 64 bits) encode,
// and the next 16 bytes of data added.
__attribute__((target("pclmul,sse4.1"))) inline __m128i fold(__m128i lane, __m128i k, __m128i next) {
  const __m128i lo = _mm_clmulepi64_si128(lane, k, 0x00);
  const __m128i hi = _mm_clmulepi64_si128(lane, k, 0x11);
  return _mm_xor_si128(_mm_xor_si128(lo, hi), next);
}

// The bit-reflected CRC register (zlib's crc, inverted) over size bytes, size >= 64 and a multiple
// of 16. Constants: x^(T) mod P for the fold distances T of the paper, bit-reflected (the
// polynomial 0x104C11DB7 reflected is 0x1DB710641; mu = floor(x^64 / P) reflected).
__attribute__((target("pclmul,sse4.1"))) std::uint32_t clmul_register(std::uint32_t reg, const std::uint8_t* p,
                                                                       std::size_t size) {
  const __m128i k_512 = _mm_set_epi64x(0x01c6e41596, 0x0154442bd4);  // fold by 4 x 128 bits
  const __m128i k_128 = _mm_set_epi64x(0x00ccaa009e, 0x01751997d0);  // fold by 128 bits
  const __m128i k_64 = _mm_set_epi64x(0, 0x0163cd6124);              // 96 -> 64 bits
  const __m128i poly_mu = _mm_set_epi64x(0x01f7011641, 0x01db710641);
  const auto load = [](const std::uint8_t* q) { return _mm_loadu_si128(reinterpret_cast<const __m128i*>(q)); };
  __m128i a = _mm_xor_si128(load(p), _mm_cvtsi32_si128(static_cast<int>(reg)));
  __m128i b = load(p + 16), c = load(p + 32), d = load(p + 48);
  p += kFoldBytes;
  size -= kFoldBytes;
  for (; size >= kFoldBytes; p += kFoldBytes, size -= kFoldBytes) {
    a = fold(a, k_512, load(p));
    b = fold(b, k_512, load(p + 16));
    c = fold(c, k_512, load(p + 32));
    d = fold(d, k_512, load(p + 48));
  }
  a = fold(fold(fold(a, k_128, b), k_128, c), k_128, d);  // the four lanes into one
  for (; size >= 16; p += 16, size -= 16) a = fold(a, k_128, load(p));
  // 128 -> 96 -> 64 bits, then Barrett reduction to 32 bits.
  const __m128i low32 = _mm_setr_epi32(-1, 0, -1, 0);
  a = _mm_xor_si128(_mm_srli_si128(a, 8), _mm_clmulepi64_si128(a, k_128, 0x10));
  a = _mm_xor_si128(_mm_srli_si128(a, 4), _mm_clmulepi64_si128(_mm_and_si128(a, low32), k_64, 0x00));
  __m128i t = _mm_clmulepi64_si128(_mm_and_si128(a, low32), poly_mu, 0x10);
  t = _mm_clmulepi64_si128(_mm_and_si128(t, low32), poly_mu, 0x00);
  return static_cast<std::uint32_t>(_mm_extract_epi32(_mm_xor_si128(a, t), 1));
}

bool has_clmul() {
  static const bool yes = __builtin_cpu_supports("pclmul") && __builtin_cpu_supports("sse4.1");
  return yes;
}

#endif

}  // namespace

std::uint32_t crc32_ieee_zlib(std::uint32_t crc, const std::uint8_t* data, std::size_t size) {
  return static_cast<std::uint32_t>(::crc32_z(crc, data, size));
}

std::uint32_t crc32_ieee(std::uint32_t crc, const std::uint8_t* data, std::size_t size) {
#ifdef INSALIGN_CRC32_CLMUL
  if (size >= kFoldBytes && has_clmul()) {
    const std::size_t bulk = size & ~std::size_t{15};
    crc = ~clmul_register(~crc, data, bulk);
    data += bulk;
    size -= bulk;
  }
#endif
  return crc32_ieee_zlib(crc, data, size);
}

}  // namespace insalign::io::bag
