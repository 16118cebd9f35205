#include "recording/pointcloud2.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fmt/format.h>
#include <limits>
#include <optional>
#include <stdexcept>
#include <type_traits>

#include "core/errors.hpp"

namespace insalign::io::bag {

namespace {

constexpr const char* kType = "sensor_msgs/PointCloud2";
// Per-point time fields, in the order they are preferred.
constexpr const char* kTimeFields[] = {"timestamp", "time", "t", "offset_time"};
constexpr const char* kIntensityFields[] = {"intensity", "reflectivity"};
constexpr const char* kRingFields[] = {"ring", "channel", "line"};

// Where the points' bytes are.
struct Grid {
  const std::uint8_t* data = nullptr;
  std::size_t width = 0, height = 0, point_step = 0, row_step = 0;
  std::size_t size() const { return width * height; }
};

[[noreturn]] void fail(const std::string& where, const std::string& problem) {
  throw InputError(where, "", std::string(kType) + ": " + problem);
}

std::string field_list(const PointCloud2Layout& cloud) {
  std::string out;
  for (const PointField& f : cloud.fields) out += (out.empty() ? "" : ", ") + f.name;
  return out.empty() ? "(none)" : out;
}

const PointField* find_field(const PointCloud2Layout& cloud, std::string_view name) {
  for (const PointField& f : cloud.fields) {
    if (f.name == name) return &f;
  }
  return nullptr;
}

// A field insalign reads must have a known type and lie inside the point.
const PointField* usable(const PointCloud2Layout& cloud, const PointField* f, const std::string& where) {
  if (f == nullptr) return nullptr;
  const std::size_t size = point_field_size(f->datatype);
  if (size == 0) fail(where, fmt::format("field '{}' has datatype {} (must be 1..8, INT8..FLOAT64)", f->name, f->datatype));
  if (static_cast<std::uint64_t>(f->offset) + size > cloud.point_step) {
    fail(where, fmt::format("field '{}' ({} bytes at offset {}) does not fit in point_step {}", f->name, size,
                            f->offset, cloud.point_step));
  }
  return f;
}

template <std::size_t N>
const PointField* first_of(const PointCloud2Layout& cloud, const char* const (&names)[N], const std::string& where) {
  for (const char* n : names) {
    if (const PointField* f = find_field(cloud, n)) return usable(cloud, f, where);
  }
  return nullptr;
}

Grid check_grid(const PointCloud2Layout& cloud, Bytes data, const std::string& where) {
  if (cloud.is_bigendian) fail(where, "big-endian point clouds are not supported");
  Grid g{data.data(), cloud.width, cloud.height, cloud.point_step, cloud.row_step};
  const std::uint64_t n = static_cast<std::uint64_t>(cloud.width) * cloud.height;
  if (n == 0) return Grid{};  // not {width 0, height 4e9}: the loops over rows would still spin
  if (cloud.point_step == 0) fail(where, fmt::format("point_step is 0 for {} points", n));
  const std::uint64_t row_bytes = static_cast<std::uint64_t>(cloud.width) * cloud.point_step;
  if (cloud.height == 1) g.row_step = row_bytes;  // row_step unused: some drivers leave it wrong
  if (g.row_step < row_bytes) {
    fail(where, fmt::format("row_step {} is less than width {} x point_step {}", cloud.row_step, cloud.width,
                            cloud.point_step));
  }
  const std::uint64_t needed = static_cast<std::uint64_t>(cloud.height - 1) * g.row_step + row_bytes;
  if (needed > data.size()) {
    fail(where, fmt::format("data has {} bytes; height {} x row_step {} (width {}, point_step {}) needs {}",
                            data.size(), cloud.height, g.row_step, cloud.width, cloud.point_step, needed));
  }
  return g;
}

// ------------------------------------------------------------------------- gathering a field

// A double beyond float's range becomes +-inf (a plain cast would be undefined behaviour).
template <typename Out, typename T>
Out convert(T v) {
  if constexpr (std::is_same_v<T, double> && std::is_same_v<Out, float>) {
    constexpr double kMax = std::numeric_limits<float>::max();
    if (v > kMax) return std::numeric_limits<float>::infinity();
    if (v < -kMax) return -std::numeric_limits<float>::infinity();
  }
  return static_cast<Out>(v);
}

template <typename T, typename Out>
void gather_as(const Grid& g, std::size_t offset, Out* out, std::size_t stride) {
  std::size_t k = 0;
  for (std::size_t r = 0; r < g.height; ++r) {
    const std::uint8_t* p = g.data + r * g.row_step + offset;
    for (std::size_t c = 0; c < g.width; ++c, p += g.point_step, k += stride) {
      T v;
      std::memcpy(&v, p, sizeof(T));
      out[k] = convert<Out>(v);
    }
  }
}

// One switch per field, none per point.
template <typename Out>
void gather(const Grid& g, const PointField& f, Out* out, std::size_t stride = 1) {
  switch (f.datatype) {
    case PointField::kInt8: return gather_as<std::int8_t>(g, f.offset, out, stride);
    case PointField::kUint8: return gather_as<std::uint8_t>(g, f.offset, out, stride);
    case PointField::kInt16: return gather_as<std::int16_t>(g, f.offset, out, stride);
    case PointField::kUint16: return gather_as<std::uint16_t>(g, f.offset, out, stride);
    case PointField::kInt32: return gather_as<std::int32_t>(g, f.offset, out, stride);
    case PointField::kUint32: return gather_as<std::uint32_t>(g, f.offset, out, stride);
    case PointField::kFloat32: return gather_as<float>(g, f.offset, out, stride);
    case PointField::kFloat64: return gather_as<double>(g, f.offset, out, stride);
    default: return;
  }
}

void gather_xyz(const Grid& g, const PointField& x, const PointField& y, const PointField& z, std::vector<Vec3f>& p) {
  p.resize(g.size());
  if (p.empty()) return;  // (p.data() is null then)
  float* out = p.data()->data();  // Vec3f is three packed floats
  const bool packed_float32 = x.datatype == PointField::kFloat32 && y.datatype == PointField::kFloat32 &&
                              z.datatype == PointField::kFloat32 && y.offset == x.offset + 4 && z.offset == x.offset + 8;
  if (!packed_float32) {
    gather(g, x, out, 3), gather(g, y, out + 1, 3), gather(g, z, out + 2, 3);
    return;
  }
  std::size_t k = 0;  // the common layout: one 12-byte copy per point
  for (std::size_t r = 0; r < g.height; ++r) {
    const std::uint8_t* src = g.data + r * g.row_step + x.offset;
    for (std::size_t c = 0; c < g.width; ++c, src += g.point_step, k += 3) std::memcpy(out + k, src, 12);
  }
}

std::vector<std::uint16_t> gather_ring(const Grid& g, const PointField& f) {
  std::vector<double> v(g.size());
  gather(g, f, v.data());
  std::vector<std::uint16_t> ring(v.size());
  for (std::size_t i = 0; i < v.size(); ++i) {
    const double r = v[i];
    ring[i] = std::isfinite(r) ? static_cast<std::uint16_t>(std::clamp(r, 0.0, 65535.0)) : 0;  // never cast NaN
  }
  return ring;
}

// ----------------------------------------------------------------------------- per-point time

struct TimeModel {
  PointTimeConvention convention = PointTimeConvention::kNone;
  double to_seconds = 1.0;  ///< value * to_seconds = seconds (absolute, or after header.stamp)
  std::string description;
};

std::string driver_hint(const std::string& name, PointTimeConvention c) {
  if (c == PointTimeConvention::kAbsoluteNanoseconds) return " (Livox)";
  if (name == "timestamp" && c == PointTimeConvention::kAbsoluteSeconds) return " (Hesai, RoboSense)";
  if (name == "time" && c == PointTimeConvention::kRelativeSeconds) return " (Velodyne)";
  if (name == "t" && c == PointTimeConvention::kRelativeNanoseconds) return " (Ouster)";
  if (name == "offset_time") return " (Livox)";
  return "";
}

// The convention from the datatype and the values (over the points kept): integers are
// nanoseconds after the stamp; floats of 1e11 and more are absolute nanoseconds; floats closer to
// the stamp than to zero are absolute seconds; small ones (|v| <= 10 s) are seconds after the
// stamp (this holds for simulation clocks that start at 0 too); anything else is absolute seconds
// of the LiDAR's own clock (e.g. since power-on).
TimeModel classify_time(const PointField& f, double vmin, double vmax, double stamp_s) {
  using C = PointTimeConvention;
  const std::string what = fmt::format("'{}' {}", f.name, point_field_type_name(f.datatype));
  const bool is_float = f.datatype == PointField::kFloat32 || f.datatype == PointField::kFloat64;
  const double magnitude = std::max(std::abs(vmin), std::abs(vmax));
  TimeModel m;
  if (!is_float) {
    m = {C::kRelativeNanoseconds, 1e-9, "nanoseconds after header.stamp"};
  } else if (magnitude >= 1e11) {
    m = {C::kAbsoluteNanoseconds, 1e-9, "absolute nanoseconds"};
  } else if (std::abs(vmax - stamp_s) < std::abs(vmax) || magnitude > 10.0) {
    m = {C::kAbsoluteSeconds, 1.0, "absolute seconds"};
  } else {
    m = {C::kRelativeSeconds, 1.0, "seconds after header.stamp"};
  }
  const bool absolute = m.convention == C::kAbsoluteSeconds || m.convention == C::kAbsoluteNanoseconds;
  if (absolute && f.datatype == PointField::kFloat32 && magnitude > 1e5) {
    return {C::kNone, 1.0, what + " holds absolute times, which float32 cannot resolve (7 digits): per-point time ignored"};
  }
  m.description = what + ": " + m.description + driver_hint(f.name, m.convention);
  return m;
}

// ---------------------------------------------------------------------------------- the steps

struct Gathered {
  std::vector<Vec3f> p;
  std::vector<double> t;  ///< raw time values, empty without a time field
  std::vector<float> intensity;
  std::vector<std::uint16_t> ring;
};

// Drops points whose keep[i] is false, in every array.
void compact(Gathered& g, const std::vector<char>& keep) {
  std::size_t k = 0;
  for (std::size_t i = 0; i < keep.size(); ++i) {
    if (!keep[i]) continue;
    g.p[k] = g.p[i];
    if (!g.t.empty()) g.t[k] = g.t[i];
    if (!g.intensity.empty()) g.intensity[k] = g.intensity[i];
    if (!g.ring.empty()) g.ring[k] = g.ring[i];
    ++k;
  }
  g.p.resize(k);
  if (!g.t.empty()) g.t.resize(k);
  if (!g.intensity.empty()) g.intensity.resize(k);
  if (!g.ring.empty()) g.ring.resize(k);
}

std::size_t drop_nonfinite(Gathered& g) {
  std::vector<char> keep(g.p.size(), 1);
  std::size_t dropped = 0;
  for (std::size_t i = 0; i < g.p.size(); ++i) {
    const bool finite = g.p[i].allFinite() && (g.t.empty() || std::isfinite(g.t[i]));
    keep[i] = finite;
    dropped += finite ? 0 : 1;
  }
  if (dropped > 0) compact(g, keep);
  return dropped;
}

// Sets t_end_s and dt_s from the raw time values (or header.stamp without them).
void apply_time(Gathered& g, const PointField* time_field, double stamp_s, Sweep& sweep, PointCloudInfo& info) {
  sweep.t_end_s = stamp_s;
  if (time_field == nullptr || g.p.empty()) {
    g.t.clear();
    info.time_description = time_field == nullptr ? "no per-point time field: frame time = header.stamp"
                                                  : "no points: frame time = header.stamp";
    return;
  }
  const auto [lo, hi] = std::minmax_element(g.t.begin(), g.t.end());
  const double vmin = *lo, vmax = *hi;
  const TimeModel model = classify_time(*time_field, vmin, vmax, stamp_s);
  info.time_field = time_field->name;
  info.time_convention = model.convention;
  info.time_description = model.description;
  if (model.convention == PointTimeConvention::kNone) {
    g.t.clear();
    return;
  }
  const bool relative = model.convention == PointTimeConvention::kRelativeSeconds ||
                        model.convention == PointTimeConvention::kRelativeNanoseconds;
  sweep.t_end_s = (relative ? stamp_s : 0.0) + vmax * model.to_seconds;
  std::vector<char> keep(g.t.size(), 1);
  sweep.dt_s.resize(g.t.size());
  for (std::size_t i = 0; i < g.t.size(); ++i) {
    const double dt = (g.t[i] - vmax) * model.to_seconds;
    keep[i] = dt >= -kMaxSweepSpan_s;
    sweep.dt_s[i] = keep[i] ? static_cast<float>(dt) : 0.0f;  // in [-1, 0] s: the cast is exact enough
  }
  info.dropped_time_outside = static_cast<std::size_t>(std::count(keep.begin(), keep.end(), 0));
  if (info.dropped_time_outside == 0) return;
  std::size_t k = 0;
  for (std::size_t i = 0; i < keep.size(); ++i) {
    if (keep[i]) sweep.dt_s[k++] = sweep.dt_s[i];
  }
  sweep.dt_s.resize(k);
  compact(g, keep);
}

}  // namespace

Sweep sweep_from_pointcloud2(const PointCloud2Layout& cloud, Bytes data, const std::string& where,
                             PointCloudInfo* info_out) {
  PointCloudInfo info;
  info.header_stamp_s = cloud.header.stamp.seconds();
  info.frame_id = cloud.header.frame_id;
  for (const PointField& f : cloud.fields) {
    info.fields.push_back(f.count > 1 ? fmt::format("{} {}[{}]", f.name, point_field_type_name(f.datatype), f.count)
                                      : fmt::format("{} {}", f.name, point_field_type_name(f.datatype)));
  }
  const Grid grid = check_grid(cloud, data, where);
  info.points = grid.size();
  const PointField* axes[3];
  for (int a = 0; a < 3; ++a) {
    const char* name = a == 0 ? "x" : a == 1 ? "y" : "z";
    axes[a] = usable(cloud, find_field(cloud, name), where);
    if (axes[a] == nullptr) fail(where, fmt::format("no '{}' field; the cloud has: {}", name, field_list(cloud)));
  }
  const PointField* time_field = first_of(cloud, kTimeFields, where);
  const PointField* intensity = first_of(cloud, kIntensityFields, where);
  const PointField* ring = first_of(cloud, kRingFields, where);

  Gathered g;
  gather_xyz(grid, *axes[0], *axes[1], *axes[2], g.p);
  if (time_field != nullptr) g.t.resize(grid.size()), gather(grid, *time_field, g.t.data());
  if (intensity != nullptr) g.intensity.resize(grid.size()), gather(grid, *intensity, g.intensity.data());
  if (ring != nullptr) g.ring = gather_ring(grid, *ring);
  info.intensity_field = intensity != nullptr ? intensity->name : "";
  info.ring_field = ring != nullptr ? ring->name : "";
  info.dropped_nonfinite = drop_nonfinite(g);

  Sweep sweep;
  apply_time(g, time_field, info.header_stamp_s, sweep, info);
  sweep.p_lidar = std::move(g.p);
  sweep.intensity = std::move(g.intensity);
  sweep.ring = std::move(g.ring);
  if (info_out != nullptr) *info_out = std::move(info);
  return sweep;
}

Sweep decode_sweep(Bytes bytes, MessageEncoding encoding, const std::string& where, PointCloudInfo* info) {
  Bytes data;
  const PointCloud2Layout cloud = decode_pointcloud2_layout(bytes, encoding, where, data);
  return sweep_from_pointcloud2(cloud, data, where, info);
}

// ------------------------------------------------------------------------------------ writing

namespace {

struct FieldSpec {
  const char* name;
  std::uint32_t offset;
  std::uint8_t datatype;
};

template <typename T>
void put(std::vector<std::uint8_t>& data, std::size_t at, T v) {
  std::memcpy(data.data() + at, &v, sizeof(T));
}

std::vector<FieldSpec> driver_fields(DriverLayout layout, std::uint32_t& point_step) {
  using F = PointField;
  switch (layout) {
    case DriverLayout::kHesai:
      point_step = 48;
      return {{"x", 0, F::kFloat32}, {"y", 4, F::kFloat32}, {"z", 8, F::kFloat32},
              {"intensity", 16, F::kFloat32}, {"timestamp", 24, F::kFloat64}, {"ring", 32, F::kUint16}};
    case DriverLayout::kVelodyne:
      point_step = 22;
      return {{"x", 0, F::kFloat32}, {"y", 4, F::kFloat32}, {"z", 8, F::kFloat32},
              {"intensity", 12, F::kFloat32}, {"ring", 16, F::kUint16}, {"time", 18, F::kFloat32}};
    case DriverLayout::kOuster:
      point_step = 48;
      return {{"x", 0, F::kFloat32},          {"y", 4, F::kFloat32},       {"z", 8, F::kFloat32},
              {"intensity", 16, F::kFloat32}, {"t", 20, F::kUint32},       {"reflectivity", 24, F::kUint16},
              {"ring", 26, F::kUint16},       {"ambient", 28, F::kUint16}, {"range", 32, F::kUint32}};
    case DriverLayout::kLivox:
      point_step = 26;
      return {{"x", 0, F::kFloat32},         {"y", 4, F::kFloat32},   {"z", 8, F::kFloat32},
              {"intensity", 12, F::kFloat32}, {"tag", 16, F::kUint8}, {"line", 17, F::kUint8},
              {"timestamp", 18, F::kFloat64}};
    case DriverLayout::kNoTime:
    default:
      point_step = 16;
      return {{"x", 0, F::kFloat32}, {"y", 4, F::kFloat32}, {"z", 8, F::kFloat32}, {"intensity", 12, F::kFloat32}};
  }
}

// header.stamp as the driver sets it: the sweep start (Ouster, Hesai, Livox) or end (Velodyne).
std::int64_t driver_stamp_ns(const Sweep& s, DriverLayout layout) {
  const double start_s = s.t_end_s + (s.dt_s.empty() ? 0.0 : *std::min_element(s.dt_s.begin(), s.dt_s.end()));
  const bool at_end = layout == DriverLayout::kVelodyne || layout == DriverLayout::kNoTime;
  return std::llround((at_end ? s.t_end_s : start_s) * 1e9);
}

}  // namespace

PointCloud2 make_pointcloud2(const Sweep& sweep, DriverLayout layout, const std::string& frame_id) {
  if (!std::isfinite(sweep.t_end_s)) throw std::invalid_argument("make_pointcloud2: the sweep has no finite t_end_s");
  PointCloud2 cloud;
  const std::vector<FieldSpec> fields = driver_fields(layout, cloud.point_step);
  for (const FieldSpec& f : fields) cloud.fields.push_back({f.name, f.offset, f.datatype, 1});
  const std::int64_t stamp_ns = driver_stamp_ns(sweep, layout);
  cloud.header.stamp = Stamp::from_nanoseconds(stamp_ns);
  cloud.header.frame_id = frame_id;
  cloud.width = static_cast<std::uint32_t>(sweep.size());
  cloud.row_step = cloud.width * cloud.point_step;
  cloud.data.assign(static_cast<std::size_t>(cloud.row_step), 0);
  // Times relative to the stamp are computed from small numbers, to keep their precision.
  const double end_after_stamp_s = sweep.t_end_s - static_cast<double>(stamp_ns) * 1e-9;
  const auto offset_of = [&](std::string_view name) -> std::optional<std::size_t> {
    for (const FieldSpec& f : fields) {
      if (name == f.name) return f.offset;
    }
    return std::nullopt;
  };
  const auto intensity = offset_of("intensity"), ring = offset_of("ring"), line = offset_of("line");
  const auto time = offset_of("time"), t = offset_of("t"), timestamp = offset_of("timestamp");
  for (std::size_t i = 0; i < sweep.size(); ++i) {
    const std::size_t at = i * cloud.point_step;
    const double dt = sweep.has_time() ? sweep.dt_s[i] : 0.0;
    std::memcpy(cloud.data.data() + at, sweep.p_lidar[i].data(), 12);
    const std::uint16_t r = sweep.ring.empty() ? 0 : sweep.ring[i];
    if (intensity) put(cloud.data, at + *intensity, sweep.intensity.empty() ? 0.0f : sweep.intensity[i]);
    if (ring) put(cloud.data, at + *ring, r);
    if (line) put(cloud.data, at + *line, static_cast<std::uint8_t>(r));
    if (time) put(cloud.data, at + *time, static_cast<float>(end_after_stamp_s + dt));
    if (t) put(cloud.data, at + *t, static_cast<std::uint32_t>(std::max(0.0, std::round((end_after_stamp_s + dt) * 1e9))));
    if (timestamp && layout == DriverLayout::kLivox) put(cloud.data, at + *timestamp, sweep.t_end_s * 1e9 + dt * 1e9);
    if (timestamp && layout != DriverLayout::kLivox) put(cloud.data, at + *timestamp, sweep.t_end_s + dt);
  }
  return cloud;
}

}  // namespace insalign::io::bag
