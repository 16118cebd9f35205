// The I/O layer's bad-input catalogue (issue 10): every case is an InputError naming the file and
// the line or byte, never a crash.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdint>
#include <fstream>
#include <random>
#include <string>

#include "core/errors.hpp"
#include "input/dataset.hpp"
#include "files/extrinsic_json.hpp"
#include "files/fiducials.hpp"
#include "pointcloud/pcd.hpp"
#include "files/poses.hpp"

namespace insalign::io {
namespace {

namespace fs = std::filesystem;

class BadInput : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("insalign_bad_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) + "_" +
            std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "lidar");
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path write(const std::string& name, const std::string& bytes) {
    const fs::path p = dir_ / name;
    std::ofstream out(p, std::ios::binary);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    return p;
  }
  std::string read(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  }
  static Sweep sweep(std::size_t n, double t_end_s) {
    std::mt19937 rng(1);
    std::uniform_real_distribution<float> u(-20.f, 20.f);
    Sweep s;
    s.t_end_s = t_end_s;
    for (std::size_t i = 0; i < n; ++i) {
      s.p_lidar.emplace_back(u(rng), u(rng), u(rng));
      s.dt_s.push_back(-0.1f * static_cast<float>(n - 1 - i) / static_cast<float>(n));
    }
    return s;
  }
  // A valid binary_compressed file's bytes.
  std::string good_pcd(PcdEncoding e = PcdEncoding::kBinaryCompressed) {
    write_pcd(dir_ / "tmp.pcd", sweep(2000, 100.0), e);
    std::string b = read(dir_ / "tmp.pcd");
    fs::remove(dir_ / "tmp.pcd");
    return b;
  }
  // Expects an InputError whose message names the file and contains `where` and `what`.
  template <typename F>
  void expect_input_error(F&& f, const fs::path& file, const std::string& where, const std::string& what = "") {
    try {
      f();
      ADD_FAILURE() << "no InputError for " << file;
    } catch (const InputError& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find(file.string()), std::string::npos) << msg;
      EXPECT_NE(msg.find(where), std::string::npos) << msg;
      EXPECT_NE(msg.find(what), std::string::npos) << msg;
    }
  }
  fs::path dir_;
};

TEST_F(BadInput, MissingAndEmptyFolders) {
  const fs::path poses = write("poses.txt", "1 0 0 0 0 0 0 1\n2 1 0 0 0 0 0 1\n");
  expect_input_error([&] { load_dataset({dir_ / "nope", poses}); }, dir_ / "nope", "", "not found");
  expect_input_error([&] { load_dataset({dir_ / "lidar", poses}); }, dir_ / "lidar", "", "no .pcd files");
  write("lidar/readme.txt", "hello");
  expect_input_error([&] { load_dataset({dir_ / "lidar", poses}); }, dir_ / "lidar", "", "1 other files");
  expect_input_error([&] { load_dataset({poses, poses}); }, poses, "", "not a folder");
}

TEST_F(BadInput, MissingPoseFile) {
  write_pcd(dir_ / "lidar/1.5.pcd", sweep(10, 1.5));
  expect_input_error([&] { load_dataset({dir_ / "lidar", dir_ / "none.txt"}); }, dir_ / "none.txt", "",
                     "file not found");
}

TEST_F(BadInput, TruncatedHeader) {
  const std::string b = good_pcd();
  const fs::path p = write("h.pcd", b.substr(0, b.find("POINTS")));
  expect_input_error([&] { read_pcd(p); }, p, "line ", "without a DATA line");
  const fs::path q = write("h2.pcd", b.substr(0, b.find("TYPE")) + std::string(8, '\0'));
  expect_input_error([&] { read_pcd(q); }, q, "line 5", "binary data inside the header");
  const fs::path r = write("h3.pcd", "");
  expect_input_error([&] { read_pcd(r); }, r, "byte 0", "empty file");
}

TEST_F(BadInput, TruncatedData) {
  for (PcdEncoding e : {PcdEncoding::kBinary, PcdEncoding::kBinaryCompressed}) {
    const std::string b = good_pcd(e);
    const fs::path p = write("t.pcd", b.substr(0, b.size() - 100));
    expect_input_error([&] { read_pcd(p); }, p, "byte ", "truncated");
  }
  const std::string a = good_pcd(PcdEncoding::kAscii);
  const fs::path p = write("ta.pcd", a.substr(0, a.size() / 2));
  expect_input_error([&] { read_pcd(p); }, p, "line ");
}

