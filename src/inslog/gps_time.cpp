#include "inslog/gps_time.hpp"

#include <fmt/format.h>

#include <array>
#include <cmath>

namespace insalign::io {
namespace {

// Days since 1970-01-01 of a proleptic Gregorian date (civil calendar arithmetic).
constexpr long long days_from_civil(long long y, unsigned m, unsigned d) {
  y -= m <= 2;
  const long long era = (y >= 0 ? y : y - 399) / 400;
  const unsigned yoe = static_cast<unsigned>(y - era * 400);
  const unsigned doy = (153 * (m > 2 ? m - 3 : m + 9) + 2) / 5 + d - 1;
  const unsigned doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  return era * 146097 + static_cast<long long>(doe) - 719468;
}

struct LeapStep {
  int year, month;  ///< the step takes effect at 00:00:00 UTC on the 1st of this month
  int gps_minus_utc_s;
};

// IERS Bulletin C history: every leap second since the GPS epoch.
constexpr std::array<LeapStep, 18> kLeapSteps = {{
    {1981, 7, 1},  {1982, 7, 2},  {1983, 7, 3},  {1985, 7, 4},  {1988, 1, 5},  {1990, 1, 6},
    {1991, 1, 7},  {1992, 7, 8},  {1993, 7, 9},  {1994, 7, 10}, {1996, 1, 11}, {1997, 7, 12},
    {1999, 1, 13}, {2006, 1, 14}, {2009, 1, 15}, {2012, 7, 16}, {2015, 7, 17}, {2017, 1, 18},
}};

constexpr double step_unix_s(const LeapStep& s) {
  return static_cast<double>(days_from_civil(s.year, static_cast<unsigned>(s.month), 1) * 86400);
}

}  // namespace

int gps_minus_utc_s(double unix_s) {
  int leap = 0;
  for (const LeapStep& s : kLeapSteps) {
    if (unix_s >= step_unix_s(s)) leap = s.gps_minus_utc_s;
  }
  return leap;
}

double unix_to_gps_seconds(double unix_s) { return unix_s - kGpsEpochUnixS + gps_minus_utc_s(unix_s); }

double gps_seconds_to_unix(double gps_s) {
  // The leap second inserted before UTC T_i starts at GPS time T_i - epoch + (new count - 1); inside
  // it, UNIX time repeats the second before T_i, as UNIX clocks do.
  int leap = 0;
  for (const LeapStep& s : kLeapSteps) {
    if (gps_s >= step_unix_s(s) - kGpsEpochUnixS + s.gps_minus_utc_s - 1) leap = s.gps_minus_utc_s;
  }
  return gps_s + kGpsEpochUnixS - leap;
}

double gps_to_unix(int week, double seconds_of_week) {
  return gps_seconds_to_unix(static_cast<double>(week) * kSecondsPerGpsWeek + seconds_of_week);
}

GpsWeekSeconds unix_to_gps(double unix_s) {
  const double gps_s = unix_to_gps_seconds(unix_s);
  GpsWeekSeconds out;
  out.week = static_cast<int>(std::floor(gps_s / kSecondsPerGpsWeek));
  out.seconds_of_week = gps_s - static_cast<double>(out.week) * kSecondsPerGpsWeek;
  return out;
}

int nearest_gps_week(double seconds_of_week, double unix_hint_s) {
  const double gps_hint_s = unix_to_gps_seconds(unix_hint_s);
  return static_cast<int>(std::lround((gps_hint_s - seconds_of_week) / kSecondsPerGpsWeek));
}

double utc_to_unix(int year, int month, int day, int hour, int minute, double second) {
  const long long days = days_from_civil(year, static_cast<unsigned>(month), static_cast<unsigned>(day));
  return static_cast<double>(days * 86400 + hour * 3600 + minute * 60) + second;
}

std::string format_utc(double unix_s, int decimals) {
  const double scale = std::pow(10.0, decimals);
  long long whole = static_cast<long long>(std::floor(unix_s));
  long long frac = std::llround((unix_s - static_cast<double>(whole)) * scale);
  if (frac >= static_cast<long long>(scale)) {  // rounding carried into the next second
    frac -= static_cast<long long>(scale);
    ++whole;
  }
  // Civil date from days since 1970-01-01 (inverse of days_from_civil).
  long long z = (whole >= 0 ? whole : whole - 86399) / 86400;
  const long long secs = whole - z * 86400;
  z += 719468;
  const long long era = (z >= 0 ? z : z - 146096) / 146097;
  const long long doe = z - era * 146097;
  const long long yoe = (doe - doe / 1460 + doe / 36524 - doe / 146096) / 365;
  const long long doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
  const long long mp = (5 * doy + 2) / 153;
  const long long d = doy - (153 * mp + 2) / 5 + 1;
  const long long m = mp < 10 ? mp + 3 : mp - 9;
  const long long y = yoe + era * 400 + (m <= 2);
  std::string out = fmt::format("{:04}-{:02}-{:02} {:02}:{:02}:{:02}", y, m, d, secs / 3600, secs / 60 % 60, secs % 60);
  if (decimals > 0) out += fmt::format(".{:0{}}", frac, decimals);
  return out;
}

}  // namespace insalign::io
