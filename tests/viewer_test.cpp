// The report's 3D view: the scene (the same points at each extrinsic, decimated, classes), its
// encoding (quantised positions and runs decoded back), and the pages in a real browser (headless
// Chromium from file:// driven with real key, mouse and wheel events over its DevTools pipe:
// drawn, before and after differ, toggles, orbit, pan, zoom and a click do what they say).
#include <gtest/gtest.h>
#include <stb_image.h>  // decoder compiled into Debian's libstb

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numeric>
#include <random>
#include <tuple>
#include <sstream>

#include "browser_cdp.hpp"
#include "cli_test_util.hpp"
#include "core/check.hpp"
#include "report/check_outputs.hpp"
#include "core/stitch.hpp"
#include "files/read_file.hpp"
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
  const std::string bytes = testing::decode_base64(j["points"].get<std::string>());
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

// Points of two LiDARs, three frames and three classes in random order come out grouped by
// (LiDAR, frame, class), in their order within a group: one run per group.
TEST(ViewerEncode, PointsInAnyOrderAreGroupedIntoRuns) {
  io::ViewerScene s;
  s.extrinsic_labels = {"a"};
  s.p_world.resize(1);
  s.frames = {{"f0", 10.0}, {"f1", 10.1}, {"f2", 10.2}};
  s.lidar_names = {"roof", "left"};
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> pick(0, 1 << 20);
  const io::ViewerPointClass classes[] = {io::ViewerPointClass::kUsed, io::ViewerPointClass::kMoving,
                                          io::ViewerPointClass::kOutside};
  for (int i = 0; i < 3000; ++i) {
    s.p_world[0].emplace_back(static_cast<float>(i) * 0.01f, 0.f, 0.f);  // x names the point
    s.lidar.push_back(static_cast<std::uint8_t>(pick(rng) % 2));
    s.frame.push_back(static_cast<std::uint32_t>(pick(rng) % 3));
    s.point_class.push_back(classes[pick(rng) % 3]);
  }
  s.points_total = s.size();
  std::vector<std::uint32_t> order(s.size());
  std::iota(order.begin(), order.end(), 0u);
  const auto key = [&](std::uint32_t i) { return std::tuple(s.lidar[i], s.frame[i], static_cast<int>(s.point_class[i])); };
  std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) { return key(a) < key(b); });
  json runs = json::array();
  for (std::size_t k = 0; k < order.size();) {
    std::size_t n = 0;
    const auto first = key(order[k]);
    for (; k < order.size() && key(order[k]) == first; ++k) ++n;
    runs.push_back({std::get<1>(first), std::get<0>(first), std::get<2>(first), n});
  }
  const io::ViewerOutput out = io::encode_viewer(s, "dir");
  const std::string& js = out.files[0].second;
  const std::string prefix = "window.insalignViewerData = ";
  const json j = json::parse(js.substr(prefix.size(), js.rfind(';') - prefix.size()));
  EXPECT_EQ(j["meta"]["runs"], runs);
  EXPECT_EQ(j["meta"]["runs"].size(), 2u * 3 * 3);
  const std::string bytes = testing::decode_base64(j["points"].get<std::string>());
  ASSERT_EQ(bytes.size(), s.size() * 6);
  const auto& box = j["meta"]["box"];
  for (std::size_t k = 0; k < order.size(); ++k) {
    const int q = static_cast<unsigned char>(bytes[k * 6]) | static_cast<unsigned char>(bytes[k * 6 + 1]) << 8;
    const double x = box["min_m"][0].get<double>() + q * box["scale_m"][0].get<double>();
    ASSERT_NEAR(x, s.p_world[0][order[k]].x(), 0.51 * box["scale_m"][0].get<double>() + 1e-5) << k;
  }
}

// ---- check.html's view --------------------------------------------------------------------------

// A check of the fixture's drive: installed at the wrong start, measured at the truth, the check
// having used the first half of the drive.
io::LidarCheck check_of(const Fixture& f, const FrameStore& store, const std::string& name, std::size_t budget) {
  io::LidarCheck l;
  l.name = name;
  l.T_ins_lidar_installed = f.T_start;
  MeasuredExtrinsic m{f.drive.T_ins_lidar_true, 0.0, Vec7::Constant(1e-4)};
  l.run.findings = judge_extrinsic(f.T_start, 0.0, m, CheckConfig{});
  const double t0 = f.drive.spec.t0_s;
  l.run.used = {{t0 - 1.0, t0 + 2.0, 5.0, "turn 90 deg left"}};
  l.viewer = io::check_viewer_scene(store, l.run, f.T_start, 0.0, io::ViewerConfig{budget});
  return l;
}