TEST_F(BadInput, LyingHeaders) {
  std::string b = good_pcd(PcdEncoding::kBinary);
  // POINTS disagrees with WIDTH x HEIGHT.
  std::string lie = b;
  lie.replace(lie.find("POINTS 2000"), 11, "POINTS 2001");
  fs::path p = write("l1.pcd", lie);
  expect_input_error([&] { read_pcd(p); }, p, "line 10", "disagrees");
  // Consistent but too many points for the data.
  lie = b;
  lie.replace(lie.find("WIDTH 2000"), 10, "WIDTH 9000");
  lie.replace(lie.find("POINTS 2000"), 11, "POINTS 9000");
  p = write("l2.pcd", lie);
  expect_input_error([&] { read_pcd(p); }, p, "byte ", "truncated");
  // Absurd point count does not allocate terabytes.
  lie = b;
  lie.replace(lie.find("WIDTH 2000"), 10, "WIDTH 99999999999999");
  lie.replace(lie.find("POINTS 2000"), 11, "POINTS 99999999999999");
  p = write("l3.pcd", lie);
  expect_input_error([&] { read_pcd(p); }, p, "line ");
  // SIZE/TYPE counts disagree with FIELDS.
  lie = b;
  lie.replace(lie.find("SIZE 4 4 4 8"), 12, "SIZE 4 4 4");
  p = write("l4.pcd", lie);
  expect_input_error([&] { read_pcd(p); }, p, "line 3", "FIELDS has 4 entries");
  // Compressed: uncompressed size does not match the header.
  std::string c = good_pcd();
  c.replace(c.find("WIDTH 2000"), 10, "WIDTH 1999");
  c.replace(c.find("POINTS 2000"), 11, "POINTS 1999");
  p = write("l5.pcd", c);
  expect_input_error([&] { read_pcd(p); }, p, "byte ", "uncompressed size");
  // Not a PCD at all.
  p = write("l6.pcd", "hello world\n");
  expect_input_error([&] { read_pcd(p); }, p, "line 1", "unknown header key");
}

TEST_F(BadInput, CorruptLzfBlock) {
  std::string b = good_pcd();
  const std::size_t data = b.find("DATA binary_compressed\n") + 23;
  // Scramble the middle of the compressed stream (back-references then point out of range).
  std::mt19937 rng(3);
  for (std::size_t i = data + 8 + 50; i < b.size() - 20; i += 7) b[i] = static_cast<char>(rng());
  const fs::path p = write("z.pcd", b);
  expect_input_error([&] { read_pcd(p); }, p, "byte " + std::to_string(data + 8), "corrupt LZF");
}

TEST_F(BadInput, LyingCountsDoNotAllocateWhatTheyClaim) {
  // Fuzzer findings: small files whose headers made the reader allocate gigabytes before noticing.
  // binary_compressed: a 4-byte LZF block cannot expand to 4 GB (LZF inflates at most 88x).
  const std::uint32_t n = 357913941;  // x y z floats: 4294967292 bytes
  std::string c = "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH " + std::to_string(n) +
                  "\nHEIGHT 1\nPOINTS " + std::to_string(n) + "\nDATA binary_compressed\n";
  const std::size_t data = c.size();
  const std::uint32_t sizes[2] = {4, n * 12};
  c.append(reinterpret_cast<const char*>(sizes), 8);
  c.append(4, '\0');
  fs::path p = write("big_lzf.pcd", c);
  expect_input_error([&] { read_pcd(p); }, p, "byte " + std::to_string(data), "cannot hold");
  // ascii: POINTS x COUNT claims ~10^15 values; the reservation is bounded by the data instead
  // (before the fix: a ~170 GB reserve, std::bad_alloc instead of an InputError).
  std::string fields = "x y z", size = "4 4 4", type = "F F F", count = "1 1 1";
  for (int k = 0; k < 16; ++k) fields += " a", size += " 4", type += " F", count += " 65536";
  const std::string a = "VERSION 0.7\nFIELDS " + fields + "\nSIZE " + size + "\nTYPE " + type + "\nCOUNT " + count +
                        "\nPOINTS 2147483648\nDATA ascii\n" + std::string(40000, ' ') + "\n";
  p = write("big_ascii.pcd", a);
  expect_input_error([&] { read_pcd(p); }, p, "line 8", "truncated");
}

