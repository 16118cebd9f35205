// One source of truth for a DOF's status (core/dof_status): `determined`, `stddev` and the
// sentences never contradict, and tz names where it came from; on the pipeline too.
#include <gtest/gtest.h>

#include <cmath>
#include <fmt/format.h>
#include <random>

#include "core/dof_status.hpp"
#include "core/pipeline.hpp"
#include "report/result_outputs.hpp"
#include "sim/simulate.hpp"
#include "sim/world_dataset.hpp"

namespace insalign {
namespace {

bool mentions(const std::vector<std::string>& lines, const std::string& what) {
  for (const std::string& l : lines)
    if (l.find(what) != std::string::npos) return true;
  return false;
}

// The sentence saying DOF `name` is not determined ("tz is not determined", "x, yaw not determined").
bool says_not_determined(const std::vector<std::string>& lines, const std::string& name) {
  for (const std::string& l : lines) {
    const std::size_t at = l.find("not determined");
    if (at == std::string::npos) continue;
    const std::string head = " " + l.substr(0, at);
    for (const std::string sep : {" ", ","})
      if (head.find(sep + name + " ") != std::string::npos || head.find(sep + name + ",") != std::string::npos) return true;
  }
  return false;
}

// The whole contract of a status, whatever the evidence.
void expect_consistent(const DofStatusResult& s) {
  const std::vector<std::string> dofs{"tx", "ty", "tz", "roll", "pitch", "yaw"};
  for (int i = 0; i < 6; ++i) {
    const DofStatus& d = s.dofs[static_cast<std::size_t>(i)];
    EXPECT_EQ(d.determined, std::isfinite(d.stddev)) << dofs[static_cast<std::size_t>(i)];
    EXPECT_EQ(!d.determined, says_not_determined(s.advice, dofs[static_cast<std::size_t>(i)]))
        << dofs[static_cast<std::size_t>(i)] << ": " << (s.advice.empty() ? "" : s.advice.front());
  }
}

TEST(DofStatus, DeterminedStddevAndSentencesAgreeOnRandomEvidence) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int trial = 0; trial < 500; ++trial) {
    DofEvidence e;
    for (int i = 0; i < 6; ++i) {
      e.observed[static_cast<std::size_t>(i)] = u(rng) < 0.8;
      const double r = u(rng);
      e.stddev[i] = r < 0.1 ? std::numeric_limits<double>::infinity() : (i < 3 ? 0.05 : 0.002) * r;
    }
    e.tz_source = static_cast<TzSource>(static_cast<int>(u(rng) * 6) % 6);
    e.tz_m = 1.0;
    const DofStatusResult s = decide_dof_status(e);
    expect_consistent(s);
    for (int i = 0; i < 6; ++i)
      if (s.dofs[static_cast<std::size_t>(i)].determined) {
        EXPECT_EQ(s.dofs[static_cast<std::size_t>(i)].stddev, e.stddev[i]);
      }
  }
}

// The real-scan case: stage 1 estimated tz with a formal 1 mm that the drive does not
// back up. A loose data tz is reported not determined, with its value and why; a tight one stands.
TEST(DofStatus, TzFromTheDataAloneCountsOnlyWhenTight) {
  DofEvidence e;
  e.observed.fill(true);
  e.stddev << 0.002, 0.002, 0.045, 1e-4, 1e-4, 3e-4;
  e.tz_source = TzSource::kData;
  e.tz_m = -0.231;
  DofStatusResult s = decide_dof_status(e);
  expect_consistent(s);
  EXPECT_FALSE(s.dofs[2].determined);
  ASSERT_FALSE(s.advice.empty());
  EXPECT_NE(s.advice.front().find("roll and pitch put it at -0.231 m"), std::string::npos) << s.advice.front();
  EXPECT_NE(s.advice.front().find("--fiducials"), std::string::npos);
  e.stddev[2] = 0.008;
  s = decide_dof_status(e);
  expect_consistent(s);
  EXPECT_TRUE(s.dofs[2].determined);
  EXPECT_EQ(s.dofs[2].stddev, 0.008);
}

TEST(DofStatus, TzNamesWhereItCameFrom) {
  DofEvidence e;
  e.observed.fill(true);
  e.observed[2] = false;
  e.stddev << 0.003, 0.002, std::numeric_limits<double>::infinity(), 1e-4, 1e-4, 3e-4;
  e.tz_m = 2.078;
  e.tz_assumed_sigma_m = 0.5;
  e.dx_per_tz = 0.0093;
  const std::pair<TzSource, std::string> cases[] = {{TzSource::kInit, "the --init file's value (2.078 m)"},
                                                    {TzSource::kGuess, "the built-in guess"},
                                                    {TzSource::kInsHeightGiven, "--ins-height-m"}};
  for (const auto& [source, phrase] : cases) {
    e.tz_source = source;
    const DofStatusResult s = decide_dof_status(e);
    expect_consistent(s);
    EXPECT_EQ(s.tz_source, source);
    ASSERT_FALSE(s.advice.empty());
    EXPECT_NE(s.advice.front().find(phrase), std::string::npos) << s.advice.front();
    EXPECT_NE(s.advice.front().find("0.9, 0.0 mm per 0.1 m of tz"), std::string::npos) << s.advice.front();
  }
}

