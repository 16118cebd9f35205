#include "pointcloud/pcd.hpp"

#include <lzf.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fmt/format.h>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string_view>

#include "core/errors.hpp"
#include "files/atomic_file.hpp"

namespace insalign::io {

namespace {

// Guards against headers that would make us allocate absurd amounts before noticing the lie.
constexpr std::size_t kMaxPoints = std::size_t{1} << 31;
constexpr int kMaxCount = 1 << 16;
constexpr std::size_t kHeaderProbeBytes = 64 * 1024;
constexpr std::size_t kMaxLzfExpansion = 88;  // 264 output bytes from one 3-byte back-reference

std::string at_line(std::size_t line) { return "line " + std::to_string(line); }
std::string at_byte(std::size_t byte) { return "byte " + std::to_string(byte); }

std::vector<std::string_view> split_ws(std::string_view s) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && (s[i] == ' ' || s[i] == '\t' || s[i] == '\r')) ++i;
    std::size_t j = i;
    while (j < s.size() && s[j] != ' ' && s[j] != '\t' && s[j] != '\r') ++j;
    if (j > i) out.push_back(s.substr(i, j - i));
    i = j;
  }
  return out;
}

std::string upper(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return out;
}

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

bool parse_size(std::string_view s, std::size_t& out) {
  const char* end = s.data() + s.size();
  auto [ptr, ec] = std::from_chars(s.data(), end, out);
  return ec == std::errc() && ptr == end;
}

bool parse_int(std::string_view s, int& out) {
  const char* end = s.data() + s.size();
  auto [ptr, ec] = std::from_chars(s.data(), end, out);
  return ec == std::errc() && ptr == end;
}

// Scratch memory of one thread, reused from sweep to sweep: fresh multi-megabyte buffers per
// file cost more in page faults and zeroing than the decoding itself (measured: 7 of 10 ms per
// Pandar64 sweep). Buffers beyond kKeepBytes are given back after use.
constexpr std::size_t kKeepBytes = std::size_t{64} << 20;
struct Scratch {
  std::unique_ptr<char[]> bytes;
  std::size_t capacity = 0;
  char* get(std::size_t n) {
    if (n > capacity) {
      capacity = std::max(n, capacity + capacity / 2);
      bytes.reset(new char[capacity]);  // not zeroed: every byte used is written first
    }
    return bytes.get();
  }
  void trim() {
    if (capacity > kKeepBytes) bytes.reset(), capacity = 0;
  }
};
thread_local Scratch file_scratch, raw_scratch, time_scratch;

// Opens the file and says how many bytes to read: its size, at most limit. Throws InputError.
std::FILE* open_for_read(const std::filesystem::path& path, std::size_t limit, std::size_t& want) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    throw InputError(path.string(), "", std::filesystem::exists(path, ec) ? "not a regular file" : "file not found");
  }
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec) throw InputError(path.string(), "", "cannot read its size: " + ec.message());
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) throw InputError(path.string(), "", std::string("cannot open: ") + std::strerror(errno));
  want = static_cast<std::size_t>(std::min<std::uintmax_t>(size, limit));
  return f;
}

// The file's first `limit` bytes.
std::string read_bytes(const std::filesystem::path& path, std::size_t limit) {
  std::size_t want = 0;
  std::FILE* f = open_for_read(path, limit, want);
  std::string buf(want, '\0');
  const std::size_t got = std::fread(buf.data(), 1, want, f);
  std::fclose(f);
  buf.resize(got);
  return buf;
}

// The whole file, in this thread's scratch buffer (valid until the next read on the thread).
std::string_view read_all(const std::filesystem::path& path, Scratch& scratch) {
  std::size_t want = 0;
  std::FILE* f = open_for_read(path, std::numeric_limits<std::size_t>::max(), want);
  char* buf = scratch.get(std::max<std::size_t>(want, 1));
  const std::size_t got = std::fread(buf, 1, want, f);
  std::fclose(f);
  return {buf, got};
}

// The header's lines as written, before their consistency is checked.
struct RawHeader {
  std::vector<std::string> names;
  std::vector<int> sizes, counts;
  std::vector<char> types;
  std::size_t width = 0, height = 0, points = 0;
  bool have_width = false, have_height = false, have_points = false, have_data = false;
  std::string data;
  std::size_t points_line = 0, fields_line = 0;
};