TEST_F(BadInput, NanInfPointsAreDroppedAndCounted) {
  Sweep s = sweep(10, 50.0);
  s.p_lidar[2].x() = std::numeric_limits<float>::quiet_NaN();
  s.p_lidar[5].z() = std::numeric_limits<float>::infinity();
  for (PcdEncoding e : {PcdEncoding::kAscii, PcdEncoding::kBinary, PcdEncoding::kBinaryCompressed}) {
    write_pcd(dir_ / "n.pcd", s, e);
    PcdInfo info;
    const Sweep out = read_pcd(dir_ / "n.pcd", &info);
    EXPECT_EQ(out.size(), 8u);
    EXPECT_EQ(info.dropped_nonfinite, 2u);
  }
}

TEST_F(BadInput, EmptyAndBadSweepsAreSkippedInADataset) {
  const fs::path poses = write("poses.txt", "0 0 0 0 0 0 0 1\n10 1 0 0 0 0 0 1\n");
  write_pcd(dir_ / "lidar/1.000.pcd", Sweep{}, PcdEncoding::kBinary, PcdTimeField::kNone);
  expect_input_error([&] { load_dataset({dir_ / "lidar", poses}); }, dir_ / "lidar/1.000.pcd", "", "empty sweep");
  write("lidar/2.000.pcd", good_pcd().substr(0, 200));
  write_pcd(dir_ / "lidar/3.000.pcd", sweep(100, 3.0));
  write("lidar/notes.txt", "x");
  LoadReport report;
  const Dataset d = load_dataset({dir_ / "lidar", poses}, &report);
  EXPECT_EQ(report.frames_total, 3u);
  EXPECT_EQ(report.frames_bad, 2u);
  EXPECT_EQ(report.skipped_files, 1u);
  EXPECT_EQ(report.frames_used, 1u);
  ASSERT_EQ(d.frames.frames.size(), 1u);
  EXPECT_GE(report.warnings.size(), 3u);
}

TEST_F(BadInput, MalformedPoseLines) {
  fs::path p = write("p1.txt", "1 0 0 0 0 0 0 1\n2 0 0 0 0 0 0 1\n3 0 0 x 0 0 0 1\n");
  expect_input_error([&] { read_pose_file(p); }, p, "line 3", "not a finite number");
  p = write("p2.txt", "# header\nf1 1 0 0 0 0 1 0 0 0 0 1 0\nf2 1 0 0 0 0 1 0 0 0 0 1\n");
  expect_input_error([&] { read_pose_file(p); }, p, "line 3", "12 values, expected 13");
  p = write("p3.txt", "1 2 3\n");
  expect_input_error([&] { read_pose_file(p); }, p, "line 1", "expected 13");
  p = write("p4.txt", "# only a comment\n\n");
  expect_input_error([&] { read_pose_file(p); }, p, "", "no poses");
  p = write("p5.txt", "1 0 0 0 0 0 0 nan\n");
  expect_input_error([&] { read_pose_file(p); }, p, "line 1", "not a finite number");
}

TEST_F(BadInput, NonOrthonormalRotations) {
  fs::path p = write("r1.txt", "f1 1 0 0 0 0 1 0 0 0 0 1 0\nf2 1 0.1 0 0 0 1 0 0 0 0 1 0\n");
  expect_input_error([&] { read_pose_file(p); }, p, "line 2", "not orthonormal");
  p = write("r2.txt", "f1 1 0 0 0 0 1 0 0 0 0 -1 0\n");
  expect_input_error([&] { read_pose_file(p); }, p, "line 1", "determinant -1");
  p = write("r3.txt", "0 0 0 0 0 0 0 1\n1 0 0 0 0 0 0 0.5\n");
  expect_input_error([&] { read_pose_file(p); }, p, "line 2", "quaternion norm");
  // Small errors are repaired, and counted when larger than print rounding.
  p = write("r4.txt", "f1 1 0.0005 0 0 0 1 0 0 0 0 1 0\n");
  const PoseFile ok = read_pose_file(p);
  EXPECT_EQ(ok.reorthonormalised, 1u);
  const Mat3 R = ok.T_world_ins[0].linear();
  EXPECT_LT((R.transpose() * R - Mat3::Identity()).norm(), 1e-12);
}

