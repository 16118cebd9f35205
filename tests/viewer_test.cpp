// The report's 3D view: the scene (the same points at each extrinsic, decimated, classes), its
// encoding (quantised positions and runs decoded back), and the page in a real browser (headless
// Chromium from file://: drawn, before and after differ, toggles change the picture, no errors).
#include <gtest/gtest.h>
#include <stb_image.h>  // decoder compiled into Debian's libstb

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "cli_test_util.hpp"
#include "core/stitch.hpp"
#include "report/report.hpp"
#include "report/viewer.hpp"
#include "test_world.hpp"

namespace insalign {
namespace {

using nlohmann::json;

struct Fixture {
  testing::TestDrive drive;
  Iso3 T_start;
  std::vector<std::size_t> frames;
  TimeSpan bad{};  // an INS span left out: frames 10-12
};

Fixture make_fixture() {
  Fixture f{testing::town_drive(testing::Drive::kFigure8, testing::roof_mount(30.0), 40, 7), {}, {}, {}};
  f.T_start = testing::perturbed(f.drive.T_ins_lidar_true, 3.0, 0.3, 11);
  for (std::size_t k = 0; k < 40; ++k) f.frames.push_back(k);
  f.bad = {f.drive.spec.t0_s + 0.95, f.drive.spec.t0_s + 1.25, "test", SpanKind::kDegradedFix, SpanSource::kInsStatus};
  return f;
}

io::ViewerScene scene_of(const Fixture& f, const FrameStore& store, std::size_t budget) {
  return io::viewer_scene(store, f.frames, {{"start", f.T_start, 0.0}, {"final", f.drive.T_ins_lidar_true, 0.0}}, {f.bad},
                          nullptr, io::ViewerConfig{budget});
}

TEST(ViewerScene, SamePointsAtEveryExtrinsicDecimatedToTheBudget) {
  const Fixture f = make_fixture();
  const FrameStore store = testing::store_of(f.drive.data);
  const io::ViewerScene scene = scene_of(f, store, 20000);
  ASSERT_EQ(scene.p_world.size(), 2u);
  ASSERT_GT(scene.points_total, 40000u);
  EXPECT_LE(scene.size(), 20000u);
  EXPECT_GE(scene.size(), 10000u);
  // The final placing is the stitched map at the truth (no voxel filter), every stride-th point.
  const std::vector<Vec3f> all = stitch_map(store, f.frames, f.drive.T_ins_lidar_true, 0.0, 0.0);
  ASSERT_EQ(all.size(), scene.points_total);
  const std::size_t stride = (scene.points_total + 19999) / 20000;
  for (std::size_t j = 0; j < scene.size(); j += 97) EXPECT_LT((scene.p_world[1][j] - all[j * stride]).norm(), 1e-4f) << j;
  // The wrong start moves the points (3 deg, 30 cm: decimetres at these ranges).
  double moved = 0;
  for (std::size_t j = 0; j < scene.size(); ++j) moved += (scene.p_world[0][j] - scene.p_world[1][j]).norm();
  EXPECT_GT(moved / scene.size(), 0.3);
  // Frames 10-12 (times t0 + 1.0 ... 1.2, sweeps 0.1 s before) touch the left-out span, the others not.
  std::size_t bad = 0;
  for (std::size_t j = 0; j < scene.size(); ++j) {
    const double t = scene.frames[scene.frame[j]].t_s - f.drive.spec.t0_s;
    const bool in_span = t > 0.95 - 1e-9 && t - 0.1 < 1.25;
    EXPECT_EQ(scene.point_class[j] == io::ViewerPointClass::kBadIns, in_span) << "t " << t;
    bad += in_span;
  }
  EXPECT_GT(bad, 0u);
}

std::string decode_base64(const std::string& s) {
  std::string out;
  std::uint32_t v = 0;
  int bits = 0;
  for (char c : s) {
    const char* table = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    const char* p = c == '=' ? nullptr : std::strchr(table, c);
    if (!p) break;
    v = (v << 6) | static_cast<std::uint32_t>(p - table);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out += static_cast<char>((v >> bits) & 0xff);
    }
  }
  return out;
}

TEST(ViewerEncode, PositionsFramesAndClassesDecodeBack) {
  io::ViewerScene s;
  s.extrinsic_labels = {"a", "b"};
  s.p_world.resize(2);
  s.frames = {{"f0", 10.0}, {"f1", 10.1}};
  s.lidar_names = {"lidar"};
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-50.f, 50.f);
  for (int i = 0; i < 1000; ++i) {
    s.p_world[0].emplace_back(u(rng), u(rng), 0.1f * u(rng));
    s.p_world[1].push_back(s.p_world[0].back() + Vec3f(0.5f, 0.f, 0.f));
    s.frame.push_back(i < 600 ? 0 : 1);
    s.point_class.push_back(i >= 500 && i < 600 ? io::ViewerPointClass::kMoving : io::ViewerPointClass::kUsed);
  }
  s.points_total = 3000;
  const io::ViewerOutput out = io::encode_viewer(s, "dir");
  ASSERT_EQ(out.files.size(), 2u);
  EXPECT_EQ(out.files[0].first, "dir/viewer_data.js");
  const std::string& js = out.files[0].second;
  const std::string prefix = "window.insalignViewerData = ";
  ASSERT_EQ(js.rfind(prefix, 0), 0u);
  const json j = json::parse(js.substr(prefix.size(), js.rfind(';') - prefix.size()));
  EXPECT_EQ(j["meta"]["points"], 1000);
  EXPECT_EQ(j["meta"]["points_total"], 3000);
  // Runs in point order: frame 0 used (500), frame 0 moving (100), frame 1 used (400).
  EXPECT_EQ(j["meta"]["runs"], json::parse("[[0,0,0,500],[0,0,1,100],[1,0,0,400]]"));
  const std::string bytes = decode_base64(j["points"].get<std::string>());
  ASSERT_EQ(bytes.size(), 2u * 1000 * 6);
  const auto& box = j["meta"]["box"];
  for (int e = 0; e < 2; ++e)
    for (int i = 0; i < 1000; ++i)
      for (int a = 0; a < 3; ++a) {
        const std::size_t at = (static_cast<std::size_t>(e) * 1000 + i) * 6 + 2 * a;
        const int q = static_cast<unsigned char>(bytes[at]) | static_cast<unsigned char>(bytes[at + 1]) << 8;
        const double p = box["min_m"][a].get<double>() + q * box["scale_m"][a].get<double>();
        EXPECT_NEAR(p, s.p_world[e][i][a], 0.51 * box["scale_m"][a].get<double>() + 1e-5);
      }
  EXPECT_NE(out.html.find("1000 of 3000 points"), std::string::npos);
  EXPECT_NE(out.html.find("src=\"dir/viewer_data.js\""), std::string::npos);
}

