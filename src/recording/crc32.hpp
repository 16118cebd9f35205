// CRC-32 (IEEE 802.3, reflected, as zlib's crc32 and MCAP's chunk CRCs). On x86-64 CPUs with
// PCLMULQDQ the bulk of the data is folded 64 bytes at a time with carry-less multiplications
// (Intel, "Fast CRC Computation for Generic Polynomials Using PCLMULQDQ Instruction", 2009):
// about 10x zlib's table-driven crc32 on a point-cloud chunk, where zlib's was the top symbol of a
// run on an MCAP recording. Elsewhere (and for the tail) zlib's crc32.
#pragma once

#include <cstddef>
#include <cstdint>

namespace insalign::io::bag {

/// The CRC continued over `size` more bytes; start with crc32_ieee(0, ...). Same value as zlib's
/// crc32_z(crc, data, size).
std::uint32_t crc32_ieee(std::uint32_t crc, const std::uint8_t* data, std::size_t size);

/// zlib's table-driven crc32 alone (the reference the tests and benchmarks compare with).
std::uint32_t crc32_ieee_zlib(std::uint32_t crc, const std::uint8_t* data, std::size_t size);

}  // namespace insalign::io::bag
