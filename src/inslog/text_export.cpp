#include "inslog/text_export.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "core/errors.hpp"
#include "inslog/attitude.hpp"
#include "inslog/gps_time.hpp"
#include "inslog/novatel_ascii.hpp"
#include "files/read_file.hpp"

namespace insalign::io {
namespace {

constexpr std::size_t kMaxHeaderSearchLines = 1000;  // preambles are tens of lines

template <typename E>
struct Named {
  const char* name;
  E value;
};
constexpr Named<TextTimeBase> kTimeBases[] = {{"unix", TextTimeBase::kUnix},
                                              {"gps-sow", TextTimeBase::kGpsSecondsOfWeek},
                                              {"gps-week-seconds", TextTimeBase::kGpsWeekSeconds},
                                              {"gps", TextTimeBase::kGpsSeconds}};
constexpr Named<TextHeightDatum> kDatums[] = {{"ellipsoidal", TextHeightDatum::kEllipsoidal},
                                              {"msl", TextHeightDatum::kMeanSeaLevel}};
constexpr Named<HeadingConvention> kHeadings[] = {{"cw-from-north", HeadingConvention::kClockwiseFromNorth},
                                                  {"ccw-from-east", HeadingConvention::kCounterClockwiseFromEast}};
constexpr Named<AngleUnit> kUnits[] = {{"deg", AngleUnit::kDegrees}, {"rad", AngleUnit::kRadians}};
constexpr Named<TextBodyFrame> kFrames[] = {{"x-forward-y-right-z-down", TextBodyFrame::kForwardRightDown},
                                            {"x-forward-y-left-z-up", TextBodyFrame::kForwardLeftUp},
                                            {"x-right-y-forward-z-up", TextBodyFrame::kRightForwardUp}};
constexpr Named<StatusCode> kStatusCodes[] = {{"ie-quality", StatusCode::kIeQuality},
                                              {"gga", StatusCode::kGga},
                                              {"novatel", StatusCode::kNovatel}};
constexpr Named<TextDelimiter> kDelimiters[] = {{"auto", TextDelimiter::kAuto},
                                                {"comma", TextDelimiter::kComma},
                                                {"semicolon", TextDelimiter::kSemicolon},
                                                {"tab", TextDelimiter::kTab},
                                                {"whitespace", TextDelimiter::kWhitespace}};

template <typename E, std::size_t N>
std::string names_of(const Named<E> (&table)[N]) {
  std::string out;
  for (const auto& n : table) out += (out.empty() ? "" : "|") + std::string(n.name);
  return out;
}

template <typename E, std::size_t N>
E lookup(const Named<E> (&table)[N], const std::string& s, const std::string& key, const std::string& source) {
  for (const auto& n : table) {
    if (s == n.name) return n.value;
  }
  throw InputError(source, "", fmt::format("{}: '{}' is not one of {}", key, s, names_of(table)));
}

template <typename E, std::size_t N>
const char* name_of(const Named<E> (&table)[N], E value) {
  for (const auto& n : table) {
    if (n.value == value) return n.name;
  }
  return "?";
}

std::string trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return std::string(s);
}

// A header cell as compared: trimmed, unquoted, lower case.
std::string normalized(std::string_view s) {
  std::string t = trim(s);
  if (t.size() >= 2 && (t.front() == '"' || t.front() == '\'') && t.back() == t.front()) t = trim(t.substr(1, t.size() - 2));
  std::transform(t.begin(), t.end(), t.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return t;
}

struct SpecItem {
  std::string key, value, qualifier;
};

// "k=v:q, k2="a,b":q" -> items; quotes protect ',' ':' '='.
std::vector<SpecItem> split_spec(const std::string& spec, const std::string& source) {
  std::vector<SpecItem> items;
  std::string part[3];
  int field = 0;
  bool quoted = false, any = false;
  const auto flush = [&] {
    if (any || !trim(part[0]).empty()) {
      if (field == 0) throw InputError(source, "", fmt::format("'{}' is not key=value", trim(part[0])));
      items.push_back({trim(part[0]), trim(part[1]), trim(part[2])});
    }
    part[0].clear(), part[1].clear(), part[2].clear();
    field = 0, any = false;
  };
  for (const char c : spec) {
    if (c == '"') {
      quoted = !quoted, any = true;
    } else if (quoted) {
      part[field] += c;
    } else if (c == ',') {
      flush();
    } else if (c == '=' && field == 0) {
      field = 1;
    } else if (c == ':' && field == 1) {
      field = 2;
    } else {
      part[field] += c;
    }
  }
  if (quoted) throw InputError(source, "", "unbalanced '\"' in the column spec");
  flush();
  return items;
}

void require_column(const std::string& name, const char* key, const std::string& source) {
  if (name.empty()) throw InputError(source, "", fmt::format("the column mapping needs {}=COLUMN", key));
}

void validate(const TextExportColumns& c, const std::string& source) {
  require_column(c.time, "time", source);
  require_column(c.latitude, "lat", source);
  require_column(c.longitude, "lon", source);
  require_column(c.height, "height", source);
  require_column(c.roll, "roll", source);
  require_column(c.pitch, "pitch", source);
  require_column(c.heading, "heading", source);
  if (c.time_base == TextTimeBase::kGpsWeekSeconds) require_column(c.week, "week (time base gps-week-seconds)", source);
  if (c.height_datum == TextHeightDatum::kMeanSeaLevel) require_column(c.undulation, "undulation (height datum msl)", source);
}

// Keys that name a column.
struct ColumnKey {
  const char* key;
  std::string TextExportColumns::*column;
};
constexpr ColumnKey kColumnKeys[] = {
    {"time", &TextExportColumns::time},         {"week", &TextExportColumns::week},
    {"lat", &TextExportColumns::latitude},      {"lon", &TextExportColumns::longitude},
    {"height", &TextExportColumns::height},     {"undulation", &TextExportColumns::undulation},
    {"roll", &TextExportColumns::roll},         {"pitch", &TextExportColumns::pitch},
    {"heading", &TextExportColumns::heading},   {"yaw", &TextExportColumns::heading},
    {"sd-east", &TextExportColumns::sd_east},   {"sd-north", &TextExportColumns::sd_north},
    {"sd-up", &TextExportColumns::sd_up},       {"sd-horizontal", &TextExportColumns::sd_horizontal},
    {"status", &TextExportColumns::status}};

// The ':qualifier' of a column key (yaw= defaults to counter-clockwise from east).
void apply_qualifier(TextExportColumns& c, const SpecItem& it, const std::string& source) {
  if (it.key == "yaw") c.heading_convention = HeadingConvention::kCounterClockwiseFromEast;
  if (it.qualifier.empty()) return;
  if (it.key == "time") {
    c.time_base = lookup(kTimeBases, it.qualifier, it.key, source);
  } else if (it.key == "height") {
    c.height_datum = lookup(kDatums, it.qualifier, it.key, source);
  } else if (it.key == "heading" || it.key == "yaw") {
    c.heading_convention = lookup(kHeadings, it.qualifier, it.key, source);
  } else if (it.key == "status") {
    c.status_code = lookup(kStatusCodes, it.qualifier, it.key, source);
  } else {
    throw InputError(source, "", fmt::format("{} takes no ':{}'", it.key, it.qualifier));
  }
}

void apply_item(TextExportColumns& c, const SpecItem& it, const std::string& source) {
  if (it.value.empty()) throw InputError(source, "", fmt::format("{}= has no value", it.key));
  for (const ColumnKey& k : kColumnKeys) {
    if (it.key == k.key) {
      c.*(k.column) = it.value;
      return apply_qualifier(c, it, source);
    }
  }
  const bool value_key = it.key == "latlon-units" || it.key == "units" || it.key == "frame" || it.key == "delimiter";
  if (!value_key) {
    throw InputError(source, "", fmt::format("unknown key '{}' (keys: time week lat lon latlon-units height undulation "
                                             "roll pitch heading yaw units frame sd-east sd-north sd-up sd-horizontal "
                                             "status delimiter)", it.key));
  }
  if (!it.qualifier.empty()) throw InputError(source, "", fmt::format("{} takes no ':{}'", it.key, it.qualifier));
  if (it.key == "latlon-units") c.latlon_units = lookup(kUnits, it.value, it.key, source);
  if (it.key == "units") c.units = lookup(kUnits, it.value, it.key, source);
  if (it.key == "frame") c.frame = lookup(kFrames, it.value, it.key, source);
  if (it.key == "delimiter") c.delimiter = lookup(kDelimiters, it.value, it.key, source);
}

}  // namespace

TextExportColumns parse_text_export_columns(const std::string& spec, const std::string& source) {
  TextExportColumns c;
  for (const SpecItem& it : split_spec(spec, source)) apply_item(c, it, source);
  validate(c, source);
  return c;
}

std::string format_text_export_columns(const TextExportColumns& c) {
  const auto col = [](const char* key, const std::string& name) {
    return name.empty() ? std::string() : fmt::format(",{}=\"{}\"", key, name);
  };
  std::string out = fmt::format("time=\"{}\":{}", c.time, name_of(kTimeBases, c.time_base));
  out += col("week", c.week) + col("lat", c.latitude) + col("lon", c.longitude);
  out += fmt::format(",latlon-units={},height=\"{}\":{}", name_of(kUnits, c.latlon_units), c.height,
                     name_of(kDatums, c.height_datum));
  out += col("undulation", c.undulation) + col("roll", c.roll) + col("pitch", c.pitch);
  out += fmt::format(",heading=\"{}\":{},units={},frame={}", c.heading, name_of(kHeadings, c.heading_convention),
                     name_of(kUnits, c.units), name_of(kFrames, c.frame));
  out += col("sd-east", c.sd_east) + col("sd-north", c.sd_north) + col("sd-up", c.sd_up) +
         col("sd-horizontal", c.sd_horizontal);
  if (!c.status.empty()) out += fmt::format(",status=\"{}\":{}", c.status, name_of(kStatusCodes, c.status_code));
  out += fmt::format(",delimiter={}", name_of(kDelimiters, c.delimiter));
  return out;
}

namespace {

// ---- reading --------------------------------------------------------------------------------

std::vector<std::string_view> split_row(std::string_view line, TextDelimiter d) {
  std::vector<std::string_view> out;
  if (d == TextDelimiter::kWhitespace || d == TextDelimiter::kAuto) {
    std::size_t i = 0;
    while (i < line.size()) {
      while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
      std::size_t j = i;
      while (j < line.size() && !std::isspace(static_cast<unsigned char>(line[j]))) ++j;
      if (j > i) out.push_back(line.substr(i, j - i));
      i = j;
    }
    return out;
  }
  const char sep = d == TextDelimiter::kComma ? ',' : d == TextDelimiter::kSemicolon ? ';' : '\t';
  std::size_t start = 0;
  for (std::size_t i = 0; i <= line.size(); ++i) {
    if (i == line.size() || line[i] == sep) {
      out.push_back(line.substr(start, i - start));
      start = i + 1;
    }
  }
  if (!out.empty() && trim(out.back()).empty()) out.pop_back();  // a trailing delimiter
  return out;
}

TextDelimiter detect_delimiter(std::string_view line) {
  if (line.find('\t') != std::string_view::npos) return TextDelimiter::kTab;
  if (line.find(';') != std::string_view::npos) return TextDelimiter::kSemicolon;
  if (line.find(',') != std::string_view::npos) return TextDelimiter::kComma;
  return TextDelimiter::kWhitespace;
}

bool parse_number(std::string_view field, bool decimal_comma, double& out) {
  std::string s = trim(field);
  if (decimal_comma) std::replace(s.begin(), s.end(), ',', '.');
  if (!s.empty() && s.front() == '+') s.erase(0, 1);
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return !s.empty() && ec == std::errc() && ptr == s.data() + s.size() && std::isfinite(out);
}

struct Line {
  std::size_t no = 0;  ///< 1-based
  std::string_view text;
};

// Non-blank lines that are not '#' comments, '\r' stripped.
std::vector<Line> content_lines(std::string_view text) {
  std::vector<Line> out;
  std::size_t pos = 0, no = 0;
  while (pos < text.size()) {
    std::size_t nl = text.find('\n', pos);
    if (nl == std::string_view::npos) nl = text.size();
    std::string_view line = text.substr(pos, nl - pos);
    pos = nl + 1;
    ++no;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    const std::string t = trim(line);
    if (t.empty() || t.front() == '#') continue;
    out.push_back({no, line});
  }
  return out;
}

std::size_t count_numeric(const std::vector<std::string_view>& fields, bool decimal_comma) {
  std::size_t n = 0;
  double v = 0.0;
  for (const auto f : fields) n += parse_number(f, decimal_comma, v) ? 1 : 0;
  return n;
}

bool is_data_row(std::string_view line) {
  const TextDelimiter d = detect_delimiter(line);
  const auto fields = split_row(line, d);
  return fields.size() >= 3 && count_numeric(fields, d == TextDelimiter::kSemicolon) >= 3;
}

// A header: the line just above the first data rows with >= 3 name cells (not numbers), preferring
// one with as many cells as the data row has fields (a units row usually has fewer).
std::optional<std::size_t> find_generic_header(const std::vector<Line>& lines) {
  for (std::size_t d = 0; d < lines.size() && d < kMaxHeaderSearchLines; ++d) {
    if (!is_data_row(lines[d].text)) continue;
    const std::size_t fields = split_row(lines[d].text, detect_delimiter(lines[d].text)).size();
    std::optional<std::size_t> fallback;
    for (std::size_t i = d; i-- > 0 && d - i <= 6;) {
      const auto cells = split_row(lines[i].text, detect_delimiter(lines[i].text));
      if (cells.size() < 3 || cells.size() - count_numeric(cells, false) < 3) continue;
      if (cells.size() == fields) return i;
      if (!fallback) fallback = i;
    }
    if (fallback) return fallback;
  }
  return std::nullopt;
}

std::vector<std::string> header_names(std::string_view line) {
  std::vector<std::string> out;
  for (const auto cell : split_row(line, detect_delimiter(line))) out.push_back(trim(cell));
  return out;
}

// Column indices of the mapping in the header row (npos for unmapped names).
struct Indices {
  std::size_t time, week, lat, lon, height, undulation, roll, pitch, heading, sd_e, sd_n, sd_u, sd_h, status;
  std::size_t max_used = 0;
  std::size_t header_cells = 0;
};

constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();

std::optional<Indices> match_header(std::string_view line, const TextExportColumns& c, std::string* missing) {
  std::vector<std::string> cells;
  for (const auto& n : header_names(line)) cells.push_back(normalized(n));
  Indices ix{};
  bool ok = true;
  const auto find = [&](const std::string& name) -> std::size_t {
    if (name.empty()) return kNone;
    const auto it = std::find(cells.begin(), cells.end(), normalized(name));
    if (it == cells.end()) {
      if (missing) *missing += (missing->empty() ? "'" : ", '") + name + "'";
      ok = false;
      return kNone;
    }
    const auto index = static_cast<std::size_t>(it - cells.begin());
    ix.max_used = std::max(ix.max_used, index);
    return index;
  };
  ix = {find(c.time), find(c.week), find(c.latitude), find(c.longitude), find(c.height), find(c.undulation),
        find(c.roll), find(c.pitch), find(c.heading), find(c.sd_east), find(c.sd_north), find(c.sd_up),
        find(c.sd_horizontal), find(c.status), ix.max_used, cells.size()};
  if (!ok) return std::nullopt;
  return ix;
}

std::string suggestion(const std::vector<std::string>& names) {
  std::vector<std::string> lower;
  for (const auto& n : names) lower.push_back(normalized(n));
  const auto has = [&](const char* n) { return std::find(lower.begin(), lower.end(), n) != lower.end(); };
  if (has("gpstime") && has("latitude") && has("h-ell") && has("heading")) {
    return fmt::format("It looks like a NovAtel Inertial Explorer export; its mapping is "
                       "\"time=GPSTime:gps-sow,{}lat=Latitude,lon=Longitude,height=H-Ell,roll=Roll,pitch=Pitch,"
                       "heading=Heading:cw-from-north,units=deg,frame=x-right-y-forward-z-up{}\"",
                       has("week") ? "week=Week," : "", has("sdnorth") ? ",sd-east=SDEast,sd-north=SDNorth,sd-up=SDHeight" : "");
  }
  if (has("time") && has("latitude") && has("ellipsoid height") && has("heading")) {
    return "It looks like an Applanix POSPac export; its mapping is \"time=TIME:gps-sow,lat=LATITUDE,lon=LONGITUDE,"
           "height=ELLIPSOID HEIGHT,roll=ROLL,pitch=PITCH,heading=HEADING:cw-from-north,units=deg,"
           "frame=x-forward-y-right-z-down" + std::string(has("north sd") ? ",sd-east=EAST SD,sd-north=NORTH SD,sd-up=HEIGHT SD" : "") + "\"";
  }
  return "Map them with --poses-columns (or poses_columns: in the config), e.g. \"time=<col>:unix|gps-sow,"
         "lat=<col>,lon=<col>,height=<col>,roll=<col>,pitch=<col>,heading=<col>:cw-from-north,units=deg,"
         "frame=x-forward-y-right-z-down\"";
}

[[noreturn]] void fail_no_mapping(const std::vector<Line>& lines, const std::string& file) {
  const auto h = find_generic_header(lines);
  if (!h) throw InputError(file, "", "a text export needs a header row naming its columns; none found");
  const auto names = header_names(lines[*h].text);
  std::string list;
  for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
  throw InputError(file, "line " + std::to_string(lines[*h].no),
                   fmt::format("a text export without a column mapping; its columns: {}. {}", list, suggestion(names)));
}

// Header row index and column indices; InputError naming the missing names otherwise.
std::pair<std::size_t, Indices> locate_header(const std::vector<Line>& lines, const TextExportColumns& c,
                                              const std::string& file) {
  for (std::size_t i = 0; i < lines.size() && i < kMaxHeaderSearchLines; ++i) {
    if (auto ix = match_header(lines[i].text, c, nullptr)) return {i, *ix};
  }
  const auto h = find_generic_header(lines);
  if (!h) throw InputError(file, "", "no header row holding the mapped column names (" + c.time + ", " + c.latitude + ", ...)");
  std::string missing, list;
  (void)match_header(lines[*h].text, c, &missing);
  for (const auto& n : header_names(lines[*h].text)) list += (list.empty() ? "" : ", ") + n;
  throw InputError(file, "line " + std::to_string(lines[*h].no),
                   fmt::format("the header has no column {} (its columns: {})", missing, list));
}

struct RowContext {
  const std::string& file;
  const TextExportColumns& c;
  const Indices& ix;
  bool decimal_comma = false;
  std::optional<double> hint_unix_s;
  std::optional<int> inferred_week;   // gps-sow without a week column
  double previous_sow = 0.0;
};

double field(const std::vector<std::string_view>& f, std::size_t index, const char* what, const Line& line,
             const RowContext& ctx) {
  double v = 0.0;
  if (!parse_number(f[index], ctx.decimal_comma, v)) {
    throw InputError(ctx.file, "line " + std::to_string(line.no),
                     fmt::format("{} (column {}) is not a finite number: '{}'", what, index + 1, trim(f[index])));
  }
  return v;
}

double row_time(const std::vector<std::string_view>& f, const Line& line, RowContext& ctx) {
  const double t = field(f, ctx.ix.time, "time", line, ctx);
  switch (ctx.c.time_base) {
    case TextTimeBase::kUnix: return t;
    case TextTimeBase::kGpsSeconds: return gps_seconds_to_unix(t);
    default: break;
  }
  if (ctx.ix.week != kNone) {
    const double week = field(f, ctx.ix.week, "week", line, ctx);
    if (!(week >= 0.0 && week <= 9999.0)) {
      throw InputError(ctx.file, "line " + std::to_string(line.no), fmt::format("GPS week {} out of range", week));
    }
    return gps_to_unix(static_cast<int>(std::lround(week)), t);
  }
  if (!ctx.inferred_week) {
    if (!ctx.hint_unix_s) {
      throw InputError(ctx.file, "line " + std::to_string(line.no),
                       "GPS seconds of week without a week column: the LiDAR's time is needed to infer the week "
                       "(or map week=COLUMN)");
    }
    ctx.inferred_week = nearest_gps_week(t, *ctx.hint_unix_s);
  } else if (t < ctx.previous_sow - kSecondsPerGpsWeek / 2) {
    ++*ctx.inferred_week;  // seconds of week wrapped at the week's end
  }
  ctx.previous_sow = t;
  return gps_to_unix(*ctx.inferred_week, t);
}

Mat3 row_attitude(double roll, double pitch, double heading, const RowContext& ctx) {
  const double k = ctx.c.units == AngleUnit::kRadians ? kDegPerRad : 1.0;
  roll *= k, pitch *= k, heading *= k;
  const bool cw = ctx.c.heading_convention == HeadingConvention::kClockwiseFromNorth;
  switch (ctx.c.frame) {
    case TextBodyFrame::kForwardRightDown: return R_enu_ins_ned(roll, pitch, cw ? heading : 90.0 - heading);
    case TextBodyFrame::kForwardLeftUp: return R_enu_ins_enu(roll, pitch, cw ? 90.0 - heading : heading);
    case TextBodyFrame::kRightForwardUp: return R_enu_ins_novatel(roll, pitch, cw ? heading : 90.0 - heading);
  }
  return Mat3::Identity();
}

GnssSolution row_status(std::string_view value, StatusCode code) {
  const std::string v = trim(value);
  if (code == StatusCode::kNovatel) return novatel_pos_type_solution(v);
  int q = -1;
  std::from_chars(v.data(), v.data() + v.size(), q);
  if (code == StatusCode::kIeQuality) {
    switch (q) {
      case 1: return GnssSolution::kRtkFixed;
      case 2: case 3: return GnssSolution::kRtkFloat;
      case 4: return GnssSolution::kDifferential;
      case 5: return GnssSolution::kSingle;
      case 6: return GnssSolution::kInvalid;
      default: return GnssSolution::kUnknown;
    }
  }
  switch (q) {  // NMEA GGA quality
    case 0: return GnssSolution::kInvalid;
    case 1: return GnssSolution::kSingle;
    case 2: case 3: case 9: return GnssSolution::kDifferential;
    case 4: return GnssSolution::kRtkFixed;
    case 5: return GnssSolution::kRtkFloat;
    case 6: return GnssSolution::kInsOnly;
    default: return GnssSolution::kUnknown;
  }
}

InsRecord parse_row(const std::vector<std::string_view>& f, const Line& line, RowContext& ctx) {
  const Indices& ix = ctx.ix;
  InsRecord r;
  r.t_s = row_time(f, line, ctx);
  const double ll = ctx.c.latlon_units == AngleUnit::kRadians ? kDegPerRad : 1.0;
  r.lat_deg = field(f, ix.lat, "latitude", line, ctx) * ll;
  r.lon_deg = field(f, ix.lon, "longitude", line, ctx) * ll;
  r.height_m = field(f, ix.height, "height", line, ctx);
  if (ix.undulation != kNone && ctx.c.height_datum == TextHeightDatum::kMeanSeaLevel) {
    r.height_m += field(f, ix.undulation, "undulation", line, ctx);
  }
  try {
    check_geodetic({r.lat_deg, r.lon_deg, r.height_m});
  } catch (const std::invalid_argument& e) {
    throw InputError(ctx.file, "line " + std::to_string(line.no), e.what());
  }
  r.R_world_ins = row_attitude(field(f, ix.roll, "roll", line, ctx), field(f, ix.pitch, "pitch", line, ctx),
                               field(f, ix.heading, "heading", line, ctx), ctx);
  if (ix.sd_h != kNone) r.position_stddev_m.head<2>().setConstant(field(f, ix.sd_h, "sd-horizontal", line, ctx) / std::sqrt(2.0));
  if (ix.sd_e != kNone) r.position_stddev_m.x() = field(f, ix.sd_e, "sd-east", line, ctx);
  if (ix.sd_n != kNone) r.position_stddev_m.y() = field(f, ix.sd_n, "sd-north", line, ctx);
  if (ix.sd_u != kNone) r.position_stddev_m.z() = field(f, ix.sd_u, "sd-up", line, ctx);
  if (ix.status != kNone) r.solution = row_status(f[ix.status], ctx.c.status_code);
  r.location = "line " + std::to_string(line.no);
  return r;
}

void push_in_order(InsTrack& track, InsRecord r, const std::string& file) {
  if (!track.records.empty() && !(r.t_s > track.records.back().t_s)) {
    throw InputError(file, r.location,
                     fmt::format("time {:.6f} (UNIX) does not come after the previous row's {:.6f} ({}): {}", r.t_s,
                                 track.records.back().t_s, track.records.back().location,
                                 r.t_s == track.records.back().t_s ? "a repeated time" : "time goes backwards"));
  }
  track.records.push_back(std::move(r));
}

std::string time_base_text(const RowContext& ctx, double t0_unix_s) {
  const TextExportColumns& c = ctx.c;
  const std::string leap = fmt::format("converted to UNIX (GPS - UTC = {} s)", gps_minus_utc_s(t0_unix_s));
  switch (c.time_base) {
    case TextTimeBase::kUnix: return fmt::format("UNIX seconds (column '{}')", c.time);
    case TextTimeBase::kGpsSeconds: return fmt::format("GPS seconds since 1980-01-06 (column '{}'), {}", c.time, leap);
    default: break;
  }
  if (ctx.ix.week != kNone) return fmt::format("GPS week (column '{}') + seconds (column '{}'), {}", c.week, c.time, leap);
  return fmt::format("GPS seconds of week (column '{}') of week {} (inferred from the LiDAR clock), {}", c.time,
                     ctx.inferred_week.value_or(-1), leap);
}

void describe(const RowContext& ctx, TextDelimiter delimiter, std::size_t header_line, InsTrack& track) {
  const TextExportColumns& c = ctx.c;
  track.format = fmt::format("text export ({}-delimited, header at line {})", name_of(kDelimiters, delimiter), header_line);
  track.time_base = time_base_text(ctx, track.records.front().t_s);
  switch (c.frame) {
    case TextBodyFrame::kForwardRightDown: track.body_frame = "x forward, y right, z down (aerospace roll, pitch, heading)"; break;
    case TextBodyFrame::kForwardLeftUp: track.body_frame = "x forward, y left, z up (ZYX roll, pitch, yaw)"; break;
    case TextBodyFrame::kRightForwardUp: track.body_frame = "x right, y forward, z up (NovAtel SPAN azimuth, pitch, roll)"; break;
  }
  track.body_frame += c.heading_convention == HeadingConvention::kClockwiseFromNorth ? "; heading clockwise from north"
                                                                                     : "; yaw counter-clockwise from east";
  track.height_datum = c.height_datum == TextHeightDatum::kEllipsoidal
                           ? fmt::format("ellipsoidal (column '{}')", c.height)
                           : fmt::format("mean sea level (column '{}') + undulation (column '{}') -> ellipsoid", c.height, c.undulation);
  track.world_frame = "local ENU at the first fix";
  track.geodetic = true;
}

enum class RowKind { kSkip, kData, kCutShortLast };

// Units rows before the data are skipped; a row whose field count is not the header's is an error
// (a value with spaces in it, such as degrees minutes seconds, would shift every column after it),
// except the last row cut short by an interrupted write.
RowKind classify_row(const std::vector<std::string_view>& f, const Line& line, const Line& header, bool data_started,
                     bool last, const RowContext& ctx) {
  double t = 0.0;
  const bool numeric = count_numeric(f, ctx.decimal_comma) >= 3 && parse_number(f.size() > ctx.ix.time ? f[ctx.ix.time] : "", ctx.decimal_comma, t);
  if (!data_started && !numeric) return RowKind::kSkip;
  if (f.size() == ctx.ix.header_cells) return RowKind::kData;
  if (last && f.size() < ctx.ix.header_cells) return RowKind::kCutShortLast;
  throw InputError(ctx.file, "line " + std::to_string(line.no),
                   fmt::format("{} fields, but the header (line {}) names {} columns: a missing value, or values with "
                               "spaces in them (degrees minutes seconds?); export one decimal number per column",
                               f.size(), header.no, ctx.ix.header_cells));
}

}  // namespace

std::optional<std::vector<std::string>> text_export_header(std::string_view text) {
  const auto lines = content_lines(text);
  const auto h = find_generic_header(lines);
  if (!h) return std::nullopt;
  return header_names(lines[*h].text);
}

InsTrack parse_text_export(std::string_view text, const std::string& file, const TextExportColumns& columns,
                           std::optional<double> lidar_time_hint_unix_s) {
  const auto lines = content_lines(text);
  if (columns.empty()) fail_no_mapping(lines, file);
  validate(columns, "column mapping");
  const auto [header, ix] = locate_header(lines, columns, file);
  InsTrack track;
  track.source = file;
  RowContext ctx{file, columns, ix, false, lidar_time_hint_unix_s, std::nullopt, 0.0};
  TextDelimiter delimiter = columns.delimiter;
  for (std::size_t i = header + 1; i < lines.size(); ++i) {
    if (delimiter == TextDelimiter::kAuto) {
      if (!is_data_row(lines[i].text)) continue;  // a units row before the data
      delimiter = detect_delimiter(lines[i].text);
    }
    ctx.decimal_comma = delimiter == TextDelimiter::kSemicolon;
    const auto f = split_row(lines[i].text, delimiter);
    const RowKind kind = classify_row(f, lines[i], lines[header], !track.records.empty(), i + 1 == lines.size(), ctx);
    if (kind == RowKind::kCutShortLast) {
      ++track.records_skipped;
      track.warnings.push_back(fmt::format("the last row (line {}) is cut short: skipped", lines[i].no));
    }
    if (kind == RowKind::kData) push_in_order(track, parse_row(f, lines[i], ctx), file);
  }
  if (track.records.empty()) throw InputError(file, "", "no data rows after the header");
  describe(ctx, delimiter, lines[header].no, track);
  if (ctx.inferred_week && std::abs(track.records.front().t_s - *lidar_time_hint_unix_s) > 86400.0) {
    track.warnings.push_back("the export starts more than a day from the LiDAR clock: if its times are seconds of the "
                             "day rather than of the GPS week, the week inferred is wrong");
  }
  return track;
}

InsTrack read_text_export(const std::filesystem::path& path, const TextExportColumns& columns,
                          std::optional<double> lidar_time_hint_unix_s) {
  return parse_text_export(read_file(path), path.string(), columns, lidar_time_hint_unix_s);
}

}  // namespace insalign::io