// ---- In a real browser -------------------------------------------------------------------------

struct Shot {
  int w = 0, h = 0;
  std::vector<unsigned char> rgb;
};

const char* kChromium = "chromium --headless --no-sandbox --enable-unsafe-swiftshader --use-angle=swiftshader "
                        "--no-first-run --disable-extensions --disable-background-networking --window-size=900,700 ";

Shot screenshot(const std::filesystem::path& page, const std::string& hash, const std::filesystem::path& png) {
  const auto [rc, out] = testing::run_command(std::string(kChromium) + "--user-data-dir=" + (png.parent_path() / "profile").string() +
                                              " --screenshot=" + png.string() + " 'file://" + page.string() + "#" + hash + "'");
  Shot s;
  int n = 0;
  unsigned char* data = stbi_load(png.c_str(), &s.w, &s.h, &n, 3);
  if (!data) {
    ADD_FAILURE() << "no screenshot for #" << hash << ": " << out;
    return s;
  }
  s.rgb.assign(data, data + 3 * s.w * s.h);
  stbi_image_free(data);
  return s;
}

// Share of pixels (below the button bar) that differ between two shots, or that are not white.
double differing(const Shot& a, const Shot& b) {
  if (a.w != b.w || a.h != b.h || a.rgb.empty()) return 0.0;
  std::size_t n = 0, total = 0;
  for (int y = a.h / 8; y < a.h * 7 / 8; ++y)
    for (int x = 0; x < a.w; ++x, ++total) {
      const std::size_t i = 3 * (static_cast<std::size_t>(y) * a.w + x);
      n += std::abs(a.rgb[i] - b.rgb[i]) + std::abs(a.rgb[i + 1] - b.rgb[i + 1]) + std::abs(a.rgb[i + 2] - b.rgb[i + 2]) > 30;
    }
  return static_cast<double>(n) / static_cast<double>(total);
}
double ink(const Shot& a) {
  Shot white = a;
  std::fill(white.rgb.begin(), white.rgb.end(), 255);
  return differing(a, white);
}

