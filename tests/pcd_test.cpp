// PCD reader and writer: the real OpenCalib sweeps, every encoding, odd layouts.
#include "pointcloud/pcd.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <random>

#include "core/errors.hpp"
#include "files/read_file.hpp"

namespace insalign::io {
namespace {

namespace fs = std::filesystem;

const fs::path kSampleDir = fs::path(INSALIGN_SHARED_DATA_DIR) / "opencalib-sample" / "top_center_lidar";

fs::path temp_dir(const std::string& tag) {
  const fs::path dir = fs::temp_directory_path() / ("insalign_pcd_" + tag + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

void write_raw(const fs::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

template <typename T>
void append(std::string& s, T v) {
  s.append(reinterpret_cast<const char*>(&v), sizeof(T));
}

Sweep random_sweep(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> xyz(-50.f, 50.f), inten(0.f, 255.f), dt(-0.1f, 0.f);
  Sweep s;
  s.name = "sweep";
  s.t_end_s = 1635236489.567891;
  for (std::size_t i = 0; i < n; ++i) {
    s.p_lidar.emplace_back(xyz(rng), xyz(rng), xyz(rng));
    s.intensity.push_back(inten(rng));
    s.ring.push_back(static_cast<std::uint16_t>(i % 64));
    s.dt_s.push_back(i == n / 2 ? 0.f : dt(rng));  // one point at the sweep end
  }
  return s;
}

TEST(Pcd, RealSampleFirstSweepFacts) {
  if (!fs::exists(kSampleDir)) GTEST_SKIP() << "shared sample data not found at " << kSampleDir;
  PcdInfo info;
  const Sweep s = read_pcd(kSampleDir / "2021-10-26-16-21-29-468.pcd", &info);
  EXPECT_EQ(s.size(), 80787u);
  EXPECT_EQ(info.points, 80787u);
  EXPECT_EQ(info.time_field, "timestamp");
  EXPECT_EQ(info.data_encoding, "binary_compressed");
  EXPECT_EQ(info.dropped_nonfinite, 0u);
  EXPECT_EQ(s.name, "2021-10-26-16-21-29-468");
  ASSERT_TRUE(s.has_time());
  const auto [lo, hi] = std::minmax_element(s.dt_s.begin(), s.dt_s.end());
  EXPECT_EQ(*hi, 0.f);  // the frame time is the latest point
  EXPECT_NEAR(*hi - *lo, 0.0999, 1e-4);
  ASSERT_EQ(s.ring.size(), s.size());
  EXPECT_EQ(*std::min_element(s.ring.begin(), s.ring.end()), 0);
  EXPECT_EQ(*std::max_element(s.ring.begin(), s.ring.end()), 60);
  EXPECT_EQ(s.intensity.size(), s.size());
  // The name is local time (UTC+8) to the ms; the sweep ends within a few ms of it.
  EXPECT_NEAR(s.t_end_s, 1635236489.468, 0.05);
}

TEST(Pcd, RealSampleAllFiveLoadFast) {
  if (!fs::exists(kSampleDir)) GTEST_SKIP() << "shared sample data not found at " << kSampleDir;
  std::size_t files = 0;
  double slowest_ms = 0.0;
  for (const auto& entry : fs::directory_iterator(kSampleDir)) {
    if (entry.path().extension() != ".pcd") continue;
    const auto t0 = std::chrono::steady_clock::now();
    const Sweep s = read_pcd(entry.path());
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    slowest_ms = std::max(slowest_ms, ms);
    EXPECT_GT(s.size(), 75000u) << entry.path();
    EXPECT_TRUE(std::isfinite(s.t_end_s));
    ++files;
  }
  EXPECT_EQ(files, 5u);
  std::printf("slowest real sweep decode: %.1f ms\n", slowest_ms);
  EXPECT_LT(slowest_ms, 200.0);  // a few ms normally; generous for a loaded CI machine
}

class PcdRoundTrip : public ::testing::TestWithParam<PcdEncoding> {};

TEST_P(PcdRoundTrip, AbsoluteTimestampsAndAllFields) {
  const fs::path dir = temp_dir("rt");
  const Sweep in = random_sweep(1000, 7);
  write_pcd(dir / "a.pcd", in, GetParam(), PcdTimeField::kAbsolute);
  PcdInfo info;
  const Sweep out = read_pcd(dir / "a.pcd", &info);
  EXPECT_EQ(info.time_field, "timestamp");
  ASSERT_EQ(out.size(), in.size());
  EXPECT_NEAR(out.t_end_s, in.t_end_s, 1e-9);
  for (std::size_t i = 0; i < in.size(); ++i) {
    ASSERT_EQ(out.p_lidar[i], in.p_lidar[i]) << i;
    ASSERT_EQ(out.intensity[i], in.intensity[i]) << i;
    ASSERT_EQ(out.ring[i], in.ring[i]) << i;
    ASSERT_NEAR(out.dt_s[i], in.dt_s[i], 1e-6) << i;
  }
  fs::remove_all(dir);
}

TEST_P(PcdRoundTrip, RelativeTimeAndNoOptionalFields) {
  const fs::path dir = temp_dir("rel");
  Sweep in = random_sweep(500, 8);
  in.intensity.clear();
  in.ring.clear();
  write_pcd(dir / "b.pcd", in, GetParam(), PcdTimeField::kRelative);
  PcdInfo info;
  const Sweep out = read_pcd(dir / "b.pcd", &info);
  EXPECT_EQ(info.time_field, "time");
  EXPECT_TRUE(std::isnan(out.t_end_s));  // relative times: the caller supplies the frame time
  EXPECT_TRUE(out.intensity.empty());
  EXPECT_TRUE(out.ring.empty());
  ASSERT_EQ(out.size(), in.size());
  for (std::size_t i = 0; i < in.size(); ++i) {
    ASSERT_EQ(out.p_lidar[i], in.p_lidar[i]);
    ASSERT_EQ(out.dt_s[i], in.dt_s[i]);
  }
  // No time at all.
  write_pcd(dir / "c.pcd", in, GetParam(), PcdTimeField::kNone);
  const Sweep none = read_pcd(dir / "c.pcd", &info);
  EXPECT_EQ(info.time_field, "");
  EXPECT_FALSE(none.has_time());
  fs::remove_all(dir);
}

TEST_P(PcdRoundTrip, EmptySweep) {
  const fs::path dir = temp_dir("empty");
  Sweep in;
  in.t_end_s = 5.0;
  write_pcd(dir / "e.pcd", in, GetParam());
  const Sweep out = read_pcd(dir / "e.pcd");
  EXPECT_EQ(out.size(), 0u);
  fs::remove_all(dir);
}

INSTANTIATE_TEST_SUITE_P(Encodings, PcdRoundTrip,
                         ::testing::Values(PcdEncoding::kAscii, PcdEncoding::kBinary, PcdEncoding::kBinaryCompressed));

TEST(Pcd, BinaryAnyFieldOrderTypesAndCounts) {
  // Ouster-like layout: padding, a COUNT 3 field, double z, uint8 ring, uint32 't' in ns.
  const fs::path dir = temp_dir("layout");
  std::string f =
      "# custom\nVERSION .7\nFIELDS t _ ring z normal y x intensity\nSIZE 4 1 1 8 4 4 4 2\nTYPE U U U F F F F U\n"
      "COUNT 1 3 1 1 3 1 1 1\nWIDTH 3\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 3\nDATA binary\n";
  const std::uint32_t t_ns[3] = {0, 50'000'000, 100'000'000};
  for (int i = 0; i < 3; ++i) {
    append<std::uint32_t>(f, t_ns[i]);
    f.append(3, '\x7f');
    append<std::uint8_t>(f, static_cast<std::uint8_t>(10 + i));
    append<double>(f, -1.5 * i);
    for (int k = 0; k < 3; ++k) append<float>(f, 9.f);
    append<float>(f, 2.f * i);
    append<float>(f, 1.f + i);
    append<std::uint16_t>(f, static_cast<std::uint16_t>(300 + i));
  }
  write_raw(dir / "o.pcd", f);
  PcdInfo info;
  const Sweep s = read_pcd(dir / "o.pcd", &info);
  EXPECT_EQ(info.time_field, "t");
  ASSERT_EQ(s.size(), 3u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(s.p_lidar[i], Vec3f(1.f + i, 2.f * i, -1.5f * i));
    EXPECT_EQ(s.ring[i], 10 + i);
    EXPECT_EQ(s.intensity[i], 300.f + i);
  }
  EXPECT_NEAR(s.dt_s[0], -0.1, 1e-7);
  EXPECT_NEAR(s.dt_s[1], -0.05, 1e-7);
  EXPECT_EQ(s.dt_s[2], 0.f);
  EXPECT_TRUE(std::isnan(s.t_end_s));
  fs::remove_all(dir);
}

TEST(Pcd, AsciiWithIntegersFloatTimestampAndCrlf) {
  const fs::path dir = temp_dir("ascii");
  write_raw(dir / "a.pcd",
            "VERSION 0.7\r\nFIELDS timestamp x y z ring\r\nSIZE 4 4 4 4 2\r\nTYPE F I F F U\r\nCOUNT 1 1 1 1 1\r\n"
            "WIDTH 2\r\nHEIGHT 1\r\nPOINTS 2\r\nDATA ascii\r\n100.5 -3 0.25 1e-2 7\r\n100.25 4 nan 1 8\r\n");
  PcdInfo info;
  const Sweep s = read_pcd(dir / "a.pcd", &info);
  EXPECT_EQ(info.time_field, "timestamp");
  EXPECT_EQ(info.dropped_nonfinite, 1u);
  ASSERT_EQ(s.size(), 1u);
  EXPECT_EQ(s.p_lidar[0], Vec3f(-3.f, 0.25f, 0.01f));
  EXPECT_EQ(s.ring[0], 7);
  EXPECT_DOUBLE_EQ(s.t_end_s, 100.5);
  fs::remove_all(dir);
}

TEST(Pcd, NanRingKeepsThePointWithRingZero) {
  // Fuzzer finding: a NaN ring was cast to uint16 (undefined behaviour, UBSan float-cast-overflow).
  const fs::path dir = temp_dir("ringnan");
  write_raw(dir / "r.pcd",
            "VERSION 0.7\nFIELDS x y z ring\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\nWIDTH 2\nHEIGHT 1\n"
            "POINTS 2\nDATA ascii\n1 2 3 nan\n4 5 6 70000\n");
  const Sweep s = read_pcd(dir / "r.pcd");
  ASSERT_EQ(s.size(), 2u);
  EXPECT_EQ(s.p_lidar[0], Vec3f(1.f, 2.f, 3.f));
  EXPECT_EQ(s.ring[0], 0);
  EXPECT_EQ(s.ring[1], 65535);
  fs::remove_all(dir);
}

TEST(Pcd, MaximallyCompressibleSweepStillReads) {
  // The reader rejects LZF blocks that claim more than 88x expansion; all-zero points compress
  // about as well as LZF can and must still load.
  const fs::path dir = temp_dir("zeros");
  Sweep in;
  in.p_lidar.assign(20000, Vec3f::Zero());
  write_pcd(dir / "z.pcd", in, PcdEncoding::kBinaryCompressed);
  EXPECT_EQ(read_pcd(dir / "z.pcd").size(), 20000u);
  fs::remove_all(dir);
}

TEST(Pcd, HeaderOnlyRead) {
  const fs::path dir = temp_dir("hdr");
  write_pcd(dir / "h.pcd", random_sweep(100, 3), PcdEncoding::kBinary);
  const PcdHeader h = read_pcd_header(dir / "h.pcd");
  EXPECT_EQ(h.points, 100u);
  EXPECT_EQ(h.data, "binary");
  EXPECT_EQ(h.point_bytes, 4u * 4 + 2 + 8);
  EXPECT_EQ(h.header_bytes + 100 * h.point_bytes, fs::file_size(dir / "h.pcd"));
  ASSERT_NE(h.find("ring"), nullptr);
  EXPECT_EQ(h.find("ring")->offset, 16u);
  fs::remove_all(dir);
}

// The header is read from the first 4 KB when it ends inside them: a header reaching past them
// (a long comment) reads whole, also where the 4 KB end inside "DATA binary_compressed".
TEST(Pcd, HeaderPastTheFirstReadIsReadWhole) {
  const fs::path dir = temp_dir("longhdr");
  const Sweep in = random_sweep(50, 4);
  write_pcd(dir / "src.pcd", in, PcdEncoding::kBinaryCompressed);
  const std::string bytes = read_file(dir / "src.pcd");
  const std::size_t data_line = bytes.find("\nDATA binary_compressed\n") + 1;
  ASSERT_NE(data_line, std::string::npos + 1);
  for (std::size_t cut = std::string("DATA ").size(); cut <= std::string("DATA binary_compressed\n").size(); ++cut) {
    // A comment line ("# " + x's + newline) after the first line moves the DATA line to cut
    // bytes before byte 4096.
    const std::size_t first_nl = bytes.find('\n') + 1;
    const std::size_t pad = 4096 - cut - data_line - 3;
    const std::string padded = bytes.substr(0, first_nl) + "# " + std::string(pad, 'x') + "\n" + bytes.substr(first_nl);
    ASSERT_EQ(padded.find("\nDATA ") + 1 + cut, 4096u);
    std::ofstream(dir / "long.pcd", std::ios::binary) << padded;
    const PcdHeader h = read_pcd_header(dir / "long.pcd");
    EXPECT_EQ(h.data, "binary_compressed") << cut;
    EXPECT_EQ(h.points, 50u) << cut;
    EXPECT_EQ(h.header_bytes, data_line + pad + 3 + std::string("DATA binary_compressed\n").size()) << cut;
    EXPECT_EQ(read_pcd(dir / "long.pcd").size(), 50u) << cut;
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace insalign::io
