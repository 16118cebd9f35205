// Format detection from content and the single entry point read_ins_log.
#include <gtest/gtest.h>

#include "core/errors.hpp"
#include "ins_log_test_util.hpp"
#include "inslog/ins_log.hpp"
#include "inslog/ins_log_writer.hpp"
#include "files/poses.hpp"

namespace insalign::io {
namespace {

TEST(InsLog, PoseFilesAreLeftToThePoseReader) {
  const auto dir = test::scratch_dir("detect");
  test::write_text(dir / "tum.txt", "# t x y z qx qy qz qw\n1.0 0 0 0 0 0 0 1\n2.0 1 0 0 0 0 0 1\n");
  test::write_text(dir / "opencalib.txt", "1635236489.468 1 0 0 0 0 1 0 0 0 0 1 0\n1635236489.568 1 0 0 1 0 1 0 0 0 0 1 0\n");
  EXPECT_EQ(detect_ins_log(dir / "tum.txt"), std::nullopt);
  EXPECT_EQ(detect_ins_log(dir / "opencalib.txt"), std::nullopt);
  EXPECT_NO_THROW(read_pose_file(dir / "tum.txt"));
  std::filesystem::create_directories(dir / "empty_folder");
  EXPECT_EQ(detect_ins_log(dir / "empty_folder"), std::nullopt);
  test::write_text(dir / "random.bin", std::string("\x00\x01\x02\x03", 4));
  EXPECT_EQ(detect_ins_log(dir / "random.bin"), std::nullopt);
  EXPECT_THROW(detect_ins_log(dir / "missing.txt"), InputError);
}

TEST(InsLog, NovatelIsFoundAfterOtherRecordsAndPreamble) {
  const auto dir = test::scratch_dir("detect-novatel");
  std::string text = "NovAtel Connect log\r\n";
  for (int i = 0; i < 50; ++i) {
    text += test::novatel_record_line('#', "RANGECMPA,COM1,0,80.5,FINESTEERING,2290,1.000,02000020,1c0a,16809;0");
  }
  text += test::novatel_record_line('%', "INSPVASA,2290,100.000;2290,100.000000000,49.0,8.0,150.0,0,0,0,0.5,-0.25,12.0,INS_SOLUTION_GOOD");
  test::write_text(dir / "span.gps", text);
  EXPECT_EQ(detect_ins_log(dir / "span.gps"), InsLogFormat::kNovatelAscii);
  EXPECT_EQ(read_ins_log(dir / "span.gps", InsLogFormat::kNovatelAscii).records.size(), 1u);
  // A binary NovAtel log is recognised, and the error says what to do.
  test::write_text(dir / "binary.gps", std::string("\xAA\x44\x12\x1C\x2A\x00\x02\x20\x48\x00\x00\x00", 12));
  ASSERT_EQ(detect_ins_log(dir / "binary.gps"), InsLogFormat::kNovatelAscii);
  try {
    read_ins_log(dir / "binary.gps", InsLogFormat::kNovatelAscii);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("convert the log to ASCII"), std::string::npos) << e.what();
  }
}

TEST(InsLog, EveryWriterFormatIsDetectedAndReadBack) {
  const auto poses = test::synthetic_drive(1700000000.0, 10.0, 50.0);
  InsLogWriteOptions w;
  w.origin = {52.52, 13.40, 35.0};
  InsLogOptions r;
  r.lidar_time_hint_unix_s = poses.front().t_s;
  r.columns = text_export_writer_columns();
  const auto dir = test::scratch_dir("every");
  for (const auto f : {InsLogFormat::kNovatelAscii, InsLogFormat::kSbet, InsLogFormat::kTextExport, InsLogFormat::kKittiOxts}) {
    SCOPED_TRACE(ins_log_format_name(f));
    const auto path = dir / (std::string(ins_log_format_name(f)) + (f == InsLogFormat::kKittiOxts ? "" : ".log"));
    write_ins_log(path, f, poses, {}, w);
    ASSERT_EQ(detect_ins_log(path), f);
    EXPECT_EQ(parse_ins_log_format(ins_log_format_name(f)), f);
    const InsTrack track = read_ins_log(path, f, r);
    EXPECT_FALSE(track.format.empty());
    EXPECT_FALSE(track.time_base.empty());
    EXPECT_FALSE(track.body_frame.empty());
    EXPECT_FALSE(track.height_datum.empty());
    EXPECT_EQ(track.world_frame, "local ENU at the first fix");
    const test::PoseDiff d = test::compare(to_world(track, w.origin).poses, poses);
    EXPECT_LT(d.max_m, 1e-3);
    EXPECT_LT(d.max_deg, 1e-3);
  }
  EXPECT_EQ(parse_ins_log_format("tum"), std::nullopt);
}

}  // namespace
}  // namespace insalign::io