// The viewer's status element after load, as the browser left the DOM.
std::string status_after_load(const std::filesystem::path& page, const std::string& hash, const std::filesystem::path& dir,
                              std::string* log) {
  const auto [rc, out] = testing::run_command(std::string(kChromium) + "--user-data-dir=" + (dir / "profile").string() +
                                              " --enable-logging=stderr --v=0 --dump-dom 'file://" + page.string() + "#" + hash + "'");
  *log = out;
  const std::size_t at = out.find("<div id=\"viewer-status\"");
  return at == std::string::npos ? std::string() : out.substr(at, out.find('>', at) - at);
}

int attribute_int(const std::string& tag, const std::string& name) {
  const std::size_t at = tag.find(name + "=\"");
  return at == std::string::npos ? -1 : std::atoi(tag.c_str() + at + name.size() + 2);
}

TEST(ViewerBrowser, ReportFromFileDrawsSwitchesAndToggles) {
  if (std::system("command -v chromium > /dev/null 2>&1") != 0) GTEST_SKIP() << "chromium is not installed (scripts/install-deps.sh)";
  const Fixture f = make_fixture();
  const FrameStore store = testing::store_of(f.drive.data);
  // A report as calibrate writes it: PNG pictures of both maps and the 3D view beside them.
  std::vector<io::MapSnapshot> maps = {{"start", stitch_map(store, f.frames, f.T_start, 0.0, 0.05), {}},
                                       {"final", stitch_map(store, f.frames, f.drive.T_ins_lidar_true, 0.0, 0.05), {}}};
  io::ReportImages images = io::draw_report_images(maps);
  io::ViewerScene scene = scene_of(f, store, 300000);
  scene.sections = io::report_sections(images);
  images.viewer = io::encode_viewer(scene);
  const std::filesystem::path dir = testing::fresh_dir("insalign_viewer_", "browser");
  io::ReportData data;
  io::write_report(dir, data, images);
  const std::filesystem::path page = dir / "report.html";

  std::string log;
  const std::string status = status_after_load(page, "", dir, &log);
  ASSERT_FALSE(status.empty()) << log;
  EXPECT_NE(status.find("data-state=\"ok\""), std::string::npos) << status;
  EXPECT_EQ(status.find("data-errors"), std::string::npos) << status;
  EXPECT_EQ(log.find("Uncaught"), std::string::npos) << log;
  const int load_ms = attribute_int(status, "data-load-ms");
  EXPECT_GE(load_ms, 0);
  EXPECT_LT(load_ms, 5000) << "the view took " << load_ms << " ms to load";
  std::cout << "viewer loaded in " << load_ms << " ms (" << scene.size() << " points)\n";

  const Shot after = screenshot(page, "full", dir / "after.png");
  const Shot before = screenshot(page, "full&extrinsic=0", dir / "before.png");
  const Shot by_time = screenshot(page, "full&colour=2", dir / "time.png");
  const Shot no_left_out = screenshot(page, "full&leftout=0", dir / "leftout.png");
  const Shot wall = screenshot(page, "full&section=0", dir / "wall.png");
  EXPECT_GT(ink(after), 0.05) << "the canvas is blank";
  EXPECT_GT(differing(before, after), 0.01) << "start and final look the same";
  EXPECT_GT(differing(by_time, after), 0.01) << "colour by frame time changed nothing";
  EXPECT_GT(differing(no_left_out, after), 0.001) << "hiding the left-out points changed nothing";
  EXPECT_GT(differing(wall, after), 0.05) << "jumping to the wall section changed nothing";
  if (const char* keep = std::getenv("INSALIGN_VIEWER_SHOTS")) std::filesystem::copy(dir / "after.png", keep, std::filesystem::copy_options::overwrite_existing);

  // Without WebGL: one line pointing at the PNG projections instead.
  const std::string fallback = status_after_load(page, "nowebgl", dir, &log);
  EXPECT_NE(fallback.find("data-state=\"fallback\""), std::string::npos) << fallback;
  EXPECT_NE(log.find("WebGL is not available in this browser: the PNG projections below show the map."), std::string::npos);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace insalign