TEST(CheckViewer, InstalledAndCorrectedWithTheStretchesUsedInColour) {
  const Fixture f = make_fixture();
  const FrameStore store = testing::store_of(f.drive.data);
  const io::LidarCheck l = check_of(f, store, "", 20000);
  const io::ViewerScene& s = l.viewer;
  ASSERT_EQ(s.extrinsic_labels, (std::vector<std::string>{"installed", "corrected"}));
  ASSERT_GT(s.size(), 5000u);
  EXPECT_LE(s.size(), 20000u);
  // "corrected" is the truth (the check measured it): the same points as the map stitched there.
  double moved = 0.0;
  for (std::size_t j = 0; j < s.size(); ++j) moved += (s.p_world[0][j] - s.p_world[1][j]).norm();
  EXPECT_GT(moved / s.size(), 0.3);
  // Frames whose sweep lies in the used stretch (t0 .. t0 + 2 s) are in colour, the others grey.
  std::size_t inside = 0, outside = 0;
  for (std::size_t j = 0; j < s.size(); ++j) {
    const double t = s.frames[s.frame[j]].t_s - f.drive.spec.t0_s;
    const bool used = t - store.sweep_period_s() >= -1.0 && t <= 2.0;
    EXPECT_EQ(s.point_class[j] == io::ViewerPointClass::kOutside, !used) << t;
    (used ? inside : outside)++;
  }
  EXPECT_GT(inside, 0u);
  EXPECT_GT(outside, 0u);
  // check.html: verdict and table first, then the view, then the details.
  const std::string html = io::check_html({l}, io::encode_viewer(s).html);
  const std::size_t table = html.find("</table>"), view = html.find("insalign-viewer"), used = html.find("Stretches used");
  EXPECT_TRUE(table < view && view < used) << table << " " << view << " " << used;
  EXPECT_NE(html.find("grey: frames outside the stretches the check used"), std::string::npos);
  // The budget 0 writes no view, and the page says nothing of one.
  const io::LidarCheck none = check_of(f, store, "", 0);
  EXPECT_EQ(none.viewer.size(), 0u);
  const testing::ScratchDir scratch("insalign_viewer_", "check_none");
  const std::filesystem::path dir = scratch.path();
  io::write_check_html(dir, {none});
  EXPECT_FALSE(std::filesystem::exists(dir / "report" / "viewer_data.js"));
  EXPECT_EQ(io::read_file(dir / "check.html").find("insalign-viewer"), std::string::npos);
}

// ---- In a real browser -------------------------------------------------------------------------

struct Shot {
  int w = 0, h = 0;
  std::vector<unsigned char> rgb;
};

