// Bad INS stretches (core/ins_screen.hpp): the INS's own status marks float episodes and outages
// relative to the drive's usual solution; a wrong fix, which the INS reports as a good fix, is
// found from the LiDAR and left out of the calibration, which stays within the stated bounds.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <memory>
#include <string>

#include "core/ins_screen.hpp"
#include "core/pipeline.hpp"
#include "sim/simulate.hpp"
#include "sim/world_dataset.hpp"

namespace insalign {
namespace {

// Whether one of the result's advice sentences starts so.
bool advises(const CalibrationResult& r, const std::string& start) {
  for (const std::string& a : r.advice)
    if (a.starts_with(start)) return true;
  return false;
}

double overlap_s(const TimeSpan& s, double t0, double t1) { return std::max(0.0, std::min(s.end_s, t1) - std::max(s.begin_s, t0)); }

double covered_s(const std::vector<TimeSpan>& spans, double t0, double t1) {
  std::vector<TimeSpan> clipped;
  for (const TimeSpan& s : spans)
    if (overlap_s(s, t0, t1) > 0.0) clipped.push_back({std::max(s.begin_s, t0), std::min(s.end_s, t1), "", s.kind, s.source});
  return spans_duration_s(clipped);
}

// 10 Hz, 60 s: RTK fixed at 1 cm, a float episode 20-28 s (stddev 0.1-0.3 m), INS only 40-45 s.
std::vector<InsQuality> status_series() {
  std::vector<InsQuality> q;
  for (int i = 0; i < 600; ++i) {
    const double t = 0.1 * i;
    InsQuality s{t, GnssSolution::kRtkFixed, 0.01, 0.015};
    if (t >= 20.0 && t < 28.0) s = {t, GnssSolution::kRtkFloat, 0.1 + 0.05 * (t - 20.0), 0.2};
    if (t >= 40.0 && t < 45.0) s = {t, GnssSolution::kInsOnly, 0.02 + 0.02 * (t - 40.0), 0.05};
    q.push_back(s);
  }
  return q;
}

TEST(InsScreen, StatusSpansCoverWhatTheInsMarksWorseThanUsual) {
  const std::vector<TimeSpan> spans = status_spans(status_series(), InsStatusConfig{});
  ASSERT_EQ(spans.size(), 2u);
  EXPECT_EQ(spans[0].kind, SpanKind::kDegradedFix);
  EXPECT_EQ(spans[1].kind, SpanKind::kInsOnly);
  EXPECT_GE(covered_s(spans, 20.0, 28.0), 7.9);
  EXPECT_GE(covered_s(spans, 40.0, 45.0), 4.9);
  EXPECT_LT(spans_duration_s(spans), 13.0 + 2.0) << "at most the neighbouring samples and a margin around each";
  for (const TimeSpan& s : spans) EXPECT_EQ(s.source, SpanSource::kInsStatus);
}

TEST(InsScreen, ADriveThatIsFloatThroughoutIsNotLeftOut) {
  // The usual solution is the drive's own: an INS that is never RTK fixed is not bad everywhere.
  std::vector<InsQuality> q = status_series();
  for (InsQuality& s : q)
    if (s.solution == GnssSolution::kRtkFixed) s = {s.t_s, GnssSolution::kRtkFloat, 0.2, 0.3};
  const std::vector<TimeSpan> spans = status_spans(q, InsStatusConfig{});
  ASSERT_EQ(spans.size(), 1u);
  EXPECT_EQ(spans[0].kind, SpanKind::kInsOnly);
}

// A 60 s figure-8 (1 deg azimuth step) of this seed with INS events, calibrated without the
// segments and the moving-points mask (tests/moving_points_test.cpp).
struct ScreenedDrive {
  std::shared_ptr<const sim::World> world;
  CalibrationResult r;
};
ScreenedDrive calibrate_drive(std::uint64_t seed, const sim::InsErrorConfig& ins_error) {
  sim::SimConfig sc;
  sc.seed = seed;
  sc.azimuth_step_deg = 1.0;
  sc.duration_s = 60.0;
  sc.ins_error = ins_error;
  ScreenedDrive out;
  out.world = std::make_shared<const sim::World>(sim::build_world(sc));
  const Dataset data = sim::world_dataset(out.world);
  PipelineConfig config;
  config.repeatability.segments = 0;
  config.moving.enabled = false;
  out.r = run_calibration(make_frame_store(data, config), config);
  return out;
}

TEST(InsScreen, WrongFixIsFoundAndTheResultStaysWithinBounds) {
  sim::InsErrorConfig ins_error;
  ins_error.wrong_fixes = 1;
  const auto [world, r] = calibrate_drive(4, ins_error);
  ASSERT_EQ(world->ins_events.size(), 1u);
  const sim::InsEvent& fix = world->ins_events.front();
  // The INS reports the wrong fix as a good RTK fix: only the LiDAR checks can find it.
  EXPECT_GE(covered_s(r.excluded, fix.t_begin_s, fix.t_end_s), 0.8 * (fix.t_end_s - fix.t_begin_s));
  EXPECT_LT(spans_duration_s(r.excluded) - covered_s(r.excluded, fix.t_begin_s - 2.5, fix.t_end_s + 2.5), 3.0)
      << "little good time left out";
  for (const TimeSpan& s : r.excluded) EXPECT_NE(s.source, SpanSource::kInsStatus) << s.reason;
  // The advice says who found it: the LiDAR (which cannot tell a jump from a place it saw too little of).
  EXPECT_TRUE(advises(r, "The LiDAR finds the INS poses off for "));
  EXPECT_FALSE(advises(r, "The INS states a degraded solution"));
  const ExtrinsicError e = extrinsic_error(r.T_ins_lidar, world->T_ins_lidar_true);
  std::printf("wrong fix %.1f-%.1f s: %zu spans; |t| %.1f %.1f %.1f mm |rpy| %.4f %.4f %.4f deg\n",
              fix.t_begin_s - world->frame_times_s.front(), fix.t_end_s - world->frame_times_s.front(),
              r.excluded.size(), 1e3 * e.dt_m.x(), 1e3 * e.dt_m.y(), 1e3 * e.dt_m.z(), e.drpy_deg.x(), e.drpy_deg.y(),
              e.drpy_deg.z());
  EXPECT_LT(e.drpy_deg.maxCoeff(), 0.03);
  EXPECT_LT(e.dt_m.head<2>().maxCoeff(), 0.01);
}

// An outage the INS reports (INS-only, coasting): left out by its own status, and the advice says
// the INS stated it.
TEST(InsScreen, AStatedOutageIsAdvisedAsTheInsStatedIt) {
  sim::InsErrorConfig ins_error;
  ins_error.outages = 1;
  const CalibrationResult r = calibrate_drive(5, ins_error).r;
  bool stated = false;
  for (const TimeSpan& s : r.excluded) stated = stated || s.source == SpanSource::kInsStatus;
  EXPECT_TRUE(stated);
  EXPECT_TRUE(advises(r, "The INS states a degraded solution for "));
}

}  // namespace
}  // namespace insalign