// Weak DOFs are named first, each with what to do; x whose stddev is mostly tz's says so.
TEST(DofStatus, WeakDofsSayWhatToDo) {
  DofEvidence e;
  e.observed.fill(true);
  e.stddev << 0.015, 0.012, 0.004, 0.0015 * kRadPerDeg, 0.08 * kRadPerDeg, 0.01 * kRadPerDeg;
  e.tz_source = TzSource::kFiducials;
  e.tz_assumed_sigma_m = 0.0;
  const DofStatusResult s = decide_dof_status(e);
  expect_consistent(s);
  ASSERT_EQ(s.advice.size(), 3u);
  EXPECT_NE(s.advice[0].find("tx is weakly determined (+- 1.5 cm): drive more turns"), std::string::npos) << s.advice[0];
  EXPECT_NE(s.advice[2].find("pitch is weakly determined (+- 0.080 deg)"), std::string::npos) << s.advice[2];
  e.observed[2] = false;
  e.tz_source = TzSource::kInit;
  e.tz_assumed_sigma_m = 0.5;
  e.dx_per_tz = 0.03;  // 15 mm of x's 15 mm is tz's
  const DofStatusResult t = decide_dof_status(e);
  expect_consistent(t);
  EXPECT_TRUE(mentions(t.advice, "tx is weakly determined (+- 1.5 cm): most of it is tz's uncertainty"));
  // Pitch's stddev mostly the INS's slow error, as the trajectory correction measured it.
  e.ins_drift_stddev[4] = 0.07 * kRadPerDeg;
  const DofStatusResult u = decide_dof_status(e);
  expect_consistent(u);
  EXPECT_TRUE(mentions(u.advice, "pitch is weakly determined (+- 0.080 deg): most of it is the INS's slow position error"));
  EXPECT_TRUE(mentions(u.advice, "tx is weakly determined (+- 1.5 cm): most of it is tz's uncertainty"));
}

// The scenario: a drifting INS on a figure-8 without fiducials, an init whose tz is
// 0.21 m off and whose rotation is far off. The rotation may be dropped, but tz is the init's,
// never the built-in guess, and the result says so.
TEST(DofStatus, TzIsTheInitsWhenNothingDeterminesItEvenIfItsRotationIsDropped) {
  sim::SimConfig sc;
  sc.seed = 12;
  sc.duration_s = 40.0;
  sc.azimuth_step_deg = 1.0;
  sc.n_fiducials = 0;
  sc.ins_error.model = sim::InsErrorModel::kDrift;
  const auto world = std::make_shared<const sim::World>(sim::build_world(sc));
  Dataset data = sim::world_dataset(world);
  Iso3 T_init = world->T_ins_lidar_true;
  T_init.translation() += Vec3(0.05, -0.04, 0.21);
  T_init.linear() = so3_exp(Vec3(0.0, 0.0, 100.0) * kRadPerDeg) * T_init.linear();
  data.T_ins_lidar_init = T_init;
  PipelineConfig config;
  config.repeatability.segments = 0;
  const FrameStore store = make_frame_store(data, config);
  const CalibrationResult r = run_calibration(store, config);
  std::printf("init source %s, tz source %s, tz %.3f m (init %.3f, truth %.3f)\n", enum_name(r.init.source).data(),
              enum_name(r.tz_source).data(), r.T_ins_lidar.translation().z(), T_init.translation().z(),
              world->T_ins_lidar_true.translation().z());
  EXPECT_EQ(r.init.source, InitSource::kDataOverridesInit) << r.init.explanation;
  ASSERT_EQ(r.tz_source, TzSource::kInit);
  EXPECT_NEAR(r.T_ins_lidar.translation().z(), T_init.translation().z(), 1e-9);
  EXPECT_LT(extrinsic_error(r.T_ins_lidar, world->T_ins_lidar_true).angle_deg, 0.1);
  EXPECT_FALSE(r.determined[2]);
  EXPECT_FALSE(std::isfinite(r.stddev[2]));
  ASSERT_FALSE(r.advice.empty());
  EXPECT_EQ(r.warnings.front(), r.advice.front());  // first, in the warnings too
  EXPECT_NE(r.advice.front().find(fmt::format("the --init file's value ({:.3f} m)", T_init.translation().z())),
            std::string::npos) << r.advice.front();
  for (int i = 0; i < 6; ++i) EXPECT_EQ(r.determined[static_cast<std::size_t>(i)], std::isfinite(r.stddev[i])) << i;
  for (const std::string& w : r.warnings) EXPECT_EQ(w.find("built-in"), std::string::npos) << w;
}

// What the user reads first: the terminal summary opens with one `attention:` line per advice
// sentence, before the numbers; the later warnings are not repeated.
TEST(DofStatus, SummaryOpensWithTheAdvice) {
  CalibrationResult r;
  DofEvidence e;
  e.observed.fill(true);
  e.observed[2] = false;
  e.stddev << 0.015, 0.002, std::numeric_limits<double>::infinity(), 1e-4, 1e-4, 3e-4;
  e.tz_source = TzSource::kInit;
  e.tz_m = 2.078;
  const DofStatusResult s = decide_dof_status(e);
  r.advice = s.advice;
  r.determined = s.determined();
  r.stddev = s.stddev();
  r.tz_source = s.tz_source;
  r.warnings = r.advice;
  r.warnings.push_back("segments of the drive disagree more than expected (x 2 cm)");
  const std::string text = io::summary_text(r, io::RunInfo{});
  ASSERT_EQ(r.advice.size(), 2u);  // tz, then x weak
  const std::size_t first = text.find("attention: tz is not determined: it is the --init file's value (2.078 m)");
  const std::size_t second = text.find("attention: tx is weakly determined (+- 1.5 cm): drive more turns");
  EXPECT_NE(first, std::string::npos) << text;
  EXPECT_LT(first, second);
  EXPECT_LT(second, text.find("T_ins_lidar"));
  EXPECT_NE(text.find("tz from the --init file"), std::string::npos) << text;
  EXPECT_NE(text.find("warning: segments of the drive disagree"), std::string::npos);
  EXPECT_EQ(text.find("warning: tz is not determined"), std::string::npos) << "said twice";
}

}  // namespace
}  // namespace insalign
