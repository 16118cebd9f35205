// Text exports: the column spec, exports laid out as Inertial Explorer and POSPac write them
// (hand-formatted here), delimiters, conventions, bad input, and the writer read back.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include "core/errors.hpp"
#include "ins_log_test_util.hpp"
#include "inslog/gps_time.hpp"
#include "inslog/ins_log.hpp"
#include "inslog/ins_log_writer.hpp"
#include "inslog/text_export.hpp"

namespace insalign::io {
namespace {

Mat3 axes_matrix(const Vec3& x, const Vec3& y, const Vec3& z) {
  Mat3 R;
  R.col(0) = x, R.col(1) = y, R.col(2) = z;
  return R;
}

const char* kIeSpec =
    "time=GPSTime:gps-sow,week=Week,lat=Latitude,lon=Longitude,height=H-Ell,roll=Roll,pitch=Pitch,"
    "heading=Heading:cw-from-north,units=deg,frame=x-right-y-forward-z-up,sd-east=SDEast,sd-north=SDNorth,"
    "sd-up=SDHeight,status=Q:ie-quality";
const char* kPospacSpec =
    "time=TIME:gps-sow,lat=LATITUDE,lon=LONGITUDE,height=ELLIPSOID HEIGHT,roll=ROLL,pitch=PITCH,"
    "heading=HEADING:cw-from-north,units=deg,frame=x-forward-y-right-z-down,sd-east=EAST SD,sd-north=NORTH SD,"
    "sd-up=HEIGHT SD";

void expect_spec_error(const std::string& spec, const std::string& words) {
  try {
    parse_text_export_columns(spec);
    FAIL() << "no error for " << spec;
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "--poses-columns");
    EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
  }
}

TEST(TextExport, ParsesTheCompactColumnSpec) {
  const TextExportColumns c = parse_text_export_columns(
      "time=GPSTime:gps-sow,lat=Latitude,lon=Longitude,height=H-Ell,roll=Roll,pitch=Pitch,heading=Heading:cw-from-north,"
      "units=deg,frame=x-forward-y-right-z-down");
  EXPECT_EQ(c.time, "GPSTime");
  EXPECT_EQ(c.time_base, TextTimeBase::kGpsSecondsOfWeek);
  EXPECT_EQ(c.height, "H-Ell");
  EXPECT_EQ(c.heading_convention, HeadingConvention::kClockwiseFromNorth);
  EXPECT_EQ(c.frame, TextBodyFrame::kForwardRightDown);
  const TextExportColumns q = parse_text_export_columns(
      "time=\"t:s\":unix, lat=phi, lon=lambda, latlon-units=rad, height=h_msl:msl, undulation=N, roll=r, pitch=p, "
      "yaw=psi, units=rad, frame=x-forward-y-left-z-up, sd-horizontal=sdh, status=fix:gga, delimiter=semicolon");
  EXPECT_EQ(q.time, "t:s");
  EXPECT_EQ(q.latlon_units, AngleUnit::kRadians);
  EXPECT_EQ(q.height_datum, TextHeightDatum::kMeanSeaLevel);
  EXPECT_EQ(q.heading, "psi");
  EXPECT_EQ(q.heading_convention, HeadingConvention::kCounterClockwiseFromEast);
  EXPECT_EQ(q.status_code, StatusCode::kGga);
  EXPECT_EQ(q.delimiter, TextDelimiter::kSemicolon);
  // The spec format_text_export_columns writes parses back to the same mapping.
  for (const std::string& spec : {std::string(kIeSpec), std::string(kPospacSpec), format_text_export_columns(q)}) {
    const TextExportColumns a = parse_text_export_columns(spec);
    const TextExportColumns b = parse_text_export_columns(format_text_export_columns(a));
    EXPECT_EQ(format_text_export_columns(a), format_text_export_columns(b));
    EXPECT_EQ(a.height, b.height);
    EXPECT_EQ(a.sd_east, b.sd_east);
  }
}

TEST(TextExport, SpecErrorsNameTheKey) {
  expect_spec_error("time=t,lat=a,lon=b,height=h,roll=r,pitch=p,heading=y,colour=red", "unknown key 'colour'");
  expect_spec_error("time=t:gps-day,lat=a,lon=b,height=h,roll=r,pitch=p,heading=y", "unix|gps-sow|gps-week-seconds|gps");
  expect_spec_error("time=t,lat=a,lon=b,height=h,roll=r,pitch=p", "heading=COLUMN");
  expect_spec_error("time=t,lat=a,lon=b,height=h:msl,roll=r,pitch=p,heading=y", "undulation");
  expect_spec_error("time=t:gps-week-seconds,lat=a,lon=b,height=h,roll=r,pitch=p,heading=y", "week");
  expect_spec_error("time=t,lat=a,lon=b,height=h,roll=r,pitch=p,heading=y,frame=x-up", "x-forward-y-right-z-down");
  expect_spec_error("time=t,lat", "not key=value");
  expect_spec_error("time=\"t,lat=a", "unbalanced");
}

// Inertial Explorer's layout: a preamble, a whitespace header, a units row, whitespace rows.
std::string ie_export(int n) {
  std::string s =
      "Project:     drive_0412\nProgram:     Inertial Explorer Version 8.90\nProfile:     insalign test\n"
      "Source:      GNSS/INS Epochs(Combined)\n\n"
      "     GPSTime  Week      Latitude      Longitude        H-Ell      Roll     Pitch    Heading  SDEast SDNorth SDHeight Q\n"
      "       (sec)                (deg)          (deg)          (m)     (deg)     (deg)      (deg)     (m)     (m)      (m)  \n";
  for (int i = 0; i < n; ++i) {
    s += fmt::format("{:12.3f}  2290  {:.10f}  {:.10f}  {:10.4f}  {:.6f}  {:.6f}  {:.6f}  0.012  0.013  0.025  {}\n",
                     400000.0 + 0.1 * i, 51.0 + 1e-6 * i, -114.0, 1050.0 + 0.01 * i, 1.0, 2.0, 10.0 * i, i < 5 ? 1 : 2);
  }
  return s;
}

TEST(TextExport, InertialExplorerLayout) {
  const auto path = test::scratch_dir("ie") / "drive_0412.txt";
  test::write_text(path, ie_export(20));
  ASSERT_EQ(detect_ins_log(path), InsLogFormat::kTextExport);
  const InsTrack t = read_text_export(path, parse_text_export_columns(kIeSpec));
  ASSERT_EQ(t.records.size(), 20u);
  for (int i = 0; i < 20; ++i) {
    const InsRecord& r = t.records[i];
    EXPECT_NEAR(r.t_s, gps_to_unix(2290, 400000.0 + 0.1 * i), 1e-6);
    EXPECT_NEAR(r.lat_deg, 51.0 + 1e-6 * i, 1e-11);
    EXPECT_NEAR(r.height_m, 1050.0 + 0.01 * i, 1e-9);
    const auto a = test::vehicle_axes(10.0 * i, 2.0, 1.0);  // SPAN: x right, y forward, z up
    EXPECT_LT(test::angle_deg(r.R_world_ins, axes_matrix(a.right, a.forward, a.up)), 1e-7);
    EXPECT_NEAR(r.position_stddev_m.x(), 0.012, 1e-12);
    EXPECT_NEAR(r.position_stddev_m.z(), 0.025, 1e-12);
    EXPECT_EQ(r.solution, i < 5 ? GnssSolution::kRtkFixed : GnssSolution::kRtkFloat);
  }
  EXPECT_NE(t.format.find("header at line 6"), std::string::npos) << t.format;
  EXPECT_NE(t.time_base.find("GPS week (column 'Week')"), std::string::npos) << t.time_base;
}

// POSPac's export utility: a comma-separated header (ELLIPSOID HEIGHT twice) over whitespace numbers.
std::string pospac_export(int n) {
  std::string s =
      "*****************\n POS Export Utility\n*****************\n Mapping frame datum: WGS84\n"
      " TIME, DISTANCE, EASTING, NORTHING, ELLIPSOID HEIGHT, LATITUDE, LONGITUDE, ELLIPSOID HEIGHT, ROLL, PITCH, HEADING,"
      " EAST VELOCITY, NORTH VELOCITY, UP VELOCITY, EAST SD, NORTH SD, HEIGHT SD, ROLL SD, PITCH SD, HEADING SD\n\n"
      "  (time in Sec, distance in Meters, position in Meters, lat, long in Degrees, orientation angles and SD in Degrees,"
      " velocity in Meter/Sec, position SD in Meters)\n";
  for (int i = 0; i < n; ++i) {
    s += fmt::format("{:.4f} {:.3f} 500000.000 5400000.000 {:.3f} {:.10f} {:.10f} {:.3f} {:.6f} {:.6f} {:.6f} 0 10 0 "
                     "0.02 0.03 0.05 0.005 0.005 0.01\n",
                     86400.0 + 0.05 * i, 0.5 * i, 80.0, 48.5, 9.0 + 1e-6 * i, 80.0, -0.5, 1.25, 359.0);
  }
  return s;
}

TEST(TextExport, PospacLayoutWithTheWeekFromTheLidarClock) {
  const auto path = test::scratch_dir("pospac") / "export.txt";
  test::write_text(path, pospac_export(10));
  ASSERT_EQ(detect_ins_log(path), InsLogFormat::kTextExport);
  const double hint = gps_to_unix(2291, 86400.0 + 3600.0);
  const InsTrack t = read_text_export(path, parse_text_export_columns(kPospacSpec), hint);
  ASSERT_EQ(t.records.size(), 10u);
  EXPECT_NEAR(t.records[3].t_s, gps_to_unix(2291, 86400.15), 1e-6);
  EXPECT_NEAR(t.records[3].lon_deg, 9.0 + 3e-6, 1e-11);
  EXPECT_NEAR(t.records[3].height_m, 80.0, 1e-9);
  const auto a = test::vehicle_axes(359.0, 1.25, -0.5);  // x forward, y right, z down
  EXPECT_LT(test::angle_deg(t.records[3].R_world_ins, axes_matrix(a.forward, a.right, -a.up)), 1e-7);
  EXPECT_NEAR(t.records[3].position_stddev_m.y(), 0.03, 1e-12);
  EXPECT_NE(t.time_base.find("week 2291 (inferred from the LiDAR clock)"), std::string::npos) << t.time_base;
  // Without the LiDAR's time the week is unknown.
  EXPECT_THROW(read_text_export(path, parse_text_export_columns(kPospacSpec)), InputError);
}

TEST(TextExport, SemicolonsDecimalCommasRadiansYawAndMeanSeaLevel) {
  const std::string text =
      "t_unix;phi;lambda;h_msl;N;r;p;psi;fix\n"
      "1700000000,5;0,8552113334772;0,1396263401595;10,0;47,5;0,01;-0,02;1,5707963267949;4\n"
      "1700000000,6;0,8552113334772;0,1396263401595;10,1;47,5;0,01;-0,02;3,14159265358979;5\n";
  const TextExportColumns c = parse_text_export_columns(
      "time=t_unix:unix,lat=phi,lon=lambda,latlon-units=rad,height=h_msl:msl,undulation=N,roll=r,pitch=p,yaw=psi,"
      "units=rad,frame=x-forward-y-left-z-up,status=fix:gga");
  const InsTrack t = parse_text_export(text, "in-house.csv", c);
  ASSERT_EQ(t.records.size(), 2u);
  EXPECT_DOUBLE_EQ(t.records[0].t_s, 1700000000.5);
  EXPECT_NEAR(t.records[0].lat_deg, 49.0, 1e-9);
  EXPECT_NEAR(t.records[0].lon_deg, 8.0, 1e-9);
  EXPECT_NEAR(t.records[1].height_m, 10.1 + 47.5, 1e-9);
  // yaw pi/2 counter-clockwise from east = facing north; ENU pitch -0.02 rad = nose up.
  const auto a = test::vehicle_axes(0.0, 0.02 * 180 / M_PI, 0.01 * 180 / M_PI);
  EXPECT_LT(test::angle_deg(t.records[0].R_world_ins, axes_matrix(a.forward, -a.right, a.up)), 1e-7);
  EXPECT_EQ(t.records[0].solution, GnssSolution::kRtkFixed);
  EXPECT_EQ(t.records[1].solution, GnssSolution::kRtkFloat);
}

TEST(TextExport, HeadingConventionsAndGpsSecondsAgree) {
  // The same attitude written as heading clockwise from north and as yaw counter-clockwise from east.
  const std::string text = "gps,lat,lon,h,roll,pitch,hdg\n1384000000.25,45,7,100,3,4,30\n";
  const auto cw = parse_text_export(text, "a.csv", parse_text_export_columns(
      "time=gps:gps,lat=lat,lon=lon,height=h,roll=roll,pitch=pitch,heading=hdg:cw-from-north"));
  const auto ccw = parse_text_export("gps,lat,lon,h,roll,pitch,hdg\n1384000000.25,45,7,100,3,4,60\n", "b.csv",
                                     parse_text_export_columns("time=gps:gps,lat=lat,lon=lon,height=h,roll=roll,"
                                                               "pitch=pitch,heading=hdg:ccw-from-east"));
  EXPECT_LT(test::angle_deg(cw.records[0].R_world_ins, ccw.records[0].R_world_ins), 1e-9);
  EXPECT_NEAR(cw.records[0].t_s, gps_seconds_to_unix(1384000000.25), 1e-6);
}

TEST(TextExport, WithoutAMappingTheErrorListsTheColumnsAndAMapping) {
  const auto path = test::scratch_dir("nomap") / "ie.txt";
  test::write_text(path, ie_export(3));
  try {
    read_ins_log(path, InsLogFormat::kTextExport);
    FAIL();
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_EQ(e.location(), "line 6");
    EXPECT_NE(what.find("GPSTime, Week, Latitude, Longitude, H-Ell"), std::string::npos) << what;
    EXPECT_NE(what.find("Inertial Explorer"), std::string::npos) << what;
    EXPECT_NE(what.find("frame=x-right-y-forward-z-up"), std::string::npos) << what;
  }
  test::write_text(path, pospac_export(3));
  try {
    read_ins_log(path, InsLogFormat::kTextExport);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("POSPac"), std::string::npos) << e.what();
  }
}