// Each value of a list line through `parse`, which says whether it is valid.
template <class T, class Parse>
void parse_list(const std::vector<std::string_view>& values, std::vector<T>& out, Parse&& parse,
                const std::string& file, std::size_t line_no, const std::string& rule) {
  for (auto v : values) {
    T x{};
    if (!parse(v, x)) throw InputError(file, at_line(line_no), rule + ", got '" + std::string(v) + "'");
    out.push_back(x);
  }
}

// One header line (KEY values...) into `raw`.
void parse_header_line(std::string_view key_token, const std::vector<std::string_view>& values, const std::string& file,
                       std::size_t line_no, RawHeader& raw) {
  const std::string key = upper(key_token);
  if (key == "VERSION" || key == "VIEWPOINT") return;
  const bool list = key == "FIELDS" || key == "COLUMNS" || key == "SIZE" || key == "TYPE" || key == "COUNT";
  if (list && values.empty()) throw InputError(file, at_line(line_no), key + " has no values");
  if (key == "FIELDS" || key == "COLUMNS") {
    raw.fields_line = line_no;
    for (auto v : values) raw.names.emplace_back(v);
  } else if (key == "SIZE") {
    parse_list(values, raw.sizes, [](std::string_view v, int& s) { return parse_int(v, s) && (s == 1 || s == 2 || s == 4 || s == 8); },
               file, line_no, "SIZE must be 1, 2, 4 or 8");
  } else if (key == "TYPE") {
    parse_list(values, raw.types, [](std::string_view v, char& t) {
                 t = v.size() == 1 ? static_cast<char>(std::toupper(static_cast<unsigned char>(v[0]))) : '?';
                 return t == 'F' || t == 'U' || t == 'I';
               }, file, line_no, "TYPE must be F, U or I");
  } else if (key == "COUNT") {
    parse_list(values, raw.counts, [](std::string_view v, int& c) { return parse_int(v, c) && c >= 1 && c <= kMaxCount; },
               file, line_no, "COUNT must be a positive integer");
  } else if (key == "WIDTH" || key == "HEIGHT" || key == "POINTS") {
    std::size_t n = 0;
    if (values.size() != 1 || !parse_size(values[0], n) || n > kMaxPoints)
      throw InputError(file, at_line(line_no), key + " must be one non-negative integer");
    if (key == "WIDTH") raw.width = n, raw.have_width = true;
    if (key == "HEIGHT") raw.height = n, raw.have_height = true;
    if (key == "POINTS") raw.points = n, raw.have_points = true, raw.points_line = line_no;
  } else if (key == "DATA") {
    if (values.size() != 1) throw InputError(file, at_line(line_no), "DATA needs exactly one value");
    raw.data = lower(values[0]);
    if (raw.data != "ascii" && raw.data != "binary" && raw.data != "binary_compressed")
      throw InputError(file, at_line(line_no),
                       "DATA must be ascii, binary or binary_compressed, got '" + std::string(values[0]) + "'");
    raw.have_data = true;
  } else {
    throw InputError(file, at_line(line_no), "unknown header key '" + std::string(key_token) + "' (not a PCD file?)");
  }
}

// FIELDS, SIZE, TYPE and COUNT into h.fields with their offsets; x, y, z must be there.
void build_fields(RawHeader& raw, const std::string& file, std::size_t last_line, PcdHeader& h) {
  if (raw.names.empty()) throw InputError(file, at_line(last_line), "header has no FIELDS line");
  if (raw.counts.empty()) raw.counts.assign(raw.names.size(), 1);
  const std::size_t n = raw.names.size();
  if (raw.sizes.size() != n || raw.types.size() != n || raw.counts.size() != n) {
    throw InputError(file, at_line(raw.fields_line),
                     fmt::format("FIELDS has {} entries but SIZE has {}, TYPE {}, COUNT {}", n, raw.sizes.size(),
                                 raw.types.size(), raw.counts.size()));
  }
  std::size_t offset = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (raw.types[i] == 'F' && raw.sizes[i] != 4 && raw.sizes[i] != 8) {
      throw InputError(file, at_line(raw.fields_line), "field '" + raw.names[i] + "' is a float of size " +
                                                           std::to_string(raw.sizes[i]) + " (must be 4 or 8)");
    }
    h.fields.push_back({raw.names[i], raw.sizes[i], raw.types[i], raw.counts[i], offset});
    offset += static_cast<std::size_t>(raw.sizes[i]) * static_cast<std::size_t>(raw.counts[i]);
  }
  h.point_bytes = offset;
  for (const char* axis : {"x", "y", "z"}) {
    const PcdHeader::Field* f = h.find(axis);
    if (f == nullptr) throw InputError(file, at_line(raw.fields_line), std::string("no '") + axis + "' field");
    if (f->count != 1) throw InputError(file, at_line(raw.fields_line), std::string("field '") + axis + "' has COUNT > 1");
  }
}

