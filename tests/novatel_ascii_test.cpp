// NovAtel OEM7 ASCII: the example records of NovAtel's own documentation (CRC and decoded values),
// logs hand-formatted here with their CRC from a second, bitwise implementation, bad input, and the
// writer read back.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include "core/errors.hpp"
#include "ins_log_test_util.hpp"
#include "inslog/gps_time.hpp"
#include "inslog/ins_log.hpp"
#include "inslog/ins_log_writer.hpp"
#include "inslog/novatel_ascii.hpp"

namespace insalign::io {
namespace {

// docs.novatel.com OEM7 logs INSPVA, INSPVAS, INSPVAX ("ASCII Example"), the SPAN on OEM6 manual's
// INSPVAXA example, and APN-030's BESTPOSA (the CRC application note), verbatim.
const std::string kDocInspvaa =
    "#INSPVAA,USB1,0,67.5,FINESTEERING,2209,490558.000,02000020,18bc,16809;2209,490558.000000000,51.15043714042,"
    "-114.03067871718,1080.3548,0.0051,-0.0014,-0.0012,-0.296402993,0.311887972,157.992156267,INS_SOLUTION_GOOD*cc698020";
const std::string kDocInspvasa =
    "%INSPVASA,2209,490712.000;2209,490712.000000000,51.15043713712,-114.03067872932,1080.3580,0.0014,-0.0007,0.0015,"
    "-0.293782412,0.302470613,157.989827209,INS_SOLUTION_GOOD*a87ab88b";
const std::string kDocInspvaxa =
    "#INSPVAXA,USB1,0,65.5,FINESTEERING,2209,490782.000,02000020,46eb,16809;INS_SOLUTION_GOOD,INS_PPP,51.15043710672,"
    "-114.03067871892,1097.3598,-17.0001,-0.0016,0.0002,0.0029,-0.308665944,0.297893298,157.960833016,0.1816,0.1816,"
    "0.1808,0.0018,0.0018,0.0016,0.0292,0.0292,0.0582,13000045,0*a74644a2";
const std::string kSpanOem6Inspvaxa =
    "#INSPVAXA,COM1,0,73.5,FINESTEERING,1695,309428.000,00000040,4e77,43562;INS_SOLUTION_GOOD,INS_PSRSP,51.11637873403,"
    "-114.03825114994,1063.6093,-16.9000,-0.0845,-0.0464,-0.0127,0.138023492,0.069459386,90.000923268,0.9428,0.6688,"
    "1.4746,0.0430,0.0518,0.0521,0.944295466,0.944567084,1.000131845,3,0*e877c178";
const std::string kApn030Bestposa =
    "#BESTPOSA,COM1,0,65.5,FINESTEERING,1254,412250.000,00000000,4ca6,34084;SOL_COMPUTED,SINGLE,51.11638281392,"
    "-114.03823667672,1057.5312,-16.2713,WGS84,1.7067,1.3294,2.6578,\"\",0.000,0.000,8,8,0,0,0,0,0,0*f8a1c3e1";

std::uint32_t stated_crc(const std::string& record) { return std::stoul(record.substr(record.find('*') + 1), nullptr, 16); }
std::string crc_body(const std::string& record) { return record.substr(1, record.find('*') - 1); }

// R_enu_ins of the SPAN vehicle frame from first principles (x right, y forward, z up).
Mat3 span_rotation(double roll, double pitch, double azimuth) {
  const auto a = test::vehicle_axes(azimuth, pitch, roll);
  Mat3 R;
  R.col(0) = a.right, R.col(1) = a.forward, R.col(2) = a.up;
  return R;
}

TEST(NovatelAscii, CrcOfNovatelsDocumentationExamples) {
  for (const std::string& r : {kDocInspvaa, kDocInspvasa, kDocInspvaxa, kSpanOem6Inspvaxa, kApn030Bestposa}) {
    EXPECT_EQ(novatel_crc32(crc_body(r)), stated_crc(r)) << r.substr(0, 10);
    EXPECT_EQ(test::bitwise_novatel_crc(crc_body(r)), stated_crc(r));
  }
  EXPECT_EQ(novatel_crc32(""), 0u);  // initial value 0, no final XOR (not zlib's CRC-32)
}

TEST(NovatelAscii, DecodesNovatelsInspvaaExample) {
  const InsTrack t = parse_novatel_ascii(kDocInspvaa + "\r\n", "doc.log");
  ASSERT_EQ(t.records.size(), 1u);
  const InsRecord& r = t.records[0];
  EXPECT_DOUBLE_EQ(r.t_s, 1652458540.0);  // 2022-05-13 16:15:40 UTC
  EXPECT_DOUBLE_EQ(r.lat_deg, 51.15043714042);
  EXPECT_DOUBLE_EQ(r.lon_deg, -114.03067871718);
  EXPECT_DOUBLE_EQ(r.height_m, 1080.3548);  // INSPVA: ellipsoidal
  EXPECT_LT(test::angle_deg(r.R_world_ins, span_rotation(-0.296402993, 0.311887972, 157.992156267)), 1e-9);
  EXPECT_EQ(r.solution, GnssSolution::kUnknown);  // INSPVA has no position type
  EXPECT_TRUE(t.geodetic);
  EXPECT_NE(t.format.find("#INSPVAA"), std::string::npos);
  EXPECT_NE(t.body_frame.find("x right, y forward, z up"), std::string::npos);
  EXPECT_NE(t.time_base.find("FINESTEERING"), std::string::npos);
  EXPECT_NE(t.time_base.find("18 s"), std::string::npos);
}

TEST(NovatelAscii, DecodesNovatelsInspvasaExample) {
  const InsTrack t = parse_novatel_ascii(kDocInspvasa + "\n", "doc.log");
  ASSERT_EQ(t.records.size(), 1u);
  EXPECT_DOUBLE_EQ(t.records[0].t_s, 1652458540.0 + 154.0);
  EXPECT_DOUBLE_EQ(t.records[0].height_m, 1080.3580);
  EXPECT_LT(test::angle_deg(t.records[0].R_world_ins, span_rotation(-0.293782412, 0.302470613, 157.989827209)), 1e-9);
  EXPECT_NE(t.format.find("%INSPVASA"), std::string::npos);
}

TEST(NovatelAscii, DecodesNovatelsInspvaxaExampleWithUndulationAndStddev) {
  const InsTrack t = parse_novatel_ascii(kDocInspvaxa + "\r\n", "doc.log");
  ASSERT_EQ(t.records.size(), 1u);
  const InsRecord& r = t.records[0];
  EXPECT_DOUBLE_EQ(r.t_s, 1652458540.0 + 224.0);  // header time 490782.000
  EXPECT_NEAR(r.height_m, 1097.3598 - 17.0001, 1e-9);  // MSL + undulation; INSPVAA said 1080.3548 at the same spot
  EXPECT_NEAR(r.position_stddev_m.x(), 0.1816, 1e-12);  // longitude sd = east
  EXPECT_NEAR(r.position_stddev_m.y(), 0.1816, 1e-12);
  EXPECT_NEAR(r.position_stddev_m.z(), 0.1808, 1e-12);
  EXPECT_EQ(r.solution, GnssSolution::kDifferential);  // INS_PPP
  EXPECT_LT(test::angle_deg(r.R_world_ins, span_rotation(-0.308665944, 0.297893298, 157.960833016)), 1e-9);
  EXPECT_NE(t.height_datum.find("mean sea level"), std::string::npos);

  const InsTrack old = parse_novatel_ascii(kSpanOem6Inspvaxa + "\r\n", "oem6.log");
  ASSERT_EQ(old.records.size(), 1u);
  EXPECT_DOUBLE_EQ(old.records[0].t_s, 1341410212.0);  // 2012: 16 leap seconds
  EXPECT_EQ(old.records[0].solution, GnssSolution::kSingle);  // INS_PSRSP
  EXPECT_NEAR(old.records[0].height_m, 1063.6093 - 16.9, 1e-9);
}

TEST(NovatelAscii, OtherRecordsAreCountedAndIgnored) {
  const std::string log = kApn030Bestposa + "\r\n" + kDocInspvaa + "\r\n" + kApn030Bestposa + "\r\n" + kDocInspvasa + "\r\n";
  const InsTrack t = parse_novatel_ascii(log, "mixed.log");
  ASSERT_EQ(t.records.size(), 2u);
  EXPECT_EQ(t.records[0].location, "line 2");
  EXPECT_EQ(t.records_skipped, 0u);
  bool mentioned = false;
  for (const auto& w : t.warnings) mentioned |= w.find("#BESTPOSA 2") != std::string::npos;
  EXPECT_TRUE(mentioned);
}

// A hand-formatted INSPVAXA log (fmt + the bitwise CRC), a drive east then north.
struct HandLog {
  std::string text;
  std::vector<double> sow;
};
HandLog hand_inspvax_log(int n, double lat0 = 49.0) {
  HandLog log;
  for (int i = 0; i < n; ++i) {
    const double sow = 300000.0 + 0.1 * i;
    const std::string content = fmt::format(
        "INSPVAXA,COM1,0,50.0,FINESTEERING,2290,{:.3f},02000020,46eb,16809;INS_SOLUTION_GOOD,INS_RTKFIXED,{:.11f},"
        "8.00000000000,{:.4f},47.5000,0.0000,1.0000,0.0000,0.5,-0.25,{:.9f},0.0100,0.0110,0.0200,0.01,0.01,0.01,0.01,0.01,"
        "0.02,00000000,0",
        sow, lat0 + 1e-6 * i, 100.0 + 0.01 * i, 90.0 - 0.5 * i);
    log.text += test::novatel_record_line('#', content);
    log.sow.push_back(sow);
  }
  return log;
}

TEST(NovatelAscii, HandFormattedInspvaxLog) {
  const HandLog log = hand_inspvax_log(50);
  const InsTrack t = parse_novatel_ascii(log.text, "hand.log");
  ASSERT_EQ(t.records.size(), 50u);
  for (int i = 0; i < 50; ++i) {
    const InsRecord& r = t.records[i];
    EXPECT_NEAR(r.t_s, gps_to_unix(2290, log.sow[i]), 1e-6);
    EXPECT_NEAR(r.lat_deg, 49.0 + 1e-6 * i, 1e-12);
    EXPECT_NEAR(r.height_m, 100.0 + 0.01 * i + 47.5, 1e-9);
    EXPECT_LT(test::angle_deg(r.R_world_ins, span_rotation(0.5, -0.25, 90.0 - 0.5 * i)), 1e-8);
    EXPECT_EQ(r.solution, GnssSolution::kRtkFixed);
  }
}

TEST(NovatelAscii, BadCrcRecordsAreSkippedAndCounted) {
  HandLog log = hand_inspvax_log(100);
  // Corrupt one digit of records 20, 40 and 60 (lines 21, 41, 61): the CRC no longer matches.
  std::vector<std::string> lines;
  for (std::size_t pos = 0, nl; (nl = log.text.find('\n', pos)) != std::string::npos; pos = nl + 1) {
    lines.push_back(log.text.substr(pos, nl - pos + 1));
  }
  for (const int i : {20, 40, 60}) lines[i][lines[i].find("INS_RTKFIXED,") + 14] ^= 1;
  std::string text;
  for (const auto& l : lines) text += l;
  const InsTrack t = parse_novatel_ascii(text, "crc.log");
  EXPECT_EQ(t.records.size(), 97u);
  EXPECT_EQ(t.records_skipped, 3u);
  bool said = false;
  for (const auto& w : t.warnings) said |= w.find("3 of 100") != std::string::npos && w.find("line 21") != std::string::npos;
  EXPECT_TRUE(said);
}

TEST(NovatelAscii, ManyBadCrcRecordsAreAnInputError) {
  const HandLog log = hand_inspvax_log(100);
  std::string text = log.text;
  for (int i = 0, pos = 0; i < 10; ++i) {  // the first 10 records
    pos = static_cast<int>(text.find("*", pos)) + 1;
    text[pos] = text[pos] == '0' ? '1' : '0';
  }
  try {
    parse_novatel_ascii(text, "corrupt.log");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.location(), "line 1");
    EXPECT_NE(std::string(e.what()).find("10 of 100"), std::string::npos) << e.what();
  }
}

TEST(NovatelAscii, TruncatedLastRecordIsSkipped) {
  const HandLog log = hand_inspvax_log(30);
  const std::string text = log.text.substr(0, log.text.size() - 40);  // the last record cut short
  const InsTrack t = parse_novatel_ascii(text, "cut.log");
  EXPECT_EQ(t.records.size(), 29u);
  EXPECT_EQ(t.records_skipped, 1u);
}

std::string one_inspvax(double sow, const std::string& lat, const std::string& roll = "0.5",
                        const std::string& status = "INS_SOLUTION_GOOD") {
  return test::novatel_record_line(
      '#', fmt::format("INSPVAXA,COM1,0,50.0,FINESTEERING,2290,{:.3f},02000020,46eb,16809;{},INS_RTKFIXED,{},8.0,100.0,"
                       "47.5,0.0,1.0,0.0,{},-0.25,12.0,0.01,0.01,0.02,0.01,0.01,0.01,0.01,0.01,0.02,00000000,0",
                       sow, status, lat, roll));
}

void expect_error_at(const std::string& text, const std::string& location, const std::string& words) {
  try {
    parse_novatel_ascii(text, "bad.log");
    FAIL() << "no error for " << words;
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "bad.log");
    EXPECT_EQ(e.location(), location) << e.what();
    EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
  }
}