void expect_row_error(const std::string& text, const std::string& location, const std::string& words) {
  const auto c = parse_text_export_columns("time=t,lat=lat,lon=lon,height=h,roll=r,pitch=p,heading=y");
  try {
    parse_text_export(text, "rows.csv", c);
    FAIL() << "no error for " << words;
  } catch (const InputError& e) {
    EXPECT_EQ(e.location(), location) << e.what();
    EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
  }
}

TEST(TextExport, BadRowsNameTheLine) {
  const std::string h = "t,lat,lon,h,r,p,y\n";
  expect_row_error(h + "1,45,7,0,0,0,0\n2,91,7,0,0,0,0\n", "line 3", "latitude");
  expect_row_error(h + "1,45,7,0,0,0,0\n2,45,7,0,nan,0,0\n", "line 3", "roll");
  expect_row_error(h + "1,45,7,0,0,0,0\n3,45,7,0,0,0,0\n2,45,7,0,0,0,0\n", "line 4", "time goes backwards");
  expect_row_error(h + "1,45,7,0,0,0,0\n1,45,7,0,0,0,0\n", "line 3", "repeated time");
  expect_row_error(h + "1,45,7,0,0,0,0\n2,45,7\n3,45,7,0,0,0,0\n", "line 3", "3 fields");
  expect_row_error("t,lat,lon,h,r,p\n1,45,7,0,0,0\n", "line 1", "no column 'y'");
  // Degrees minutes seconds in a whitespace export: more fields than the header names, not shifted columns.
  const auto ie = parse_text_export_columns("time=GPSTime:gps,lat=Latitude,lon=Longitude,height=H-Ell,roll=Roll,pitch=Pitch,heading=Heading");
  try {
    parse_text_export("GPSTime Latitude Longitude H-Ell Roll Pitch Heading\n"
                      "1384000000.0 51 07 12.34 -114 02 11.1 1050.0 1.0 2.0 30.0\n", "dms.txt", ie);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.location(), "line 2");
    EXPECT_NE(std::string(e.what()).find("degrees minutes seconds"), std::string::npos) << e.what();
  }
  // A cut-short LAST row is an interrupted write: skipped and counted.
  const auto c = parse_text_export_columns("time=t,lat=lat,lon=lon,height=h,roll=r,pitch=p,heading=y");
  const InsTrack t = parse_text_export(h + "1,45,7,0,0,0,0\n2,45,7,0,0,0,0\n3,45,7,0", "cut.csv", c);
  EXPECT_EQ(t.records.size(), 2u);
  EXPECT_EQ(t.records_skipped, 1u);
}