// POINTS, WIDTH and HEIGHT into one consistent point count.
void resolve_point_count(const RawHeader& raw, const std::string& file, std::size_t last_line, PcdHeader& h) {
  h.width = raw.width, h.height = raw.height, h.points = raw.points;
  if (!raw.have_points) {
    if (!raw.have_width) throw InputError(file, at_line(last_line), "header has neither POINTS nor WIDTH");
    h.points = h.width * (raw.have_height ? h.height : 1);
    if (h.points > kMaxPoints) throw InputError(file, at_line(last_line), "WIDTH x HEIGHT is implausibly large");
  } else if (raw.have_width && raw.have_height && h.width * h.height != h.points) {
    throw InputError(file, at_line(raw.points_line),
                     fmt::format("POINTS {} disagrees with WIDTH {} x HEIGHT {}", h.points, h.width, h.height));
  }
  if (!raw.have_width) h.width = h.points;
  if (!raw.have_height) h.height = 1;
}

PcdHeader parse_header(std::string_view buf, const std::string& file) {
  if (buf.empty()) throw InputError(file, "byte 0", "empty file");
  RawHeader raw;
  std::size_t pos = 0, line_no = 0;
  while (pos < buf.size() && !raw.have_data) {
    std::size_t nl = buf.find('\n', pos);
    const bool last = nl == std::string_view::npos;
    if (last) nl = buf.size();
    const std::string_view line = buf.substr(pos, nl - pos);
    ++line_no;
    pos = last ? buf.size() : nl + 1;
    // A header line is short text; a NUL or other binary here means the header is cut off.
    if (line.find('\0') != std::string_view::npos)
      throw InputError(file, at_line(line_no), "binary data inside the header (truncated or not a PCD)");
    const auto tok = split_ws(line);
    if (tok.empty() || tok[0].front() == '#') continue;
    parse_header_line(tok[0], std::vector<std::string_view>(tok.begin() + 1, tok.end()), file, line_no, raw);
  }
  if (!raw.have_data) {
    throw InputError(file, at_line(line_no), "header ends without a DATA line (truncated or not a PCD file)");
  }
  PcdHeader h;
  h.data = raw.data;
  h.header_bytes = pos;
  h.header_lines = line_no;
  build_fields(raw, file, line_no, h);
  resolve_point_count(raw, file, line_no, h);
  return h;
}

enum class TimeKind { kNone, kAbsolute, kRelativeS, kRelativeNs };

struct Layout {
  const PcdHeader::Field *x, *y, *z, *intensity, *ring, *time;
  TimeKind time_kind = TimeKind::kNone;
};

Layout layout_of(const PcdHeader& h) {
  Layout l{h.find("x"), h.find("y"), h.find("z"), h.find("intensity"), h.find("ring"), nullptr};
  if (l.intensity != nullptr && l.intensity->count != 1) l.intensity = nullptr;
  if (l.ring != nullptr && l.ring->count != 1) l.ring = nullptr;
  const std::pair<const char*, TimeKind> candidates[] = {
      {"timestamp", TimeKind::kAbsolute}, {"time", TimeKind::kRelativeS}, {"t", TimeKind::kRelativeNs}};
  for (const auto& [name, kind] : candidates) {
    const PcdHeader::Field* f = h.find(name);
    if (f != nullptr && f->count == 1) {
      l.time = f;
      l.time_kind = kind;
      break;
    }
  }
  return l;
}

// Where one field's values sit: the first at `base`, the next `stride` bytes on. Binary data
// is an array of structs (stride = point size), binary_compressed one block per field (stride =
// element size), ascii is parsed into rows of doubles first.
struct Column {
  const char* base = nullptr;
  std::size_t stride = 0;
  char type = 'F';
  int size = 4;
};

