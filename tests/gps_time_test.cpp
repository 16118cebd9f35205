// GPS time <-> UNIX time with the leap-second table; expected values computed apart (Python's
// datetime from 1980-01-06 with the leap count of the date).
#include <gtest/gtest.h>

#include "inslog/gps_time.hpp"

namespace insalign::io {
namespace {

TEST(GpsTime, GpsEpochIsUnix315964800) {
  EXPECT_DOUBLE_EQ(gps_to_unix(0, 0.0), 315964800.0);
  EXPECT_EQ(gps_minus_utc_s(315964800.0), 0);
}

TEST(GpsTime, LeapSecondsAtTheTableBoundaries) {
  const double y2017 = 1483228800.0;  // 2017-01-01 00:00:00 UTC
  EXPECT_EQ(gps_minus_utc_s(y2017), 18);
  EXPECT_EQ(gps_minus_utc_s(y2017 - 1.0), 17);
  EXPECT_EQ(gps_minus_utc_s(y2017 - 0.001), 17);
  EXPECT_EQ(gps_minus_utc_s(utc_to_unix(2015, 7, 1, 0, 0, 0)), 17);
  EXPECT_EQ(gps_minus_utc_s(utc_to_unix(2015, 6, 30, 23, 59, 59)), 16);
  EXPECT_EQ(gps_minus_utc_s(utc_to_unix(2012, 7, 1, 0, 0, 0)), 16);
  EXPECT_EQ(gps_minus_utc_s(utc_to_unix(2009, 1, 1, 0, 0, 0)), 15);
  EXPECT_EQ(gps_minus_utc_s(utc_to_unix(2011, 9, 26, 13, 2, 25)), 15);  // KITTI raw
  EXPECT_EQ(gps_minus_utc_s(utc_to_unix(2008, 12, 31, 23, 59, 59)), 14);
  EXPECT_EQ(gps_minus_utc_s(utc_to_unix(1981, 7, 1, 0, 0, 0)), 1);
  EXPECT_EQ(gps_minus_utc_s(utc_to_unix(1981, 6, 30, 23, 59, 59)), 0);
  EXPECT_EQ(gps_minus_utc_s(utc_to_unix(2026, 11, 30, 0, 0, 0)), 18);
}

TEST(GpsTime, NovatelExampleTimesToUnix) {
  // NovAtel's OEM7 INSPVAA example, week 2209 490558.000 = 2022-05-13 16:15:40 UTC.
  EXPECT_DOUBLE_EQ(gps_to_unix(2209, 490558.0), 1652458540.0);
  EXPECT_EQ(format_utc(gps_to_unix(2209, 490558.0), 0), "2022-05-13 16:15:40");
  // The SPAN OEM6 INSPVAXA example, week 1695 309428.000 (16 leap seconds in 2012).
  EXPECT_DOUBLE_EQ(gps_to_unix(1695, 309428.0), 1341410212.0);
}

TEST(GpsTime, RoundTripsAcrossLeapSteps) {
  for (const double u0 : {1483228800.0, 1435708800.0, 1341100800.0, 1230768000.0, 1700000000.0}) {
    for (double du = -3.0; du <= 3.0; du += 0.25) {
      const double u = u0 + du;
      EXPECT_NEAR(gps_seconds_to_unix(unix_to_gps_seconds(u)), u, 1e-6) << u;
      const GpsWeekSeconds g = unix_to_gps(u);
      EXPECT_GE(g.seconds_of_week, 0.0);
      EXPECT_LT(g.seconds_of_week, kSecondsPerGpsWeek);
      EXPECT_NEAR(gps_to_unix(g.week, g.seconds_of_week), u, 1e-6);
    }
  }
  // The second after the step: GPS runs on while UTC repeats 23:59:59 -> GPS is one more ahead.
  EXPECT_DOUBLE_EQ(unix_to_gps_seconds(1483228800.0) - unix_to_gps_seconds(1483228799.0), 2.0);
  // Inside the inserted second (23:59:60) UNIX time repeats 23:59:59, never runs backwards.
  const double g_step = 1483228800.0 - kGpsEpochUnixS + 18.0;
  EXPECT_DOUBLE_EQ(gps_seconds_to_unix(g_step - 0.5), 1483228799.5);
  EXPECT_DOUBLE_EQ(gps_seconds_to_unix(g_step - 1.5), 1483228799.5);
  EXPECT_DOUBLE_EQ(gps_seconds_to_unix(g_step), 1483228800.0);
}

TEST(GpsTime, NearestWeekForSecondsOfWeek) {
  const GpsWeekSeconds g = unix_to_gps(1700000000.0);
  EXPECT_EQ(nearest_gps_week(g.seconds_of_week, 1700000000.0), g.week);
  EXPECT_EQ(nearest_gps_week(g.seconds_of_week, 1700000000.0 + 3 * 3600.0), g.week);   // LiDAR 3 h (time zone) off
  EXPECT_EQ(nearest_gps_week(g.seconds_of_week, 1700000000.0 - 3.0 * 86400.0), g.week);  // 3 days off
  // Seconds near the end of a week, LiDAR clock just after the week changed: still the old week.
  EXPECT_EQ(nearest_gps_week(604790.0, gps_to_unix(2290, 604790.0) + 20.0), 2290);
  EXPECT_EQ(nearest_gps_week(5.0, gps_to_unix(2291, 5.0) - 20.0), 2291);
}

TEST(GpsTime, UtcCalendarRoundTrip) {
  EXPECT_DOUBLE_EQ(utc_to_unix(2011, 9, 26, 13, 2, 25.0), 1317042145.0);
  EXPECT_EQ(format_utc(1317042145.964389, 6), "2011-09-26 13:02:25.964389");
  EXPECT_EQ(format_utc(1317042145.9999999999, 3), "2011-09-26 13:02:26.000");  // rounding carries
  EXPECT_EQ(format_utc(951782400.0, 0), "2000-02-29 00:00:00");
  EXPECT_EQ(format_utc(0.0, 1), "1970-01-01 00:00:00.0");
}

}  // namespace
}  // namespace insalign::io
