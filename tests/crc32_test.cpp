// The carry-less-multiply CRC-32 against zlib's on every length and alignment it treats apart
// (the 64-byte folds, the 16-byte tail, the bytes zlib finishes), continued in pieces as the MCAP
// writer does, and the standard check value.
#include "recording/crc32.hpp"

#include <gtest/gtest.h>

#include <random>
#include <string_view>
#include <vector>

namespace insalign::io::bag {
namespace {

std::vector<std::uint8_t> random_bytes(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> byte(0, 255);
  std::vector<std::uint8_t> out(n);
  for (auto& b : out) b = static_cast<std::uint8_t>(byte(rng));
  return out;
}

TEST(Crc32, CheckValue) {
  const std::string_view check = "123456789";
  EXPECT_EQ(crc32_ieee(0, reinterpret_cast<const std::uint8_t*>(check.data()), check.size()), 0xCBF43926u);
  const std::vector<std::uint8_t> zeros(4096, 0);
  EXPECT_EQ(crc32_ieee(0, zeros.data(), zeros.size()), crc32_ieee_zlib(0, zeros.data(), zeros.size()));
}

TEST(Crc32, EveryLengthAndAlignmentMatchesZlib) {
  const std::vector<std::uint8_t> data = random_bytes(1200, 1);
  for (std::size_t offset = 0; offset < 17; ++offset) {
    for (std::size_t n = 0; n + offset <= data.size(); n += (n < 300 ? 1 : 37)) {
      const std::uint8_t* p = data.data() + offset;
      ASSERT_EQ(crc32_ieee(0, p, n), crc32_ieee_zlib(0, p, n)) << "offset " << offset << ", " << n << " bytes";
      ASSERT_EQ(crc32_ieee(0xDEADBEEF, p, n), crc32_ieee_zlib(0xDEADBEEF, p, n)) << "offset " << offset << ", " << n;
    }
  }
}

TEST(Crc32, ChunkSizedBufferInPiecesMatchesZlibWhole) {
  const std::vector<std::uint8_t> data = random_bytes(5'500'001, 2);
  const std::uint32_t whole = crc32_ieee_zlib(0, data.data(), data.size());
  EXPECT_EQ(crc32_ieee(0, data.data(), data.size()), whole);
  std::uint32_t pieces = 0;
  for (std::size_t at = 0, step = 1; at < data.size(); at += step, step = step * 3 + 1) {
    pieces = crc32_ieee(pieces, data.data() + at, std::min(step, data.size() - at));
  }
  EXPECT_EQ(pieces, whole);
}

}  // namespace
}  // namespace insalign::io::bag