// Calls f(i, value) for the n values of one column, each in its stored type; the type switch
// runs once per column, not once per value.
template <typename T, typename F>
void each_as(const Column& c, std::size_t n, F& f) {
  for (std::size_t i = 0; i < n; ++i) {
    T v;
    std::memcpy(&v, c.base + i * c.stride, sizeof(T));
    f(i, v);
  }
}
template <typename F>
void each_value(const Column& c, std::size_t n, F&& f) {
  switch (c.type == 'F' ? c.size * 10 : c.type == 'I' ? c.size * 100 : c.size) {
    case 40: each_as<float>(c, n, f); break;
    case 80: each_as<double>(c, n, f); break;
    case 100: each_as<std::int8_t>(c, n, f); break;
    case 200: each_as<std::int16_t>(c, n, f); break;
    case 400: each_as<std::int32_t>(c, n, f); break;
    case 800: each_as<std::int64_t>(c, n, f); break;
    case 1: each_as<std::uint8_t>(c, n, f); break;
    case 2: each_as<std::uint16_t>(c, n, f); break;
    case 4: each_as<std::uint32_t>(c, n, f); break;
    default: each_as<std::uint64_t>(c, n, f); break;
  }
}

// Fills the sweep straight from the columns, dropping non-finite points, and sets the times.
template <typename Locate>
void fill_sweep(Sweep& sweep, std::size_t n, const Layout& l, Locate&& locate, PcdInfo& info) {
  static_assert(sizeof(Vec3f) == 3 * sizeof(float));
  sweep.p_lidar.resize(n);
  for (int axis = 0; axis < 3; ++axis) {
    each_value(locate(axis == 0 ? l.x : axis == 1 ? l.y : l.z), n,
               [&](std::size_t i, auto v) { sweep.p_lidar[i][axis] = static_cast<float>(v); });
  }
  if (l.intensity) {
    sweep.intensity.resize(n);
    each_value(locate(l.intensity), n, [&](std::size_t i, auto v) { sweep.intensity[i] = static_cast<float>(v); });
  }
  if (l.ring) {
    sweep.ring.resize(n);
    each_value(locate(l.ring), n, [&](std::size_t i, auto v) {
      // A NaN ring (float field or "nan" in ascii) has no channel; casting it would be undefined.
      const double r = static_cast<double>(v);
      sweep.ring[i] = std::isfinite(r) ? static_cast<std::uint16_t>(std::clamp(r, 0.0, 65535.0)) : 0;
    });
  }
  double* t = l.time ? reinterpret_cast<double*>(time_scratch.get(n * sizeof(double))) : nullptr;
  if (l.time) {
    const double scale = l.time_kind == TimeKind::kRelativeNs ? 1e-9 : 1.0;
    each_value(locate(l.time), n, [&](std::size_t i, auto v) { t[i] = static_cast<double>(v) * scale; });
  }
  std::size_t kept = 0;
  double t_max = -std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < n; ++i) {
    if (!sweep.p_lidar[i].allFinite() || (t != nullptr && !std::isfinite(t[i]))) continue;
    sweep.p_lidar[kept] = sweep.p_lidar[i];
    if (l.intensity) sweep.intensity[kept] = sweep.intensity[i];
    if (l.ring) sweep.ring[kept] = sweep.ring[i];
    if (t != nullptr) t[kept] = t[i], t_max = std::max(t_max, t[i]);
    ++kept;
  }
  info.dropped_nonfinite = n - kept;
  sweep.p_lidar.resize(kept);
  if (l.intensity) sweep.intensity.resize(kept);
  if (l.ring) sweep.ring.resize(kept);
  sweep.t_end_s = std::numeric_limits<double>::quiet_NaN();
  if (t != nullptr && kept > 0) {
    sweep.dt_s.resize(kept);
    for (std::size_t i = 0; i < kept; ++i) sweep.dt_s[i] = static_cast<float>(t[i] - t_max);
    if (l.time_kind == TimeKind::kAbsolute) sweep.t_end_s = t_max;
  }
  time_scratch.trim();
}