TEST_F(BadInput, UnsortedAndDuplicatePoseTimes) {
  write_pcd(dir_ / "lidar/1.5.pcd", sweep(100, 1.5));
  // Unsorted: sorted with a warning.
  fs::path p = write("u.txt", "2 1 0 0 0 0 0 1\n1 0 0 0 0 0 0 1\n3 2 0 0 0 0 0 1\n");
  LoadReport report;
  const Dataset d = load_dataset({dir_ / "lidar", p}, &report);
  EXPECT_EQ(d.poses.size(), 3u);
  EXPECT_EQ(d.poses.t_begin(), 1.0);
  bool warned = false;
  for (const auto& w : report.warnings) warned |= w.find("not in time order") != std::string::npos;
  EXPECT_TRUE(warned);
  // Duplicate: an error naming the later line.
  p = write("d.txt", "1 0 0 0 0 0 0 1\n2 1 0 0 0 0 0 1\n2 1 0 0 0 0 0 1\n");
  expect_input_error([&] { load_dataset({dir_ / "lidar", p}); }, p, "line 3", "same time");
  // Duplicate frame times (two names for the same instant).
  write_pcd(dir_ / "lidar/1.50.pcd", sweep(100, 1.5));
  p = write("ok.txt", "1 0 0 0 0 0 0 1\n2 1 0 0 0 0 0 1\n");
  expect_input_error([&] { load_dataset({dir_ / "lidar", p}); }, dir_ / "lidar/1.5", "", "same frame time");
}

TEST_F(BadInput, FramesOutsideThePoses) {
  write_pcd(dir_ / "lidar/5.0.pcd", sweep(100, 5.0));
  fs::path p = write("p.txt", "100 0 0 0 0 0 0 1\n101 1 0 0 0 0 0 1\n");
  expect_input_error([&] { load_dataset({dir_ / "lidar", p}); }, p, "", "no frame lies within");
  write_pcd(dir_ / "lidar/100.5.pcd", sweep(100, 100.5));
  LoadReport report;
  const Dataset d = load_dataset({dir_ / "lidar", p}, &report);
  EXPECT_EQ(report.frames_outside_poses, 1u);
  EXPECT_EQ(d.frames.frames.size(), 1u);
}

TEST_F(BadInput, MalformedJson) {
  fs::path p = write("e1.json", "{\n  \"a\": {\n    \"param\": [1, 2,\n}\n");
  expect_input_error([&] { read_opencalib_extrinsic(p); }, p, "line 4", "malformed JSON");
  p = write("e2.json", "{\"a\": {\"param\": {\"sensor_calib\": {\"data\": [[1,0,0],[0,1,0],[0,0,1]]}}}}");
  expect_input_error([&] { read_opencalib_extrinsic(p); }, p, "sensor_calib.data", "4x4");
  p = write("e3.json", "{\"a\": {\"param\": {}}}");
  expect_input_error([&] { read_opencalib_extrinsic(p); }, p, "", "not an OpenCalib extrinsic");
  p = write("e4.json",
            "{\"a\": {\"param\": {\"sensor_calib\": {\"data\": [[1,0,0,0],[0,2,0,0],[0,0,1,0],[0,0,0,1]]}}}}");
  expect_input_error([&] { read_opencalib_extrinsic(p); }, p, "", "not orthonormal");
  p = write("e5.json",
            "{\"a\": {\"param\": {\"sensor_calib\": {\"data\": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,\"x\"]]}}}}");
  expect_input_error([&] { read_opencalib_extrinsic(p); }, p, "", "not a number");
  expect_input_error([&] { read_opencalib_extrinsic(dir_ / "missing.json"); }, dir_ / "missing.json", "",
                     "file not found");
}

TEST_F(BadInput, BadFiducialLines) {
  fs::path p = write("f1.txt", "# id x y z\nA 1 2 3\nB 1 2\n");
  expect_input_error([&] { read_fiducials(p); }, p, "line 3", "expected 'id x y z'");
  p = write("f2.txt", "A 1 2 3\nB 1 two 3\n");
  expect_input_error([&] { read_fiducials(p); }, p, "line 2", "coordinate y");
  p = write("f3.txt", "A 1 2 3\nA 4 5 6 # again\n");
  expect_input_error([&] { read_fiducials(p); }, p, "line 2", "duplicate fiducial id");
  p = write("f4.txt", "A 1 2 inf\n");
  expect_input_error([&] { read_fiducials(p); }, p, "line 1", "coordinate z");
}

}  // namespace
}  // namespace insalign::io
