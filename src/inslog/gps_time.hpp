// GPS time and UNIX time. GPS time runs continuously from 1980-01-06 00:00:00 UTC; UTC (and UNIX
// time) drops a leap second now and then, so GPS = UNIX - 315964800 s + (GPS - UTC), with GPS - UTC
// from the table of leap seconds (CONVENTIONS.md): 15 s in 2011 (KITTI), 18 s since 2017-01-01.
#pragma once

#include <string>

namespace insalign::io {

inline constexpr double kGpsEpochUnixS = 315964800.0;  ///< 1980-01-06 00:00:00 UTC as UNIX time
inline constexpr double kSecondsPerGpsWeek = 604800.0;

/// GPS - UTC (leap seconds) in force at UNIX time `unix_s`: 0 before 1981-07-01, 18 since
/// 2017-01-01 (the last step in the table; a later one needs a new table entry).
int gps_minus_utc_s(double unix_s);

/// GPS seconds since the GPS epoch (week * 604800 + seconds of week) to UNIX time, and back. A GPS
/// time inside an inserted leap second gives the UNIX second before the step again (UNIX repeats it).
double gps_seconds_to_unix(double gps_s);
double unix_to_gps_seconds(double unix_s);

/// GPS week and seconds of week to UNIX time (seconds_of_week may exceed 604800: logs that keep
/// counting past the week's end stay continuous).
double gps_to_unix(int week, double seconds_of_week);

struct GpsWeekSeconds {
  int week = 0;
  double seconds_of_week = 0.0;  ///< [0, 604800)
};
GpsWeekSeconds unix_to_gps(double unix_s);

/// The GPS week for which `seconds_of_week` lies nearest to `unix_hint_s` (e.g. the LiDAR's first
/// stamp): how an SBET, which stores only seconds of week, is dated. Correct while the two clocks
/// differ by less than half a week (3.5 days).
int nearest_gps_week(double seconds_of_week, double unix_hint_s);

/// UNIX time of a UTC calendar date and time (proleptic Gregorian; second may carry a fraction).
double utc_to_unix(int year, int month, int day, int hour, int minute, double second);

/// "2011-09-26 13:02:25.964389445" (UTC) for UNIX time `unix_s`, `decimals` digits after the second.
std::string format_utc(double unix_s, int decimals = 9);

}  // namespace insalign::io