void read_ascii(Sweep& sweep, const PcdHeader& h, std::string_view data, const std::string& file, PcdInfo& info) {
  // Parse every line into a row of doubles (one per element), then read columns from the rows.
  std::size_t elements = 0;
  std::vector<std::size_t> first_element(h.fields.size());
  for (std::size_t f = 0; f < h.fields.size(); ++f) {
    first_element[f] = elements;
    elements += static_cast<std::size_t>(h.fields[f].count);
  }
  // Each value takes at least one character and a separator, so the data bounds the reservation
  // however large POINTS and COUNT claim to be.
  std::vector<double> values;
  values.reserve(std::min(h.points * elements, data.size() / 2 + 1));
  std::size_t pos = 0, line_no = h.header_lines, rows = 0;
  while (pos < data.size()) {
    std::size_t nl = data.find('\n', pos);
    if (nl == std::string_view::npos) nl = data.size();
    const std::string_view line = data.substr(pos, nl - pos);
    pos = nl + 1;
    ++line_no;
    const auto tok = split_ws(line);
    if (tok.empty()) continue;
    if (rows == h.points) {
      throw InputError(file, at_line(line_no), fmt::format("more data lines than POINTS {}", h.points));
    }
    if (tok.size() != elements) {
      throw InputError(file, at_line(line_no), fmt::format("expected {} values, found {}", elements, tok.size()));
    }
    for (std::string_view v : tok) {
      double d = 0.0;
      if (!v.empty() && v.front() == '+') v.remove_prefix(1);
      const char* end = v.data() + v.size();
      auto [ptr, ec] = std::from_chars(v.data(), end, d);
      if (ec == std::errc::result_out_of_range && ptr == end) {
        d = std::numeric_limits<double>::infinity();  // dropped as non-finite
      } else if (ec != std::errc() || ptr != end) {
        throw InputError(file, at_line(line_no), "not a number: '" + std::string(v) + "'");
      }
      values.push_back(d);
    }
    ++rows;
  }
  if (rows != h.points) {
    throw InputError(file, at_line(line_no),
                     fmt::format("truncated: POINTS says {} but the file has {} data lines", h.points, rows));
  }
  const auto locate = [&](const PcdHeader::Field* f) {
    const std::size_t k = first_element[static_cast<std::size_t>(f - h.fields.data())];
    return Column{reinterpret_cast<const char*>(values.data() + k), elements * sizeof(double), 'F', 8};
  };
  fill_sweep(sweep, rows, layout_of(h), locate, info);
}

void read_binary(Sweep& sweep, const PcdHeader& h, std::string_view data, const std::string& file,
                 PcdInfo& info) {
  const std::size_t need = h.points * h.point_bytes;
  if (data.size() < need) {
    throw InputError(file, at_byte(h.header_bytes + data.size()),
                     fmt::format("truncated: {} points of {} bytes need {} data bytes, the file has {}", h.points,
                                 h.point_bytes, need, data.size()));
  }
  const auto locate = [&](const PcdHeader::Field* f) {
    return Column{data.data() + f->offset, h.point_bytes, f->type, f->size};
  };
  fill_sweep(sweep, h.points, layout_of(h), locate, info);
}

void read_binary_compressed(Sweep& sweep, const PcdHeader& h, std::string_view data, const std::string& file,
                            PcdInfo& info) {
  if (data.size() < 8) {
    throw InputError(file, at_byte(h.header_bytes + data.size()), "truncated: missing the compressed-size words");
  }
  std::uint32_t compressed = 0, uncompressed = 0;
  std::memcpy(&compressed, data.data(), 4);
  std::memcpy(&uncompressed, data.data() + 4, 4);
  const std::size_t need = h.points * h.point_bytes;
  if (uncompressed != need) {
    throw InputError(file, at_byte(h.header_bytes + 4),
                     fmt::format("uncompressed size {} does not match {} points of {} bytes ({})", uncompressed,
                                 h.points, h.point_bytes, need));
  }
  // An LZF back-reference expands 3 bytes into at most 264, so no valid block inflates more than
  // 88 times; refuse before allocating what a lying header asks for.
  if (need > std::size_t{compressed} * kMaxLzfExpansion) {
    throw InputError(file, at_byte(h.header_bytes),
                     fmt::format("corrupt LZF block: {} compressed bytes cannot hold {} uncompressed bytes",
                                 compressed, need));
  }
  if (compressed > data.size() - 8) {
    throw InputError(file, at_byte(h.header_bytes + data.size()),
                     fmt::format("truncated: compressed block of {} bytes, only {} in the file", compressed,
                                 data.size() - 8));
  }
  char* raw = raw_scratch.get(std::max<std::size_t>(need, 1));
  if (need > 0) {
    const unsigned int got = lzf_decompress(data.data() + 8, compressed, raw, static_cast<unsigned int>(need));
    if (got != need) {
      throw InputError(file, at_byte(h.header_bytes + 8),
                       fmt::format("corrupt LZF block: decompressed {} of {} bytes", got, need));
    }
  }
  // binary_compressed stores one block per field: field f starts at points * offset(f).
  const auto locate = [&](const PcdHeader::Field* f) {
    return Column{raw + h.points * f->offset, static_cast<std::size_t>(f->size) * f->count, f->type, f->size};
  };
  fill_sweep(sweep, h.points, layout_of(h), locate, info);
  raw_scratch.trim();
}

}  // namespace