TEST(TextExport, WriterReadsBackToThePoses) {
  const auto poses = test::synthetic_drive();
  std::vector<InsQuality> quality(poses.size());
  for (std::size_t i = 0; i < quality.size(); ++i) {
    quality[i].solution = i % 3 == 0 ? GnssSolution::kRtkFixed : i % 3 == 1 ? GnssSolution::kRtkFloat : GnssSolution::kInsOnly;
    quality[i].horizontal_stddev_m = 0.03, quality[i].vertical_stddev_m = 0.05;
  }
  InsLogWriteOptions options;
  options.origin = {35.68, 139.69, 40.0};
  const auto path = test::scratch_dir("csv-writer") / "ins.csv";
  write_text_export(path, poses, quality, options);
  ASSERT_EQ(detect_ins_log(path), InsLogFormat::kTextExport);
  InsLogOptions read_options;
  read_options.columns = text_export_writer_columns();
  const InsTrack track = read_ins_log(path, InsLogFormat::kTextExport, read_options);
  const WorldTrack world = to_world(track, options.origin);
  const test::PoseDiff d = test::compare(world.poses, poses);
  EXPECT_LT(d.max_m, 1e-3);
  EXPECT_LT(d.max_deg, 1e-3);
  EXPECT_LT(d.max_dt_s, 1e-5);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(world.quality[i].solution, quality[i].solution);
    EXPECT_NEAR(world.quality[i].horizontal_stddev_m, 0.03, 1e-4);
  }
}

}  // namespace
}  // namespace insalign::io
