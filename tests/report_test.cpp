#include <gtest/gtest.h>
#include <stb_image.h>  // decoder compiled into Debian's libstb
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <regex>
#include <set>
#include <sstream>

#include "report/render.hpp"
#include "report/report.hpp"

namespace insalign::io {
namespace {

namespace fs = std::filesystem;

// A small town: ground, two building walls and a low box, sampled like a stitched LiDAR map whose
// surfaces are blurred by `blur_m` (a wrong extrinsic smears every surface).
std::vector<Vec3f> synthetic_map(double blur_m, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> n(0.0, 1.0);
  std::vector<Vec3f> p;
  auto noise = [&] { return blur_m * n(rng) + 0.01 * n(rng); };
  for (int i = 0; i < 80000; ++i) p.emplace_back(-20 + 40 * u(rng), -20 + 40 * u(rng), noise());  // ground
  for (int i = 0; i < 30000; ++i) p.emplace_back(12 + noise(), -15 + 30 * u(rng), 7 * u(rng));  // wall x = 12
  for (int i = 0; i < 20000; ++i) p.emplace_back(-18 + 30 * u(rng), -14 + noise(), 5 * u(rng));  // wall y = -14
  for (int i = 0; i < 4000; ++i) p.emplace_back(-4 + 4 * u(rng), 3 + 2 * u(rng), 1.5 + noise());  // car roof
  return p;
}

ReportData synthetic_report() {
  ReportData d;
  d.input_summary = {{"frames", "600"}, {"distance", "812 m"}, {"heading change", "1440 deg"}, {"speed", "4.1 m/s mean"}};
  const Iso3 truth = make_transform({0.1, -0.2, 1.6}, {0.5, -1.0, 90.0});
  const Iso3 init = make_transform({0.4, 0.1, 1.6}, {8.0, 5.0, 75.0});
  const Iso3 rough = make_transform({0.12, -0.18, 1.6}, {0.6, -0.9, 90.1});
  d.T_ins_lidar = truth;
  d.stages = {{"initial", init, 0.0, "", NAN, NAN, NAN, "--init"},
              {"stage 1: rough", rough, 0.0, "plane RMS (m)", 0.21, 0.034, 12.5, ""},
              {"stage 2: refine", truth, 0.0042, "plane RMS (m)", 0.034, 0.015, 30.1, "time offset estimated"},
              {"stage 3: z", truth, 0.0042, "", NAN, NAN, 2.0, "5 fiducials"}};
  for (int r = 0; r < 6; ++r) {
    const double f = std::pow(0.35, r);
    Iso3 T = truth;
    T.translation() += f * (init.translation() - truth.translation());
    T.linear() = so3_exp(f * so3_log(init.linear() * truth.linear().transpose())) * truth.linear();
    d.convergence.push_back({"rough", r + 1, T, 0.2 * f + 0.03});
  }
  for (int r = 0; r < 4; ++r) d.convergence.push_back({"refine", r + 1, truth, 0.03 - 0.004 * r});
  d.maps = {{"initial", synthetic_map(0.25, 1), {}}, {"rough", synthetic_map(0.04, 2), {}}, {"final", synthetic_map(0.0, 3), {}}};
  d.fiducials = {{"F1", 0.031, 0.002, true, ""}, {"F2", 0.029, -0.001, true, ""}, {"F3", 0.2, 0.17, false, "outlier (17 cm)"}};
  d.fiducial_summary = "tz from 2 of 3 fiducials";
  d.time_offset_s = 0.0042;
  d.time_offset_stddev_s = 0.0003;
  ObservabilityReport o;
  o.determined = {true, true, false, true, true, true};
  o.stddev << 0.002, 0.003, NAN, 0.01, 0.012, 0.02;
  o.explanation = "tz: planar driving cannot determine it; set from fiducials";
  d.observability = o;
  RepeatabilityReport rep;
  rep.segments = {{"0-60 s", true, "", truth, 0.004}, {"60-120 s", true, "", rough, 0.0045}, {"120-180 s", false, "too few turns", truth, 0}};
  rep.spread << 0.02, 0.02, 0, 0.1, 0.1, 0.1;
  d.repeatability = rep;
  d.warnings = {"repeatability: segments disagree by 0.1 deg in roll <script>"};  // escaped in the HTML
  d.output_files = {{"extrinsic.json", "the result"}};
  d.command_line = "insalign calibrate --out x";
  return d;
}

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

struct Decoded {
  int w = 0, h = 0;
  std::vector<unsigned char> rgb;
};
std::optional<Decoded> decode_png(const fs::path& p) {
  Decoded d;
  int channels = 0;
  unsigned char* data = stbi_load(p.c_str(), &d.w, &d.h, &channels, 3);
  if (data == nullptr) return std::nullopt;
  d.rgb.assign(data, data + static_cast<std::size_t>(d.w) * d.h * 3);
  stbi_image_free(data);
  return d;
}

// Fraction of pixels that differ clearly from the top-left (background) pixel.
double non_background_fraction(const Decoded& d) {
  std::size_t n = 0;
  for (std::size_t i = 0; i < d.rgb.size(); i += 3) {
    const int diff = std::abs(d.rgb[i] - d.rgb[0]) + std::abs(d.rgb[i + 1] - d.rgb[1]) + std::abs(d.rgb[i + 2] - d.rgb[2]);
    if (diff > 30) ++n;
  }
  return static_cast<double>(n) / (d.rgb.size() / 3);
}

class ReportTest : public ::testing::Test {
 protected:
  void SetUp() override {
    // INSALIGN_KEEP_REPORT=DIR keeps the report for a person to look at.
    const char* keep = std::getenv("INSALIGN_KEEP_REPORT");
    dir_ = keep ? fs::path(keep) : fs::temp_directory_path() / ("insalign_report_" + std::to_string(::getpid()));
    keep_ = keep != nullptr;
    fs::remove_all(dir_);
  }
  void TearDown() override {
    if (!keep_) fs::remove_all(dir_);
  }
  fs::path dir_;
  bool keep_ = false;
};

TEST_F(ReportTest, EveryReferencedImageExistsAndDecodesAndMapsGetThinner) {
  const ReportData data = synthetic_report();
  const ReportFiles files = write_report(dir_, data);
  const std::string html = read_text(files.html);
  ASSERT_FALSE(html.empty());

  // Offline: the only URL is the SVG namespace, which is a name, not a fetch.
  const std::regex url("(https?:)?//[A-Za-z0-9.-]+");
  for (auto it = std::sregex_iterator(html.begin(), html.end(), url); it != std::sregex_iterator(); ++it) {
    EXPECT_EQ(it->str(), "http://www.w3.org") << "external reference in the report";
  }
  EXPECT_EQ(html.find("<script>"), std::string::npos) << "text not escaped";

  const std::regex src("src=\"([^\"]+)\"");
  std::set<std::string> referenced;
  for (auto it = std::sregex_iterator(html.begin(), html.end(), src); it != std::sregex_iterator(); ++it) {
    referenced.insert((*it)[1].str());
  }
  // 3 snapshots x (top, front, side, wall, ground).
  EXPECT_EQ(referenced.size(), 15u);
  for (const auto& rel : referenced) {
    EXPECT_TRUE(fs::path(rel).is_relative()) << rel;
    const auto img = decode_png(dir_ / rel);
    ASSERT_TRUE(img.has_value()) << rel << " missing or not a PNG";
    EXPECT_GT(img->w, 32) << rel;
    EXPECT_GT(non_background_fraction(*img), 0.01) << rel << " is blank";
  }
  for (const auto& entry : fs::recursive_directory_iterator(dir_)) {
    EXPECT_EQ(entry.path().string().find(".tmp."), std::string::npos) << "leftover " << entry.path();
  }

  // The sections are found on the final map and show the thinning.
  ASSERT_EQ(files.section_thickness_m.size(), 3u);
  const auto& before = files.section_thickness_m.front();
  const auto& after = files.section_thickness_m.back();
  EXPECT_GT(before.first, 0.15);   // wall blurred by 25 cm
  EXPECT_LT(after.first, 0.02);    // 1 cm noise
  EXPECT_GT(before.second, 0.15);  // ground
  EXPECT_LT(after.second, 0.02);
  EXPECT_NE(html.find("Repeatability"), std::string::npos);
  EXPECT_NE(html.find("<svg"), std::string::npos);
}

TEST_F(ReportTest, SectionsAreFoundOnTheRightSurfaces) {
  const auto map = synthetic_map(0.0, 5);
  const MapSections sections = find_sections(map);
  const auto& wall = sections.wall;
  ASSERT_TRUE(wall.has_value());
  // One of the two building walls, not the car roof or the ground.
  const bool on_x_wall = std::abs(wall->centre_m.x() - 12) < 0.1 && std::abs(wall->across_axis.x()) > 0.99;
  const bool on_y_wall = std::abs(wall->centre_m.y() + 14) < 0.1 && std::abs(wall->across_axis.y()) > 0.99;
  EXPECT_TRUE(on_x_wall || on_y_wall) << wall->centre_m.transpose();
  const auto& ground = sections.ground;
  ASSERT_TRUE(ground.has_value());
  EXPECT_NEAR(ground->centre_m.z(), 0.0, 0.05);
}

// calibrate stitches each map only when it is drawn (the final first, for the framing): the same
// pictures as from maps stitched up front, each map asked for once.
TEST(ReportImages, MapsStitchedOnDemandGiveTheSamePictures) {
  const ReportData data = synthetic_report();
  const ReportImages eager = draw_report_images(data.maps);
  std::vector<int> asked(data.maps.size(), 0);
  const ReportImages lazy = draw_report_images(data.maps.size(), [&](std::size_t i) {
    ++asked[i];
    return data.maps[i];
  });
  EXPECT_EQ(asked, std::vector<int>(data.maps.size(), 1));
  ASSERT_EQ(lazy.png_files.size(), eager.png_files.size());
  EXPECT_EQ(lazy.png_files.size(), 5 * data.maps.size());  // three views, a wall and a ground section each
  for (std::size_t k = 0; k < lazy.png_files.size(); ++k) {
    EXPECT_EQ(lazy.png_files[k].first, eager.png_files[k].first);
    EXPECT_TRUE(lazy.png_files[k].second == eager.png_files[k].second) << lazy.png_files[k].first;
  }
}

TEST_F(ReportTest, RendersInHeadlessChromium) {
  const fs::path chromium = "/usr/bin/chromium";
  if (!fs::exists(chromium)) GTEST_SKIP() << "no /usr/bin/chromium (Debian package chromium; scripts/install-deps.sh)";
  write_report(dir_, synthetic_report());
  const fs::path profile = dir_ / "chromium-profile";
  fs::create_directories(profile);
  const fs::path shot = dir_ / "screenshot.png";
  const std::string cmd = "timeout 120 " + chromium.string() +
                          " --headless --no-sandbox --disable-gpu --disable-quic --no-first-run"
                          " --disable-background-networking --disable-component-update --disable-sync"
                          " --user-data-dir=" + profile.string() + " --screenshot=" + shot.string() +
                          " --window-size=1280,3000 file://" + fs::absolute(dir_ / "report.html").string() +
                          " > " + (dir_ / "chromium.log").string() + " 2>&1";
  const int rc = std::system(cmd.c_str());
  ASSERT_EQ(rc, 0) << "chromium failed:\n" << read_text(dir_ / "chromium.log");
  const auto img = decode_png(shot);
  ASSERT_TRUE(img.has_value()) << "no screenshot";
  EXPECT_EQ(img->w, 1280);
  // Text, tables and map images: a blank or broken page is nearly all background.
  const double inked = non_background_fraction(*img);
  EXPECT_GT(inked, 0.05) << "screenshot looks blank";
  // The map images are colourful (height colour map); count saturated pixels.
  std::size_t coloured = 0;
  for (std::size_t i = 0; i < img->rgb.size(); i += 3) {
    const int mx = std::max({img->rgb[i], img->rgb[i + 1], img->rgb[i + 2]});
    const int mn = std::min({img->rgb[i], img->rgb[i + 1], img->rgb[i + 2]});
    if (mx - mn > 80) ++coloured;
  }
  EXPECT_GT(coloured, 5000u) << "no coloured map pixels in the screenshot: images did not load";
  fs::remove_all(profile);
}

}  // namespace
}  // namespace insalign::io
