#include "inslog/novatel_ascii.hpp"

#include <fmt/format.h>

#include <array>
#include <charconv>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <stdexcept>
#include <vector>

#include "core/errors.hpp"
#include "inslog/attitude.hpp"
#include "inslog/gps_time.hpp"
#include "files/read_file.hpp"

namespace insalign::io {
namespace {

constexpr double kQualityWindowS = 1.5;  // INSPVAX quality carried to INSPVA records this long

std::vector<std::string_view> split(std::string_view s, char sep) {
  std::vector<std::string_view> out;
  std::size_t start = 0;
  for (std::size_t i = 0; i <= s.size(); ++i) {
    if (i == s.size() || s[i] == sep) {
      out.push_back(s.substr(start, i - start));
      start = i + 1;
    }
  }
  return out;
}

bool parse_double(std::string_view s, double& out) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && ptr == s.data() + s.size() && std::isfinite(out);
}

bool parse_int(std::string_view s, int& out) {
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && ptr == s.data() + s.size();
}

bool is_name_char(char c) { return (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_'; }

// A record starts at '#'/'%' followed by an upper-case name ending in 'A' and a ','.
std::optional<std::size_t> record_start(std::string_view line, std::size_t from = 0) {
  for (std::size_t i = line.find_first_of("#%", from); i != std::string_view::npos;
       i = line.find_first_of("#%", i + 1)) {
    std::size_t j = i + 1;
    while (j < line.size() && is_name_char(line[j])) ++j;
    if (j > i + 2 && j < line.size() && line[j] == ',' && line[j - 1] == 'A') return i;
  }
  return std::nullopt;
}

enum class Kind { kInspva, kInspvax };

struct RawRecord {
  Kind kind = Kind::kInspva;
  std::size_t line = 0;
  double t_s = 0.0;
  GeodeticPoint p;
  double roll_deg = 0.0, pitch_deg = 0.0, azimuth_deg = 0.0;
  GnssSolution solution = GnssSolution::kUnknown;
  Vec3 stddev_enu_m = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
};

struct Scan {
  std::vector<RawRecord> inspva, inspvax;
  std::size_t ins_records = 0, bad = 0, first_bad_line = 0, time_unknown = 0;
  std::map<std::string, std::size_t> not_navigating, invalid_status, other;
  std::map<std::string, std::size_t> names_read;  // "#INSPVAXA" -> count
  std::string time_status;                         // the first long header's
};

// Context for decoding one record: the file and line for errors.
struct Where {
  const std::string& file;
  std::size_t line;
  [[noreturn]] void fail(const std::string& what) const { throw InputError(file, "line " + std::to_string(line), what); }
  double number(std::string_view s, const char* field) const {
    double v = 0.0;
    if (!parse_double(s, v)) fail(fmt::format("{} is not a finite number: '{}'", field, s));
    return v;
  }
};

// INS status -> solution; nullopt: not navigating (the record is skipped).
std::optional<GnssSolution> solution_of_status(std::string_view status) {
  if (status == "INS_SOLUTION_GOOD") return GnssSolution::kUnknown;  // refined by the position type
  if (status == "INS_SOLUTION_FREE") return GnssSolution::kInsOnly;
  if (status == "INS_ALIGNMENT_COMPLETE" || status == "INS_HIGH_VARIANCE") return GnssSolution::kInvalid;
  return std::nullopt;
}

void set_position(RawRecord& r, const Where& w, std::string_view lat, std::string_view lon, double height_m) {
  r.p = {w.number(lat, "latitude"), w.number(lon, "longitude"), height_m};
  try {
    check_geodetic(r.p);
  } catch (const std::invalid_argument& e) {
    w.fail(e.what());
  }
}

void set_time(RawRecord& r, const Where& w, std::string_view week, std::string_view seconds) {
  int wk = 0;
  if (!parse_int(week, wk) || wk < 0 || wk > 9999) w.fail(fmt::format("GPS week '{}' is not a week number", week));
  const double sow = w.number(seconds, "GPS seconds of week");
  if (sow < 0.0 || sow > 2 * kSecondsPerGpsWeek) w.fail(fmt::format("GPS seconds of week {} out of range", sow));
  r.t_s = gps_to_unix(wk, sow);
}

void set_attitude(RawRecord& r, const Where& w, const std::vector<std::string_view>& f, std::size_t first) {
  r.roll_deg = w.number(f[first], "roll");
  r.pitch_deg = w.number(f[first + 1], "pitch");
  r.azimuth_deg = w.number(f[first + 2], "azimuth");
}

// INSPVA body: week, seconds, lat, lon, height (ellipsoidal), vn, ve, vu, roll, pitch, azimuth, status.
std::optional<RawRecord> decode_inspva(const std::vector<std::string_view>& f, const Where& w, Scan& scan) {
  if (f.size() != 12) w.fail(fmt::format("INSPVA has {} fields after the header, expected 12", f.size()));
  const auto solution = solution_of_status(f[11]);
  if (!solution) {
    ++scan.not_navigating[std::string(f[11])];
    return std::nullopt;
  }
  if (*solution == GnssSolution::kInvalid) ++scan.invalid_status[std::string(f[11])];
  RawRecord r;
  r.kind = Kind::kInspva;
  r.line = w.line;
  r.solution = *solution;
  set_time(r, w, f[0], f[1]);
  set_position(r, w, f[2], f[3], w.number(f[4], "height"));
  set_attitude(r, w, f, 8);
  return r;
}

// INSPVAX body: ins status, pos type, lat, lon, height (MSL), undulation, vn, ve, vu, roll, pitch,
// azimuth, lat sd, lon sd, height sd, 6 more sd, extended status, time since update.
std::optional<RawRecord> decode_inspvax(const std::vector<std::string_view>& f, const Where& w, Scan& scan) {
  if (f.size() < 21) w.fail(fmt::format("INSPVAX has {} fields after the header, expected 23", f.size()));
  const auto solution = solution_of_status(f[0]);
  if (!solution) {
    ++scan.not_navigating[std::string(f[0])];
    return std::nullopt;
  }
  if (*solution == GnssSolution::kInvalid) ++scan.invalid_status[std::string(f[0])];
  RawRecord r;
  r.kind = Kind::kInspvax;
  r.line = w.line;
  r.solution = f[0] == "INS_SOLUTION_GOOD" ? novatel_pos_type_solution(f[1]) : *solution;
  const double height_msl_m = w.number(f[4], "height");
  const double undulation_m = w.number(f[5], "undulation");
  set_position(r, w, f[2], f[3], height_msl_m + undulation_m);
  set_attitude(r, w, f, 9);
  r.stddev_enu_m = {w.number(f[13], "longitude sd"), w.number(f[12], "latitude sd"), w.number(f[14], "height sd")};
  return r;
}

bool crc_ok(std::string_view record, std::size_t star) {
  if (star + 9 > record.size()) return false;
  std::uint32_t stated = 0;
  const char* begin = record.data() + star + 1;
  const auto [ptr, ec] = std::from_chars(begin, begin + 8, stated, 16);
  return ec == std::errc() && ptr == begin + 8 && stated == novatel_crc32(record.substr(1, star - 1));
}

// One INS record (CRC already checked): header time and body.
void decode_record(std::string_view name, std::string_view record, std::size_t star, const Where& w, Scan& scan) {
  const std::size_t semi = record.find(';');
  if (semi == std::string_view::npos || semi > star) w.fail("record without ';' between header and body");
  const auto header = split(record.substr(1, semi - 1), ',');
  const auto body = split(record.substr(semi + 1, star - semi - 1), ',');
  const bool long_header = record[0] == '#';
  if (long_header && header.size() < 7) w.fail(fmt::format("long header has {} fields, expected 10", header.size()));
  if (!long_header && header.size() < 3) w.fail(fmt::format("short header has {} fields, expected 3", header.size()));
  if (long_header) {
    if (scan.time_status.empty()) scan.time_status = std::string(header[4]);
    if (header[4] == "UNKNOWN") {
      ++scan.time_unknown;
      return;
    }
  }
  std::optional<RawRecord> r;
  if (name == "INSPVAXA") {
    if (!long_header) w.fail("INSPVAX needs the long header (it has no time of its own)");
    r = decode_inspvax(body, w, scan);
    if (r) set_time(*r, w, header[5], header[6]);
  } else {
    r = decode_inspva(body, w, scan);
  }
  if (!r) return;
  ++scan.names_read[fmt::format("{}{}", record[0], name)];
  (r->kind == Kind::kInspvax ? scan.inspvax : scan.inspva).push_back(*r);
}

void scan_line(std::string_view line, std::size_t line_no, const std::string& file, Scan& scan) {
  const auto start = record_start(line);
  if (!start) return;
  const std::string_view record = line.substr(*start);
  const std::string_view name = record.substr(1, record.find(',') - 1);
  const bool ins = (record[0] == '#' && (name == "INSPVAA" || name == "INSPVAXA")) ||
                   (record[0] == '%' && name == "INSPVASA");
  if (!ins) {
    ++scan.other[fmt::format("{}{}", record[0], name)];
    return;
  }
  ++scan.ins_records;
  const std::size_t star = record.find('*');
  if (star == std::string_view::npos || !crc_ok(record, star)) {
    if (scan.bad++ == 0) scan.first_bad_line = line_no;
    return;
  }
  decode_record(name, record, star, Where{file, line_no}, scan);
}

std::string counts_text(const std::map<std::string, std::size_t>& counts) {
  std::string out;
  for (const auto& [name, n] : counts) out += fmt::format("{}{} {}", out.empty() ? "" : ", ", name, n);
  return out;
}

void check_bad(const Scan& scan, const std::string& file, const NovatelReadOptions& options, InsTrack& track) {
  if (scan.bad == 0) return;
  const bool too_many = scan.bad > options.max_bad_records ||
                        static_cast<double>(scan.bad) > options.max_bad_fraction * static_cast<double>(scan.ins_records);
  const std::string what = fmt::format("{} of {} INS records have a bad CRC or are cut short (first at line {})",
                                       scan.bad, scan.ins_records, scan.first_bad_line);
  if (too_many) {
    throw InputError(file, "line " + std::to_string(scan.first_bad_line),
                     fmt::format("{}: more than {:g}% or {} is a corrupt file, not a few transmission errors", what,
                                 100.0 * options.max_bad_fraction, options.max_bad_records));
  }
  track.records_skipped += scan.bad;
  track.warnings.push_back(what + ": skipped");
}

// INSPVA records take solution and stddev from the latest INSPVAX at most kQualityWindowS before.
void attach_inspvax_quality(std::vector<RawRecord>& poses, const std::vector<RawRecord>& quality) {
  std::size_t q = 0;
  for (RawRecord& r : poses) {
    while (q + 1 < quality.size() && quality[q + 1].t_s <= r.t_s) ++q;
    if (quality.empty() || quality[q].t_s > r.t_s || r.t_s - quality[q].t_s > kQualityWindowS) continue;
    if (r.solution == GnssSolution::kUnknown) r.solution = quality[q].solution;
    r.stddev_enu_m = quality[q].stddev_enu_m;
  }
}

// The same solution logged twice (INSPVAA and INSPVASA both requested): identical time and values.
bool same_solution(const RawRecord& a, const RawRecord& b) {
  return a.t_s == b.t_s && a.p.lat_deg == b.p.lat_deg && a.p.lon_deg == b.p.lon_deg && a.p.height_m == b.p.height_m &&
         a.roll_deg == b.roll_deg && a.pitch_deg == b.pitch_deg && a.azimuth_deg == b.azimuth_deg;
}

void fill_records(const std::vector<RawRecord>& raw, const std::string& file, InsTrack& track) {
  std::size_t repeated = 0;
  const RawRecord* previous = nullptr;
  for (const RawRecord& r : raw) {
    if (previous && same_solution(r, *previous)) {
      ++repeated;
      continue;
    }
    if (previous && !(r.t_s > previous->t_s)) {
      throw InputError(file, "line " + std::to_string(r.line),
                       fmt::format("time {:.3f} (UNIX) does not come after the record at line {} ({:.3f}): {}", r.t_s,
                                   previous->line, previous->t_s,
                                   r.t_s == previous->t_s ? "a repeated time with other values" : "time goes backwards"));
    }
    previous = &r;
    InsRecord out;
    out.t_s = r.t_s;
    out.lat_deg = r.p.lat_deg;
    out.lon_deg = r.p.lon_deg;
    out.height_m = r.p.height_m;
    out.R_world_ins = R_enu_ins_novatel(r.roll_deg, r.pitch_deg, r.azimuth_deg);
    out.solution = r.solution;
    out.position_stddev_m = r.stddev_enu_m;
    out.location = "line " + std::to_string(r.line);
    track.records.push_back(out);
  }
  if (repeated > 0) {
    track.records_skipped += repeated;
    track.warnings.push_back(fmt::format("{} records repeat the one before them (the same solution logged twice, e.g. "
                                         "as INSPVAA and INSPVASA): skipped", repeated));
  }
}

void describe(const Scan& scan, bool use_inspvax, InsTrack& track) {
  std::string names;
  for (const auto& [name, n] : scan.names_read) {
    if ((name == "#INSPVAXA") == use_inspvax) names += (names.empty() ? "" : " + ") + name;
  }
  track.format = "NovAtel OEM7 ASCII " + names;
  const double t0 = track.records.front().t_s;
  track.time_base = fmt::format("GPS week + seconds{}, converted to UNIX (GPS - UTC = {} s)",
                                scan.time_status.empty() ? "" : " (time status " + scan.time_status + ")",
                                gps_minus_utc_s(t0));
  track.body_frame = "NovAtel SPAN vehicle frame (x right, y forward, z up; azimuth clockwise from north)";
  track.height_datum = use_inspvax ? "INSPVAX height above mean sea level + its undulation -> WGS-84 ellipsoid"
                                   : "WGS-84 ellipsoid (INSPVA heights are ellipsoidal)";
  track.world_frame = "local ENU at the first fix";
  track.geodetic = true;
  if (!use_inspvax && !scan.inspvax.empty()) {
    track.warnings.push_back(fmt::format("{} #INSPVAXA records give the GNSS solution and standard deviations",
                                         scan.inspvax.size()));
  }
}

void report_skips(const Scan& scan, InsTrack& track) {
  std::size_t not_nav = 0;
  for (const auto& [status, n] : scan.not_navigating) not_nav += n;
  if (not_nav > 0) {
    track.records_skipped += not_nav;
    track.warnings.push_back(fmt::format("{} records skipped: the INS was not navigating ({})", not_nav,
                                         counts_text(scan.not_navigating)));
  }
  if (scan.time_unknown > 0) {
    track.records_skipped += scan.time_unknown;
    track.warnings.push_back(fmt::format("{} records skipped: header time status UNKNOWN", scan.time_unknown));
  }
  if (!scan.invalid_status.empty()) {
    track.warnings.push_back(fmt::format("records marked invalid: navigating, not yet within specification ({})",
                                         counts_text(scan.invalid_status)));
  }
  if (!scan.other.empty()) track.warnings.push_back("other records ignored: " + counts_text(scan.other));
}

}  // namespace

GnssSolution novatel_pos_type_solution(std::string_view t) {
  const auto has = [&](std::string_view s) { return t.find(s) != std::string_view::npos; };
  if (has("RTKFIXED") || has("_INT")) return GnssSolution::kRtkFixed;
  if (has("RTKFLOAT") || has("FLOAT")) return GnssSolution::kRtkFloat;
  if (has("PSRDIFF") || has("SBAS") || has("PPP") || has("OMNISTAR") || has("WAAS")) return GnssSolution::kDifferential;
  if (has("PSRSP") || has("SINGLE")) return GnssSolution::kSingle;
  if (t == "NONE" || t == "INS") return GnssSolution::kInsOnly;
  return GnssSolution::kUnknown;
}

std::uint32_t novatel_crc32(std::string_view bytes) {
  static const std::array<std::uint32_t, 256> table = [] {
    std::array<std::uint32_t, 256> t{};
    for (std::uint32_t i = 0; i < 256; ++i) {
      std::uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1u) ? (c >> 1) ^ 0xEDB88320u : c >> 1;
      t[i] = c;
    }
    return t;
  }();
  std::uint32_t crc = 0;
  for (const char ch : bytes) crc = (crc >> 8) ^ table[(crc ^ static_cast<unsigned char>(ch)) & 0xFFu];
  return crc;
}

bool looks_like_novatel_ascii(std::string_view text) {
  std::size_t pos = 0;
  while (pos < text.size()) {
    std::size_t nl = text.find('\n', pos);
    if (nl == std::string_view::npos) nl = text.size();
    const std::string_view line = text.substr(pos, nl - pos);
    if (const auto start = record_start(line); start && line.find(';', *start) != std::string_view::npos) return true;
    pos = nl + 1;
  }
  return false;
}

InsTrack parse_novatel_ascii(std::string_view text, const std::string& file, const NovatelReadOptions& options) {
  Scan scan;
  std::size_t pos = 0, line_no = 0;
  while (pos < text.size()) {
    std::size_t nl = text.find('\n', pos);
    if (nl == std::string_view::npos) nl = text.size();
    ++line_no;
    scan_line(text.substr(pos, nl - pos), line_no, file, scan);
    pos = nl + 1;
  }
  InsTrack track;
  track.source = file;
  check_bad(scan, file, options, track);
  if (scan.inspva.empty() && scan.inspvax.empty()) {
    std::string found = scan.ins_records > 0 ? fmt::format("{} INS records, none navigating", scan.ins_records)
                                             : (scan.other.empty() ? "nothing" : counts_text(scan.other));
    if (text.find("\xAA\x44\x12") != std::string_view::npos || text.find("\xAA\x44\x13") != std::string_view::npos) {
      found += "; binary NovAtel records are not read: convert the log to ASCII (NovAtel Convert)";
    }
    throw InputError(file, "", "no usable #INSPVAA, %INSPVASA or #INSPVAXA record (found: " + found +
                                   "); log INSPVAXA (or INSPVASA at a high rate) on the receiver");
  }
  const bool use_inspvax = scan.inspvax.size() >= scan.inspva.size();
  std::vector<RawRecord>& poses = use_inspvax ? scan.inspvax : scan.inspva;
  if (!use_inspvax) attach_inspvax_quality(poses, scan.inspvax);
  fill_records(poses, file, track);
  describe(scan, use_inspvax, track);
  report_skips(scan, track);
  return track;
}

InsTrack read_novatel_ascii(const std::filesystem::path& path, const NovatelReadOptions& options) {
  return parse_novatel_ascii(read_file(path), path.string(), options);
}

}  // namespace insalign::io
