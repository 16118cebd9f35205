// The two wire formats of ROS messages, with no ROS installed:
// - ROS 1: little-endian primitives packed with no padding; strings and variable arrays are a
//   uint32 count then the elements (strings without a terminating NUL).
// - CDR (rosbag2, MCAP "cdr"): XCDR1 little-endian after the 4-byte encapsulation header
//   00 01 00 00; every primitive is aligned to its own size (8-byte types to 8), counted from the
//   byte AFTER that header; strings are a uint32 length that includes a terminating NUL.
// MessageReader is a bounds-checked cursor: every overrun is an InputError naming the message and
// the byte offset (counted from the first byte of the message, header included).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "recording/bag_reader.hpp"

namespace insalign::io::bag {

/// A ROS time: ROS 1 `time` (uint32 secs, nsecs) or ROS 2 builtin_interfaces/Time (int32 sec,
/// uint32 nanosec).
struct Stamp {
  std::int64_t sec = 0;
  std::uint32_t nsec = 0;  ///< [0, 1e9)

  double seconds() const { return static_cast<double>(sec) + static_cast<double>(nsec) * 1e-9; }
  std::int64_t nanoseconds() const { return sec * 1'000'000'000 + static_cast<std::int64_t>(nsec); }
  static Stamp from_nanoseconds(std::int64_t t_ns);
  static Stamp from_seconds(double t_s);  ///< rounded to the nearest nanosecond
  bool operator==(const Stamp&) const = default;
};

/// Reads one serialized message. `where` names the message in errors (e.g. "drive.bag /points
/// message 12"), `type` is its ROS type; both appear in every InputError.
class MessageReader {
 public:
  MessageReader(std::span<const std::uint8_t> bytes, MessageEncoding encoding, std::string where, std::string type);
  /// The reader keeps a view of the bytes: a temporary vector would dangle.
  MessageReader(std::vector<std::uint8_t>&&, MessageEncoding, std::string, std::string) = delete;

  MessageEncoding encoding() const { return encoding_; }
  bool cdr() const { return encoding_ == MessageEncoding::kCdr; }
  std::size_t offset() const { return pos_; }  ///< byte index in the message
  std::size_t remaining() const { return bytes_.size() - pos_; }
  /// Nothing left to read (CDR: at most 3 bytes, which a writer may add as final padding).
  bool at_end() const { return remaining() == 0 || (cdr() && remaining() < 4); }
  const std::string& where() const { return where_; }
  const std::string& type() const { return type_; }

  /// CDR: skips padding so that the next byte is aligned to `n` (from after the header). ROS 1: no-op.
  void align(std::size_t n);

  /// An integer or floating-point primitive; `field` names it in errors.
  template <typename T>
  T read(const char* field) {
    static_assert(std::is_arithmetic_v<T> && !std::is_same_v<T, bool>);
    align(sizeof(T));
    need(sizeof(T), field);
    T v;
    std::memcpy(&v, bytes_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  bool read_bool(const char* field);
  std::string read_string(const char* field);
  Stamp read_time(const char* field);
  /// The uint32 element count of a variable-length array; refuses counts whose elements (at least
  /// `min_element_bytes` each) cannot fit in the bytes left.
  std::uint32_t read_length(const char* field, std::size_t min_element_bytes);
  /// `n` raw bytes (uint8[] payloads) as a view into the message: no copy.
  std::span<const std::uint8_t> read_bytes(std::size_t n, const char* field);
  template <typename T, std::size_t N>
  void read_array(std::array<T, N>& out, const char* field) {
    for (T& v : out) v = read<T>(field);
  }
  /// Throws unless at_end(): trailing bytes mean the layout is not the one assumed.
  void expect_end();

  [[noreturn]] void fail(const std::string& problem) const { fail_at(pos_, problem); }
  [[noreturn]] void fail_at(std::size_t offset, const std::string& problem) const;

 private:
  void need(std::size_t n, const char* field) const;

  std::span<const std::uint8_t> bytes_;
  MessageEncoding encoding_;
  std::string where_;
  std::string type_;
  std::size_t pos_ = 0;
  std::size_t origin_ = 0;  ///< where alignment is counted from (CDR: 4)
};

/// Writes one message in either encoding (CDR: the encapsulation header first). Values a format
/// cannot hold (a negative ROS 1 time, a string over 4 GB) throw std::invalid_argument.
class MessageWriter {
 public:
  explicit MessageWriter(MessageEncoding encoding);

  bool cdr() const { return encoding_ == MessageEncoding::kCdr; }
  std::size_t size() const { return buf_.size(); }
  void align(std::size_t n);

  template <typename T>
  void write(T v) {
    static_assert(std::is_arithmetic_v<T> && !std::is_same_v<T, bool>);
    align(sizeof(T));
    const std::size_t at = buf_.size();
    buf_.resize(at + sizeof(T));
    std::memcpy(buf_.data() + at, &v, sizeof(T));
  }
  void write_bool(bool v) { write<std::uint8_t>(v ? 1 : 0); }
  void write_string(std::string_view s);
  void write_time(const Stamp& t);
  void write_length(std::size_t n);
  void write_bytes(std::span<const std::uint8_t> bytes);
  template <typename T, std::size_t N>
  void write_array(const std::array<T, N>& values) {
    for (const T& v : values) write<T>(v);
  }
  /// The message; the writer is empty afterwards.
  std::vector<std::uint8_t> take() { return std::move(buf_); }

 private:
  std::vector<std::uint8_t> buf_;
  MessageEncoding encoding_;
};

}  // namespace insalign::io::bag
