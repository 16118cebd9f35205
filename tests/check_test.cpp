// The check's verdict rules (CONVENTIONS.md "Checking an installed extrinsic"), the history's
// information-weighted combination and step detection, and the stretch selection.
#include <gtest/gtest.h>

#include <cmath>

#include "core/check.hpp"
#include "core/check_history.hpp"
#include "core/stretches.hpp"

namespace insalign {
namespace {

std::string fmt_date(int k) { return "2026-01-" + std::string(k < 9 ? "0" : "") + std::to_string(k + 1) + "T10:00:00Z"; }

const Iso3 kMount = make_transform(Vec3(0.8, -0.3, 1.6), Vec3(1.5, -2.0, 92.0));

// The mount moved in the INS frame: R' = Rz Ry Rx(drpy) R, t' = t + dt.
Iso3 moved(const Iso3& T, const Vec3& dt_m, const Vec3& drpy_deg) {
  Iso3 out = T;
  out.linear() = rotation_from_rpy(drpy_deg * kRadPerDeg) * T.linear();
  out.translation() += dt_m;
  return out;
}

TEST(CheckCorrection, IsEstimateMinusInstalledInTheInsFrame) {
  const Iso3 est = moved(kMount, Vec3(0.02, -0.01, 0.0), Vec3(0.0, 0.05, 0.1));
  const Vec7 c = extrinsic_correction(kMount, 0.001, est, 0.004);
  EXPECT_NEAR(c(0), 0.02, 1e-12);
  EXPECT_NEAR(c(1), -0.01, 1e-12);
  EXPECT_NEAR(c(2), 0.0, 1e-12);
  EXPECT_NEAR(c(3), 0.0, 1e-9);
  EXPECT_NEAR(c(4), 0.05, 1e-9);
  EXPECT_NEAR(c(5), 0.1, 1e-9);
  EXPECT_NEAR(c(6), 0.003, 1e-15);
}

TEST(CheckRule, OkDriftedAndNotObservableAsConventionsSays) {
  const CheckConfig cfg;  // 0.05 deg, 2 cm, 2 ms; ok: |c| + 2 sd <= tol; drifted: |c| > tol and > 3 sd
  EXPECT_EQ(judge_dof(5, 0.01, 0.01, cfg).verdict, DofVerdictKind::kOk);          // 0.03 <= 0.05
  EXPECT_EQ(judge_dof(5, -0.01, 0.02, cfg).verdict, DofVerdictKind::kOk);         // 0.05 <= 0.05
  EXPECT_EQ(judge_dof(5, 0.01, 0.021, cfg).verdict, DofVerdictKind::kNotObservable);
  EXPECT_EQ(judge_dof(5, 0.10, 0.02, cfg).verdict, DofVerdictKind::kDrifted);     // > 0.05 and > 0.06
  EXPECT_EQ(judge_dof(5, -0.10, 0.034, cfg).verdict, DofVerdictKind::kNotObservable);  // 0.1 < 3 x 0.034
  EXPECT_EQ(judge_dof(5, 0.049, 0.0001, cfg).verdict, DofVerdictKind::kOk);       // sharp, inside
  EXPECT_EQ(judge_dof(5, 0.051, 0.0001, cfg).verdict, DofVerdictKind::kDrifted);  // sharp, just beyond
  EXPECT_EQ(judge_dof(0, 0.03, 0.005, cfg).verdict, DofVerdictKind::kDrifted);    // 3 cm vs 2 cm
  EXPECT_EQ(judge_dof(0, 0.005, 0.005, cfg).verdict, DofVerdictKind::kOk);
  EXPECT_EQ(judge_dof(6, 0.003, 0.0005, cfg).verdict, DofVerdictKind::kDrifted);  // 3 ms vs 2 ms
  const DofCheck unseen = judge_dof(2, 0.0, std::numeric_limits<double>::infinity(), cfg);
  EXPECT_EQ(unseen.verdict, DofVerdictKind::kNotObservable);
  EXPECT_NE(unseen.why.find("fiducials"), std::string::npos) << unseen.why;
  EXPECT_NE(judge_dof(5, 1.0, std::numeric_limits<double>::infinity(), cfg).why.find("turns both ways"),
            std::string::npos);
  CheckConfig loose = cfg;
  loose.tolerance_deg = 0.2;
  EXPECT_EQ(judge_dof(5, 0.10, 0.02, loose).verdict, DofVerdictKind::kOk);
}

TEST(CheckRule, OverallVerdict) {
  std::array<DofCheck, 7> dofs;
  for (DofCheck& d : dofs) d.verdict = DofVerdictKind::kOk;
  const std::array<bool, 7> none{};
  EXPECT_EQ(overall_verdict(dofs, none), CheckVerdict::kOk);
  dofs[2].verdict = DofVerdictKind::kNotObservable;
  EXPECT_EQ(overall_verdict(dofs, none), CheckVerdict::kInconclusive);
  std::array<bool, 7> tz_unchecked{};
  tz_unchecked[2] = true;
  EXPECT_EQ(overall_verdict(dofs, tz_unchecked), CheckVerdict::kOk);
  dofs[5].verdict = DofVerdictKind::kDrifted;
  EXPECT_EQ(overall_verdict(dofs, none), CheckVerdict::kRecalibrate);
  EXPECT_EQ(overall_verdict(dofs, tz_unchecked), CheckVerdict::kRecalibrate);
  CheckConfig cfg;
  cfg.unchecked_dofs = "tz, time_offset";
  const auto u = unchecked_dofs(cfg);
  EXPECT_TRUE(u[2] && u[6] && !u[0] && !u[5]);
  cfg.unchecked_dofs = "height";
  EXPECT_THROW(unchecked_dofs(cfg), std::invalid_argument);
}

MeasuredExtrinsic measured(const Iso3& T, double sd_m, double sd_deg, double sd_s) {
  MeasuredExtrinsic m;
  m.T_ins_lidar = T;
  m.stddev << sd_m, sd_m, sd_m, sd_deg * kRadPerDeg, sd_deg * kRadPerDeg, sd_deg * kRadPerDeg, sd_s;
  return m;
}

TEST(CheckJudge, KnockIsRecalibrateNamingTheDofs) {
  const Iso3 truth = moved(kMount, Vec3(0.0, 0.03, 0.0), Vec3(0.0, 0.0, 0.12));
  const CheckFindings f = judge_extrinsic(kMount, 0.0, measured(truth, 0.004, 0.01, 0.0003), CheckConfig{});
  EXPECT_EQ(f.verdict, CheckVerdict::kRecalibrate);
  EXPECT_EQ(f.dofs[1].verdict, DofVerdictKind::kDrifted);
  EXPECT_EQ(f.dofs[5].verdict, DofVerdictKind::kDrifted);
  EXPECT_EQ(f.dofs[0].verdict, DofVerdictKind::kOk);
  EXPECT_NE(f.message.find("ty"), std::string::npos) << f.message;
  EXPECT_NE(f.message.find("yaw"), std::string::npos) << f.message;
  EXPECT_TRUE(f.warnings.empty());
}

TEST(CheckJudge, InconclusiveSaysWhatDriveWouldDecide) {
  MeasuredExtrinsic m = measured(kMount, 0.004, 0.01, 0.0003);
  m.stddev(2) = std::numeric_limits<double>::infinity();
  const CheckFindings f = judge_extrinsic(kMount, 0.0, m, CheckConfig{});
  EXPECT_EQ(f.verdict, CheckVerdict::kInconclusive);
  EXPECT_NE(f.message.find("tz needs fiducials"), std::string::npos) << f.message;
}

TEST(CheckJudge, InvertedExtrinsicIsGrosslyOffAndSaysInvert) {
  const CheckFindings f = judge_extrinsic(kMount.inverse(), 0.0, measured(kMount, 0.004, 0.01, 0.0003), CheckConfig{});
  EXPECT_EQ(f.verdict, CheckVerdict::kRecalibrate);
  ASSERT_EQ(f.warnings.size(), 1u);
  EXPECT_NE(f.warnings[0].find("invert"), std::string::npos) << f.warnings[0];
  // Another LiDAR's extrinsic (a side mount) is grossly off too, but no inverse explains it.
  const Iso3 side = make_transform(Vec3(0.2, 0.9, 1.2), Vec3(0.0, 10.0, 90.0));
  const CheckFindings g = judge_extrinsic(side, 0.0, measured(kMount, 0.004, 0.01, 0.0003), CheckConfig{});
  ASSERT_EQ(g.warnings.size(), 1u);
  EXPECT_EQ(g.warnings[0].find("invert"), std::string::npos);
  EXPECT_NE(g.warnings[0].find("another LiDAR"), std::string::npos) << g.warnings[0];
}

CheckRecord record(const std::string& date, const Iso3& measured_T, double sd_deg, double sd_m) {
  CheckRecord r;
  r.drive_end = date;
  r.T_ins_lidar_checked = kMount;
  r.T_ins_lidar_corrected = measured_T;
  r.stddev = {sd_m, sd_m, std::numeric_limits<double>::infinity(), sd_deg, sd_deg, sd_deg, 0.0005};
  return r;
}

TEST(CheckHistory, CombinesInformationWeightedAndDatesAKnock) {
  // Six drives of the unchanged mount with 0.03 deg per-drive noise (seeded draws), then a knock
  // of 0.08 deg in yaw: each drive alone cannot call 0.08 deg drifted (3 x 0.03 = 0.09), the
  // drives since the knock together can, and the drives before it are not averaged in.
  std::vector<CheckRecord> records;
  const double noise_deg[] = {0.021, -0.034, 0.012, -0.008, 0.029, -0.017, 0.015, -0.022, 0.009, 0.026, -0.011};
  for (int k = 0; k < 11; ++k) {
    const double yaw = noise_deg[k] + (k >= 6 ? 0.08 : 0.0);
    records.push_back(record(fmt_date(k), moved(kMount, Vec3::Zero(), Vec3(0, 0, yaw)), 0.03, 0.005));
  }
  const CheckConfig check;
  HistoryConfig cfg;
  cfg.step_sigmas = 2.5;  // 0.08 deg against one drive's 0.03: 2.5 sigma
  // Before the knock: six drives, ok on yaw.
  const HistoryFindings before = combine_history({records.begin(), records.begin() + 6}, kMount, 0.0, check, cfg);
  EXPECT_EQ(before.drives, 6);
  EXPECT_TRUE(before.steps.empty());
  EXPECT_NEAR(before.dofs[5].stddev, 0.03 / std::sqrt(6.0), 1e-9);
  EXPECT_EQ(before.dofs[5].verdict, DofVerdictKind::kOk);
  const HistoryFindings after = combine_history(records, kMount, 0.0, check, cfg);
  ASSERT_EQ(after.steps.size(), 1u);
  EXPECT_EQ(after.steps[0].date, fmt_date(6));
  EXPECT_EQ(after.since, fmt_date(6));
  EXPECT_EQ(after.drives, 5);
  EXPECT_NEAR(after.dofs[5].correction, 0.08 + (0.015 - 0.022 + 0.009 + 0.026 - 0.011) / 5.0, 1e-6);
  EXPECT_EQ(after.dofs[5].verdict, DofVerdictKind::kDrifted);
  EXPECT_EQ(after.verdict, CheckVerdict::kRecalibrate);
  EXPECT_NE(after.message.find("5 drives"), std::string::npos) << after.message;
}

// 30 minutes east at 10 m/s with a left turn at 300 s, a right turn at 900 s and a stop at
// 1200 s, as the INS reports it at 10 Hz (x-forward body).
PoseStream long_drive(double duration_s) {
  std::vector<StampedPose> poses;
  double heading = 0.0, speed = 10.0;
  Vec3 p = Vec3::Zero();
  for (double t = 0.0; t <= duration_s; t += 0.1) {
    double yaw_rate = 0.0;
    if (t >= 300 && t < 310) yaw_rate = M_PI / 20;   // 90 deg left in 10 s
    if (t >= 900 && t < 910) yaw_rate = -M_PI / 20;  // 90 deg right
    speed = (t >= 1195 && t < 1235) ? std::max(0.0, 10.0 * std::abs(t - 1215.0) / 20.0) : 10.0;
    heading += yaw_rate * 0.1;
    p += 0.1 * speed * Vec3(std::cos(heading), std::sin(heading), 0.0);
    Iso3 T = Iso3::Identity();
    T.linear() = rotation_from_rpy(Vec3(0, 0, heading));
    T.translation() = p;
    poses.push_back({1.7e9 + t, T});
  }
  return PoseStream(std::move(poses));
}

TEST(CheckStretches, PicksTheTurnsBothWaysWithinTheBudget) {
  const PoseStream poses = long_drive(1800.0);
  StretchConfig cfg;
  const std::vector<Stretch> used = informative_stretches(poses, poses.t_begin(), poses.t_end(), cfg);
  ASSERT_FALSE(used.empty());
  double total = 0.0;
  bool left = false, right = false, stop = false;
  for (std::size_t i = 0; i < used.size(); ++i) {
    total += used[i].end_s - used[i].begin_s;
    if (i > 0) {
      EXPECT_GT(used[i].begin_s, used[i - 1].end_s);
    }
    const double a = used[i].begin_s - 1.7e9, b = used[i].end_s - 1.7e9;
    if (a <= 300 && b >= 310) left = used[i].why.find("left") != std::string::npos;
    if (a <= 900 && b >= 910) right = used[i].why.find("right") != std::string::npos;
    if (a <= 1215 && b >= 1200) stop = true;
  }
  EXPECT_LE(total, cfg.budget_s + cfg.window_s);
  EXPECT_TRUE(left && right && stop);
  // A short drive is used whole.
  const PoseStream short_drive = long_drive(120.0);
  const auto whole = informative_stretches(short_drive, short_drive.t_begin(), short_drive.t_end(), cfg);
  ASSERT_EQ(whole.size(), 1u);
  EXPECT_NEAR(whole[0].end_s - whole[0].begin_s, 120.0, 0.2);
}

}  // namespace
}  // namespace insalign