Shot decode_png(const std::string& png) {
  Shot s;
  int n = 0;
  unsigned char* data = stbi_load_from_memory(reinterpret_cast<const unsigned char*>(png.data()), static_cast<int>(png.size()),
                                              &s.w, &s.h, &n, 3);
  if (!data) return s;
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
// Share of grey points' pixels (the drive beyond a check's stretches).
double grey(const Shot& a) {
  std::size_t n = 0;
  for (std::size_t i = 0; i + 2 < a.rgb.size(); i += 3)
    n += std::abs(a.rgb[i] - 158) < 6 && std::abs(a.rgb[i + 1] - 158) < 6 && std::abs(a.rgb[i + 2] - 158) < 6;
  return a.rgb.empty() ? 0.0 : 3.0 * static_cast<double>(n) / static_cast<double>(a.rgb.size());
}

// A page with the viewer open in one headless Chromium, acted on with real input events.
struct ViewerPage {
  testing::Browser browser;
  json canvas;  // its box in the window, CSS pixels
  ViewerPage(const std::filesystem::path& profile, const std::filesystem::path& page, const std::string& hash)
      : browser(profile, 900, 700) {
    browser.navigate("file://" + page.string() + "#" + hash);
    if (!browser.wait_for("document.getElementById('viewer-status') && "
                          "document.getElementById('viewer-status').dataset.state !== 'loading'"))
      throw std::runtime_error("the viewer did not load within 10 s");
    canvas = browser.eval("(() => { const r = document.querySelector('#insalign-viewer canvas').getBoundingClientRect(); "
                          "return {x: r.left, y: r.top, w: r.width, h: r.height}; })()");
  }
  json status() { return browser.eval("Object.assign({}, document.getElementById('viewer-status').dataset)"); }
  double cx() { return canvas["x"].get<double>() + canvas["w"].get<double>() / 2; }
  double cy() { return canvas["y"].get<double>() + canvas["h"].get<double>() / 2; }
  /// The picture after `act` and the view's next draw.
  template <class Act>
  Shot after(Act act) {
    const int draws = std::stoi(status().value("draws", "0"));
    act(browser);
    if (!browser.wait_for("+document.getElementById('viewer-status').dataset.draws > " + std::to_string(draws)))
      ADD_FAILURE() << "the view did not draw again";
    return decode_png(browser.screenshot_png());
  }
  Shot shot() { return decode_png(browser.screenshot_png()); }
  std::vector<double> camera() {  // yaw, pitch, distance, target x y z (local frame, m)
    std::vector<double> v;
    std::stringstream in(status().value("camera", ""));
    for (std::string x; std::getline(in, x, ',');) v.push_back(std::stod(x));
    return v;
  }
};

bool same(const std::vector<double>& a, const std::vector<double>& b, std::size_t from, std::size_t to) {
  for (std::size_t i = from; i < to && i < a.size() && i < b.size(); ++i)
    if (std::abs(a[i] - b[i]) > 1e-3) return false;
  return a.size() == 6 && b.size() == 6;
}

TEST(ViewerBrowser, ReportFromFileDrawsSwitchesTogglesOrbitsPansZoomsAndPicks) {
  if (!testing::have_chromium()) GTEST_SKIP() << "chromium is not installed (scripts/install-deps.sh)";
  const Fixture f = make_fixture();
  const FrameStore store = testing::store_of(f.drive.data);
  // A report as calibrate writes it: PNG pictures of both maps and the 3D view beside them.
  std::vector<io::MapSnapshot> maps = {{"start", stitch_map(store, f.frames, f.T_start, 0.0, 0.05), {}},
                                       {"final", stitch_map(store, f.frames, f.drive.T_ins_lidar_true, 0.0, 0.05), {}}};
  io::ReportImages images = io::draw_report_images(maps);
  io::ViewerScene scene = scene_of(f, store, 300000);
  scene.sections = io::report_sections(images);
  images.viewer = io::encode_viewer(scene);
  // Declared before the browser, so removed after it has quit: a running Chromium still writes its profile.
  const testing::ScratchDir scratch("insalign_viewer_", "browser");
  const std::filesystem::path dir = scratch.path();
  io::ReportData data;
  io::write_report(dir, data, images);
  const std::filesystem::path page = dir / "report.html";

  const auto start = std::chrono::steady_clock::now();
  ViewerPage v(dir / "profile", page, "full");
  const double open_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const json status = v.status();
  EXPECT_EQ(status.value("state", ""), "ok") << status.dump();
  EXPECT_FALSE(status.contains("errors")) << status.dump();
  const int load_ms = std::stoi(status.value("loadMs", "-1"));
  EXPECT_GE(load_ms, 0);
  EXPECT_LT(load_ms, 5000) << "the view took " << load_ms << " ms to load";
  std::cout << "viewer loaded in " << load_ms << " ms (" << scene.size() << " points); browser started and page open in "
            << open_s << " s\n";

  using B = testing::Browser;
  EXPECT_GT(ink(v.shot()), 0.05) << "the canvas is blank";
  // The reference picture once the page has settled (a redraw, nothing changed: B twice).
  const Shot after = v.after([](B& b) { b.key("b"); b.key("b"); });
  // One key switches to the start and back: the same camera, so the same picture again.
  const Shot before = v.after([](B& b) { b.key("b"); });
  EXPECT_EQ(v.status().value("extrinsic", ""), "start");
  EXPECT_GT(differing(before, after), 0.01) << "start and final look the same";
  const Shot back = v.after([](B& b) { b.key("b"); });
  EXPECT_LT(differing(back, after), 0.002) << "the camera moved with the switch";
  EXPECT_GT(differing(v.after([](B& b) { b.key("c"); }), after), 0.01) << "colour by frame time changed nothing";
  EXPECT_EQ(v.status().value("mode", ""), "frame time");
  v.after([](B& b) { b.key("c"); });
  EXPECT_GT(differing(v.after([](B& b) { b.key("l"); }), after), 0.001) << "hiding the left-out points changed nothing";
  v.after([](B& b) { b.key("l"); });
  if (const char* keep = std::getenv("INSALIGN_VIEWER_SHOTS")) {
    std::ofstream(keep, std::ios::binary) << v.browser.screenshot_png();
  }

  // The mouse: a drag orbits (the camera turns about its target), a shift-drag and a right-drag
  // pan (the target moves, the direction stays), the wheel zooms (the distance changes).
  const double x = v.cx(), y = v.cy();
  const std::vector<double> c0 = v.camera();
  ASSERT_EQ(c0.size(), 6u) << v.status().dump();
  const Shot orbited = v.after([&](B& b) { b.drag(x, y, x + 150, y + 60); });
  const std::vector<double> c1 = v.camera();
  EXPECT_FALSE(same(c0, c1, 0, 2)) << "a drag did not orbit";
  EXPECT_TRUE(same(c0, c1, 2, 6)) << "a drag moved the target or the distance";
  EXPECT_GT(differing(orbited, after), 0.02) << "orbiting changed nothing on screen";
  const Shot panned = v.after([&](B& b) { b.drag(x, y, x - 120, y + 40, "left", B::kShift); });
  const std::vector<double> c2 = v.camera();
  EXPECT_TRUE(same(c1, c2, 0, 3)) << "a shift-drag turned the camera";
  EXPECT_FALSE(same(c1, c2, 3, 6)) << "a shift-drag did not pan";
  EXPECT_GT(differing(panned, orbited), 0.02) << "panning changed nothing on screen";
  v.after([&](B& b) { b.drag(x, y, x + 80, y - 50, "right"); });
  const std::vector<double> c3 = v.camera();
  EXPECT_TRUE(same(c2, c3, 0, 3)) << "a right-drag turned the camera";
  EXPECT_FALSE(same(c2, c3, 3, 6)) << "a right-drag did not pan";
  const Shot zoomed = v.after([&](B& b) { b.wheel(x, y, -400); });
  const std::vector<double> c4 = v.camera();
  ASSERT_EQ(c4.size(), 6u);
  EXPECT_LT(c4[2], 0.8 * c3[2]) << "the wheel did not zoom in";
  EXPECT_GT(differing(zoomed, panned), 0.02) << "zooming changed nothing on screen";

  // Key 1 flies to the wall section; a click on it (the centre of the view) names a point.
  EXPECT_GT(differing(v.after([](B& b) { b.key("1"); }), after), 0.05) << "jumping to the wall section changed nothing";
  v.browser.click(x, y);
  EXPECT_TRUE(v.browser.wait_for("'picked' in document.getElementById('viewer-status').dataset")) << v.status().dump();
  const std::string line = v.browser.eval("document.querySelector('#insalign-viewer .viewer-info').textContent").get<std::string>();
  EXPECT_NE(line.find("m (world) · frame frame"), std::string::npos) << line;
  EXPECT_TRUE(v.browser.errors.empty()) << v.browser.errors.front();

  // Without WebGL: one line pointing at the PNG projections instead.
  v.browser.navigate("about:blank");
  v.browser.navigate("file://" + page.string() + "#nowebgl");
  EXPECT_TRUE(v.browser.wait_for("document.getElementById('viewer-status').dataset.state === 'fallback'"));
  const std::string fallback = v.browser.eval("document.querySelector('#insalign-viewer .viewer-fallback').textContent").get<std::string>();
  EXPECT_EQ(fallback, "WebGL is not available in this browser: the PNG projections below show the map.");
}

TEST(ViewerBrowser, CheckPageShowsInstalledAndCorrectedAndARigByLidar) {
  if (!testing::have_chromium()) GTEST_SKIP() << "chromium is not installed (scripts/install-deps.sh)";
  const Fixture f = make_fixture();
  const FrameStore store = testing::store_of(f.drive.data);
  const testing::ScratchDir scratch("insalign_viewer_", "check");
  const std::filesystem::path dir = scratch.path();
  io::write_check_html(dir / "one", {check_of(f, store, "", 200000)});
  using B = testing::Browser;
  {
    ViewerPage v(dir / "profile1", dir / "one" / "check.html", "full");
    EXPECT_EQ(v.status().value("state", ""), "ok") << v.status().dump();
    EXPECT_EQ(v.status().value("extrinsic", ""), "corrected");
    const Shot corrected = v.shot();
    EXPECT_GT(ink(corrected), 0.05) << "the canvas is blank";
    EXPECT_GT(grey(corrected), 0.002) << "the drive beyond the check's stretches is not shown grey";
    const Shot installed = v.after([](B& b) { b.key("b"); });
    EXPECT_EQ(v.status().value("extrinsic", ""), "installed");
    EXPECT_GT(differing(installed, corrected), 0.01) << "installed and corrected look the same";
    const Shot hidden = v.after([](B& b) { b.key("l"); });
    EXPECT_LT(grey(hidden), 0.1 * grey(corrected)) << "L did not hide the drive beyond the stretches";
    EXPECT_TRUE(v.browser.errors.empty()) << v.browser.errors.front();
  }
  // A rig: both LiDARs in one view (each half the budget), coloured by LiDAR with C.
  io::write_check_html(dir / "rig", {check_of(f, store, "front", 100000), check_of(f, store, "rear", 100000)});
  {
    ViewerPage v(dir / "profile2", dir / "rig" / "check.html", "full");
    EXPECT_EQ(v.status().value("state", ""), "ok") << v.status().dump();
    const Shot height = v.shot();
    const Shot by_lidar = v.after([](B& b) { b.key("c"); });
    EXPECT_EQ(v.status().value("mode", ""), "LiDAR");
    EXPECT_GT(differing(by_lidar, height), 0.01) << "colour by LiDAR changed nothing";
    EXPECT_TRUE(v.browser.errors.empty()) << v.browser.errors.front();
  }
}

}  // namespace
}  // namespace insalign