TEST(NovatelAscii, BadFieldsAreInputErrorsNamingTheLine) {
  expect_error_at(one_inspvax(1.0, "49.0") + one_inspvax(2.0, "91.0"), "line 2", "latitude");
  expect_error_at(one_inspvax(1.0, "49.0") + one_inspvax(2.0, "49.0", "nan"), "line 2", "roll");
  expect_error_at(one_inspvax(1.0, "49.0") + one_inspvax(2.0, "49.0") + one_inspvax(1.5, "49.0"), "line 3",
                  "time goes backwards");
  expect_error_at(one_inspvax(1.0, "49.0") + one_inspvax(1.0, "49.1"), "line 2", "repeated time");
  // The very same solution twice (logged as two record types) is not an error: skipped, counted.
  const InsTrack twice = parse_novatel_ascii(one_inspvax(1.0, "49.0") + one_inspvax(1.0, "49.0") + one_inspvax(2.0, "49.0"), "twice.log");
  EXPECT_EQ(twice.records.size(), 2u);
  EXPECT_EQ(twice.records_skipped, 1u);
}

TEST(NovatelAscii, NotNavigatingRecordsAreSkippedNotValidated) {
  // Receivers print latitude -90 and height -6356752 m while aligning.
  const std::string aligning = test::novatel_record_line(
      '#', "INSPVAA,COM1,0,86.0,FINESTEERING,1815,408756.500,00000000,54e2,11526;1815,408756.500000000,-90.00000000000,"
           "0.00000000000,-6356752.3142,0.0000,0.0000,0.0000,0.000000000,0.000000000,0.000000000,INS_ALIGNING");
  const InsTrack t = parse_novatel_ascii(aligning + kDocInspvaa + "\n", "start.log");
  ASSERT_EQ(t.records.size(), 1u);
  EXPECT_EQ(t.records_skipped, 1u);
  // Navigating but not within specification yet: kept, marked invalid.
  const InsTrack c = parse_novatel_ascii(one_inspvax(1.0, "49.0", "0.5", "INS_ALIGNMENT_COMPLETE"), "c.log");
  ASSERT_EQ(c.records.size(), 1u);
  EXPECT_EQ(c.records[0].solution, GnssSolution::kInvalid);
  EXPECT_EQ(parse_novatel_ascii(one_inspvax(1.0, "49.0", "0.5", "INS_SOLUTION_FREE"), "f.log").records[0].solution,
            GnssSolution::kInsOnly);
}