const PcdHeader::Field* PcdHeader::find(const std::string& name) const {
  for (const Field& f : fields) {
    if (f.name == name) return &f;
  }
  return nullptr;
}

PcdHeader read_pcd_header(const std::filesystem::path& path) {
  // Headers are a few hundred bytes: 4 KB first (a folder's every header is read at load, and
  // 64 KB a file was most of that cost); the whole probe only when the header is not done by then.
  constexpr std::size_t kFirstBytes = 4096;
  const std::string first = read_bytes(path, kFirstBytes);
  if (first.size() < kFirstBytes) return parse_header(first, path.string());
  try {
    const PcdHeader h = parse_header(first, path.string());
    if (h.header_bytes < first.size()) return h;  // the DATA line ended inside: not cut short
  } catch (const InputError&) {
  }
  return parse_header(read_bytes(path, kHeaderProbeBytes), path.string());
}

Sweep read_pcd(const std::filesystem::path& path, PcdInfo* info_out) {
  const std::string file = path.string();
  const std::string_view buf = read_all(path, file_scratch);
  const PcdHeader h = parse_header(buf.substr(0, std::min(buf.size(), kHeaderProbeBytes)), file);
  const std::string_view data = buf.substr(h.header_bytes);
  PcdInfo info;
  info.points = h.points;
  info.data_encoding = h.data;
  Sweep sweep;
  sweep.name = path.stem().string();
  if (h.data == "ascii") {
    read_ascii(sweep, h, data, file, info);
  } else if (h.data == "binary") {
    read_binary(sweep, h, data, file, info);
  } else {
    read_binary_compressed(sweep, h, data, file, info);
  }
  const Layout l = layout_of(h);
  info.time_field = l.time ? l.time->name : "";
  if (info_out) *info_out = info;
  file_scratch.trim();
  return sweep;
}

