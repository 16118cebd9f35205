#include "recording/ros_serialization.hpp"

#include <cmath>
#include <fmt/format.h>
#include <limits>
#include <stdexcept>

#include "core/errors.hpp"

namespace insalign::io::bag {

namespace {

constexpr std::size_t kCdrHeaderBytes = 4;
constexpr std::int64_t kNsPerS = 1'000'000'000;

// The representation identifier (first two bytes, big-endian by definition) of the CDR header.
std::string representation_problem(std::uint16_t id) {
  switch (id) {
    case 0x0000: return "big-endian CDR (encapsulation 00 00) is not supported";
    case 0x0002:
    case 0x0003: return "parameter-list CDR (PL_CDR) is not supported";
    default:
      return fmt::format("unsupported CDR encapsulation {:02x} {:02x} (only plain little-endian CDR, 00 01, is read)",
                         id >> 8, id & 0xff);
  }
}

}  // namespace

Stamp Stamp::from_nanoseconds(std::int64_t t_ns) {
  std::int64_t sec = t_ns / kNsPerS;
  std::int64_t rem = t_ns % kNsPerS;
  if (rem < 0) rem += kNsPerS, --sec;
  return {sec, static_cast<std::uint32_t>(rem)};
}

Stamp Stamp::from_seconds(double t_s) {
  const double sec = std::floor(t_s);
  auto nsec = static_cast<std::int64_t>(std::llround((t_s - sec) * 1e9));
  auto whole = static_cast<std::int64_t>(sec);
  if (nsec >= kNsPerS) nsec -= kNsPerS, ++whole;
  return {whole, static_cast<std::uint32_t>(nsec)};
}

// ---------------------------------------------------------------------------------------- reader

MessageReader::MessageReader(std::span<const std::uint8_t> bytes, MessageEncoding encoding, std::string where,
                             std::string type)
    : bytes_(bytes), encoding_(encoding), where_(std::move(where)), type_(std::move(type)) {
  if (!cdr()) return;
  if (bytes_.size() < kCdrHeaderBytes) {
    fail_at(0, fmt::format("{} bytes: shorter than the 4-byte CDR encapsulation header", bytes_.size()));
  }
  const auto id = static_cast<std::uint16_t>((bytes_[0] << 8) | bytes_[1]);
  if (id != 0x0001) fail_at(0, representation_problem(id));
  // Bytes 2-3 are options (some writers note the final padding there); nothing to do with them.
  pos_ = origin_ = kCdrHeaderBytes;
}

void MessageReader::align(std::size_t n) {
  if (!cdr() || n <= 1) return;
  const std::size_t misalign = (pos_ - origin_) % n;
  if (misalign == 0) return;
  const std::size_t pad = n - misalign;
  if (pad > remaining()) {
    fail(fmt::format("{} bytes of CDR alignment padding needed, {} left (truncated message?)", pad, remaining()));
  }
  pos_ += pad;
}

void MessageReader::need(std::size_t n, const char* field) const {
  if (n > remaining()) {
    fail(fmt::format("'{}' needs {} bytes, {} left (truncated message, or a different message layout)", field, n,
                     remaining()));
  }
}

bool MessageReader::read_bool(const char* field) {
  need(1, field);
  const std::uint8_t v = bytes_[pos_];
  if (v > 1) fail(fmt::format("'{}' is a bool but holds {}", field, v));
  ++pos_;
  return v == 1;
}

std::string MessageReader::read_string(const char* field) {
  const std::size_t at = pos_;
  const std::uint32_t length = read<std::uint32_t>(field);
  if (length > remaining()) {
    fail_at(at, fmt::format("string '{}' claims {} bytes, {} left", field, length, remaining()));
  }
  const char* chars = reinterpret_cast<const char*>(bytes_.data() + pos_);
  pos_ += length;
  if (!cdr() || length == 0) return std::string(chars, length);  // some CDR writers give "" as length 0
  if (chars[length - 1] != '\0') {
    fail_at(at, fmt::format("CDR string '{}' of {} bytes does not end in NUL (misaligned read?)", field, length));
  }
  return std::string(chars, length - 1);
}

Stamp MessageReader::read_time(const char* field) {
  Stamp t;
  t.sec = cdr() ? static_cast<std::int64_t>(read<std::int32_t>(field)) : static_cast<std::int64_t>(read<std::uint32_t>(field));
  const std::uint32_t nsec = read<std::uint32_t>(field);
  // A few writers leave nsec >= 1e9; carry it rather than refuse the message.
  t.sec += nsec / kNsPerS;
  t.nsec = static_cast<std::uint32_t>(nsec % kNsPerS);
  return t;
}

std::uint32_t MessageReader::read_length(const char* field, std::size_t min_element_bytes) {
  const std::size_t at = pos_;
  const std::uint32_t n = read<std::uint32_t>(field);
  if (min_element_bytes > 0 && n > remaining() / min_element_bytes) {
    fail_at(at, fmt::format("array '{}' claims {} elements of at least {} bytes, {} bytes left", field, n,
                            min_element_bytes, remaining()));
  }
  return n;
}

std::span<const std::uint8_t> MessageReader::read_bytes(std::size_t n, const char* field) {
  need(n, field);
  const auto out = bytes_.subspan(pos_, n);
  pos_ += n;
  return out;
}

void MessageReader::expect_end() {
  if (!at_end()) {
    fail(fmt::format("{} bytes left after the last field (not the layout insalign reads: a different version "
                     "or a custom fork of the message?)",
                     remaining()));
  }
}

void MessageReader::fail_at(std::size_t offset, const std::string& problem) const {
  throw InputError(where_, "byte " + std::to_string(offset), type_ + ": " + problem);
}

// ---------------------------------------------------------------------------------------- writer

MessageWriter::MessageWriter(MessageEncoding encoding) : encoding_(encoding) {
  if (cdr()) buf_ = {0x00, 0x01, 0x00, 0x00};
}

void MessageWriter::align(std::size_t n) {
  if (!cdr() || n <= 1) return;
  const std::size_t misalign = (buf_.size() - 4) % n;
  if (misalign != 0) buf_.resize(buf_.size() + n - misalign, 0);
}

void MessageWriter::write_string(std::string_view s) {
  const std::size_t length = s.size() + (cdr() ? 1 : 0);
  if (length > std::numeric_limits<std::uint32_t>::max()) throw std::invalid_argument("string longer than 4 GB");
  write<std::uint32_t>(static_cast<std::uint32_t>(length));
  buf_.insert(buf_.end(), s.begin(), s.end());
  if (cdr()) buf_.push_back(0);
}

void MessageWriter::write_time(const Stamp& t) {
  if (cdr()) {
    if (t.sec < std::numeric_limits<std::int32_t>::min() || t.sec > std::numeric_limits<std::int32_t>::max()) {
      throw std::invalid_argument("time " + std::to_string(t.sec) + " s does not fit builtin_interfaces/Time");
    }
    write<std::int32_t>(static_cast<std::int32_t>(t.sec));
  } else {
    if (t.sec < 0 || t.sec > std::numeric_limits<std::uint32_t>::max()) {
      throw std::invalid_argument("time " + std::to_string(t.sec) + " s does not fit a ROS 1 time");
    }
    write<std::uint32_t>(static_cast<std::uint32_t>(t.sec));
  }
  write<std::uint32_t>(t.nsec);
}

void MessageWriter::write_length(std::size_t n) {
  if (n > std::numeric_limits<std::uint32_t>::max()) throw std::invalid_argument("array longer than 2^32 elements");
  write<std::uint32_t>(static_cast<std::uint32_t>(n));
}

void MessageWriter::write_bytes(std::span<const std::uint8_t> bytes) {
  buf_.insert(buf_.end(), bytes.begin(), bytes.end());
}

}  // namespace insalign::io::bag