TEST(NovatelAscii, NoInsRecordIsAnInputErrorSayingWhatToLog) {
  expect_error_at(kApn030Bestposa + "\n", "", "INSPVAXA");
}

TEST(NovatelAscii, InspvaStreamTakesQualityFromSparseInspvax) {
  std::string text;
  for (int i = 0; i < 20; ++i) {
    const double sow = 100.0 + 0.05 * i;
    if (i % 10 == 0) text += one_inspvax(sow, "49.0");
    text += test::novatel_record_line(
        '%', fmt::format("INSPVASA,2290,{0:.3f};2290,{0:.9f},49.0,8.0,150.0,0,0,0,0.5,-0.25,12.0,INS_SOLUTION_GOOD", sow + 0.01));
  }
  const InsTrack t = parse_novatel_ascii(text, "mixed.log");
  ASSERT_EQ(t.records.size(), 20u);
  EXPECT_NE(t.format.find("%INSPVASA"), std::string::npos);
  EXPECT_EQ(t.records[5].solution, GnssSolution::kRtkFixed);
  EXPECT_NEAR(t.records[5].position_stddev_m.z(), 0.02, 1e-12);
}

TEST(NovatelAscii, WriterReadsBackToThePosesForEachRecordType) {
  const auto poses = test::synthetic_drive();
  InsLogWriteOptions options;
  options.origin = {48.78, 9.18, 300.0};
  const auto dir = test::scratch_dir("novatel-writer");
  for (const NovatelRecord kind : {NovatelRecord::kInspvaxa, NovatelRecord::kInspvaa, NovatelRecord::kInspvasa}) {
    options.novatel_record = kind;
    const auto path = dir / "ins.log";
    write_novatel_ascii(path, poses, {}, options);
    ASSERT_EQ(detect_ins_log(path), InsLogFormat::kNovatelAscii);
    const InsTrack track = read_ins_log(path, InsLogFormat::kNovatelAscii);
    const WorldTrack world = to_world(track, options.origin);
    const test::PoseDiff d = test::compare(world.poses, poses);
    EXPECT_LT(d.max_m, 1e-3);
    EXPECT_LT(d.max_deg, 1e-3);
    EXPECT_LT(d.max_dt_s, 1e-6);
    EXPECT_EQ(track.records_skipped, 0u);
  }
}

}  // namespace
}  // namespace insalign::io