namespace {

enum class OutKind { kX, kY, kZ, kIntensity, kRing, kTimestamp, kTime };
struct OutField {
  const char* name;
  int size;
  char type;
  OutKind kind;
};

std::vector<OutField> out_fields(const Sweep& sweep, PcdTimeField time_field) {
  std::vector<OutField> fields = {{"x", 4, 'F', OutKind::kX}, {"y", 4, 'F', OutKind::kY}, {"z", 4, 'F', OutKind::kZ}};
  if (!sweep.intensity.empty()) fields.push_back({"intensity", 4, 'F', OutKind::kIntensity});
  if (!sweep.ring.empty()) fields.push_back({"ring", 2, 'U', OutKind::kRing});
  if (time_field == PcdTimeField::kAbsolute) fields.push_back({"timestamp", 8, 'F', OutKind::kTimestamp});
  if (time_field == PcdTimeField::kRelative) fields.push_back({"time", 4, 'F', OutKind::kTime});
  return fields;
}

std::string header_text(const std::vector<OutField>& fields, std::size_t n, PcdEncoding encoding) {
  std::string out = "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS";
  for (const auto& f : fields) fmt::format_to(std::back_inserter(out), " {}", f.name);
  out += "\nSIZE";
  for (const auto& f : fields) fmt::format_to(std::back_inserter(out), " {}", f.size);
  out += "\nTYPE";
  for (const auto& f : fields) fmt::format_to(std::back_inserter(out), " {}", f.type);
  out += "\nCOUNT";
  for (std::size_t i = 0; i < fields.size(); ++i) out += " 1";
  const char* data_name = encoding == PcdEncoding::kAscii    ? "ascii"
                          : encoding == PcdEncoding::kBinary ? "binary"
                                                             : "binary_compressed";
  out += fmt::format("\nWIDTH {}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {}\nDATA {}\n", n, n, data_name);
  return out;
}

// Field f of point i, as its bytes, at dst.
void put_field(const Sweep& sweep, const OutField& f, std::size_t i, char* dst) {
  switch (f.kind) {
    case OutKind::kX: case OutKind::kY: case OutKind::kZ: {
      const float v = sweep.p_lidar[i][static_cast<Eigen::Index>(f.kind)];
      std::memcpy(dst, &v, 4);
      break;
    }
    case OutKind::kIntensity: std::memcpy(dst, &sweep.intensity[i], 4); break;
    case OutKind::kRing: std::memcpy(dst, &sweep.ring[i], 2); break;
    case OutKind::kTimestamp: {
      const double v = sweep.t_end_s + static_cast<double>(sweep.dt_s[i]);
      std::memcpy(dst, &v, 8);
      break;
    }
    case OutKind::kTime: std::memcpy(dst, &sweep.dt_s[i], 4); break;
  }
}

void append_ascii(const Sweep& sweep, PcdTimeField time_field, std::string& out) {
  auto it = std::back_inserter(out);
  for (std::size_t i = 0; i < sweep.size(); ++i) {
    const Vec3f& p = sweep.p_lidar[i];
    fmt::format_to(it, "{} {} {}", p.x(), p.y(), p.z());
    if (!sweep.intensity.empty()) fmt::format_to(it, " {}", sweep.intensity[i]);
    if (!sweep.ring.empty()) fmt::format_to(it, " {}", sweep.ring[i]);
    if (time_field == PcdTimeField::kAbsolute) fmt::format_to(it, " {}", sweep.t_end_s + double(sweep.dt_s[i]));
    if (time_field == PcdTimeField::kRelative) fmt::format_to(it, " {}", sweep.dt_s[i]);
    out += '\n';
  }
}

// Binary: point after point. Compressed: field after field (one block per field), LZF-packed
// behind its packed and unpacked sizes.
void append_binary(const Sweep& sweep, const std::vector<OutField>& fields, bool compressed,
                   const std::filesystem::path& path, std::string& out) {
  const std::size_t n = sweep.size();
  std::size_t point_bytes = 0;
  for (const auto& f : fields) point_bytes += static_cast<std::size_t>(f.size);
  std::string raw(n * point_bytes, '\0');
  std::size_t field_off = 0;
  for (const OutField& f : fields) {
    const std::size_t size = static_cast<std::size_t>(f.size);
    for (std::size_t i = 0; i < n; ++i)
      put_field(sweep, f, i, raw.data() + (compressed ? n * field_off + i * size : i * point_bytes + field_off));
    field_off += size;
  }
  if (!compressed) {
    out += raw;
    return;
  }
  // LZF can expand incompressible input slightly; leave room for that.
  std::string packed(raw.size() + raw.size() / 16 + 64, '\0');
  unsigned int packed_size = 0;
  if (!raw.empty()) {
    packed_size = lzf_compress(raw.data(), static_cast<unsigned int>(raw.size()), packed.data(),
                               static_cast<unsigned int>(packed.size()));
    if (packed_size == 0) throw std::runtime_error("write_pcd: LZF compression failed for " + path.string());
  }
  const std::uint32_t sizes[2] = {packed_size, static_cast<std::uint32_t>(raw.size())};
  out.append(reinterpret_cast<const char*>(sizes), 8);
  out.append(packed.data(), packed_size);
}

}  // namespace

void write_pcd(const std::filesystem::path& path, const Sweep& sweep, PcdEncoding encoding,
               PcdTimeField time_field) {
  const std::size_t n = sweep.size();
  if ((!sweep.intensity.empty() && sweep.intensity.size() != n) || (!sweep.ring.empty() && sweep.ring.size() != n) ||
      (sweep.has_time() && sweep.dt_s.size() != n)) {
    throw std::invalid_argument("write_pcd: per-point arrays of sweep '" + sweep.name + "' differ in length");
  }
  if (!sweep.has_time()) time_field = PcdTimeField::kNone;
  if (time_field == PcdTimeField::kAbsolute && !std::isfinite(sweep.t_end_s)) {
    throw std::invalid_argument("write_pcd: absolute timestamps need a finite t_end_s (sweep '" + sweep.name + "')");
  }
  const std::vector<OutField> fields = out_fields(sweep, time_field);
  std::string out = header_text(fields, n, encoding);
  if (encoding == PcdEncoding::kAscii) append_ascii(sweep, time_field, out);
  else append_binary(sweep, fields, encoding == PcdEncoding::kBinaryCompressed, path, out);
  write_file_atomic(path, out);
}

}  // namespace insalign::io
