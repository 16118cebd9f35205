// insalign evaluate (and the simulate command's files): error printout, thresholds, exit codes.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "cli_test_util.hpp"
#include "core/geometry.hpp"
#include "files/extrinsic_json.hpp"

namespace insalign {
namespace {

namespace fs = std::filesystem;

using testing::RunResult;
const auto& run = testing::run_insalign;

class EvaluateCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("insalign_evaluate_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string write_json(const std::string& name, const nlohmann::json& j) {
    const fs::path p = dir_ / name;
    std::ofstream(p) << j.dump(2);
    return p.string();
  }
  fs::path dir_;
};

TEST_F(EvaluateCli, PrintsErrorsAndAppliesThresholds) {
  const Iso3 T_gt = make_transform(Vec3(1.0, 0.2, 1.3), Vec3(1.0, -2.0, 95.0));
  // Estimate: 0.3 deg about z (yaw) and 2 cm in x, 1 cm in z off.
  Iso3 T_est = T_gt;
  T_est.linear() = rotation_from_rpy(Vec3(0, 0, 0.3 * kRadPerDeg)) * T_gt.linear();
  T_est.translation() += Vec3(0.02, 0.0, -0.01);
  const std::string gt = write_json("gt.json", {{"T_ins_lidar", io::transform_to_json(T_gt)}, {"time_offset_s", 0.05}});
  const std::string est =
      write_json("est.json", {{"T_ins_lidar", io::transform_to_json(T_est)}, {"time_offset_s", 0.047}});

  RunResult r = run("evaluate --gt " + gt + " --result " + est);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("dx 0.0200"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("dz 0.0100"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("yaw 0.3000"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("angle 0.3000"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("error 0.0030 s"), std::string::npos) << r.output;

  r = run("evaluate --gt " + gt + " --result " + est + " --max-rot-deg 0.5 --max-trans-m 0.05");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("PASS"), std::string::npos);
  r = run("evaluate --gt " + gt + " --result " + est + " --max-rot-deg 0.2");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("FAIL: rotation"), std::string::npos);
  r = run("evaluate --gt " + gt + " --result " + est + " --max-trans-m 0.021");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  // Without z the 2 cm x error alone passes.
  r = run("evaluate --gt " + gt + " --result " + est + " --max-trans-m 0.021 --ignore-z");
  EXPECT_EQ(r.exit_code, 0) << r.output;
}

TEST_F(EvaluateCli, BadInputExitsTwo) {
  const std::string gt = write_json("gt.json", {{"T_ins_lidar", io::transform_to_json(Iso3::Identity())}});
  const std::string no_key = write_json("nokey.json", {{"extrinsic", 1}});
  {
    std::ofstream(dir_ / "broken.json") << "{\"T_ins_lidar\": [[1,0,0,0],";
  }
  RunResult r = run("evaluate --gt " + gt + " --result " + no_key);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("nokey.json"), std::string::npos) << r.output;
  r = run("evaluate --gt " + gt + " --result " + (dir_ / "broken.json").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("byte"), std::string::npos) << r.output;
  r = run("evaluate --gt " + gt + " --result " + (dir_ / "missing.json").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  r = run("evaluate --gt " + gt);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  const std::string bad_rot = write_json("badrot.json", {{"T_ins_lidar", {{1, 1, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}}}});
  r = run("evaluate --gt " + gt + " --result " + bad_rot);
  EXPECT_EQ(r.exit_code, 2) << r.output;
}

TEST_F(EvaluateCli, SimulateWritesTheDatasetAndEvaluatesAgainstItself) {
  const fs::path out = dir_ / "sim";
  RunResult r = run("simulate --out " + out.string() +
                    " --seed 3 --frames 4 --azimuth-step-deg 2 --lidar hdl32 --time-offset-s 0.02 --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::size_t pcds = 0;
  for (const auto& e : fs::directory_iterator(out / "lidar")) {
    ++pcds;
    const double t = std::stod(e.path().stem().string());
    EXPECT_GT(t, 1.6e9);
  }
  EXPECT_EQ(pcds, 4u);
  for (const char* f : {"poses.txt", "poses_tum.txt", "init-extrinsic.json", "fiducials.txt", "ground_truth.json"})
    EXPECT_TRUE(fs::exists(out / f)) << f;
  std::ifstream poses(out / "poses.txt");
  std::string line;
  int lines = 0;
  while (std::getline(poses, line)) lines += !line.empty();
  EXPECT_EQ(lines, 4);
  const nlohmann::json gt = nlohmann::json::parse(std::ifstream(out / "ground_truth.json"));
  EXPECT_DOUBLE_EQ(gt.at("time_offset_s").get<double>(), 0.02);
  EXPECT_EQ(gt.at("T_ins_lidar").size(), 4u);
  // The ground truth against itself: zero error, passes the tightest thresholds.
  r = run("evaluate --gt " + (out / "ground_truth.json").string() + " --result " + (out / "ground_truth.json").string() +
          " --max-rot-deg 1e-6 --max-trans-m 1e-9");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  // Running again into the same directory without --overwrite refuses.
  r = run("simulate --out " + out.string() + " --frames 2 --quiet");
  EXPECT_EQ(r.exit_code, 2) << r.output;
}

TEST_F(EvaluateCli, SimulateRejectsBadOptions) {
  const std::string out = (dir_ / "bad").string();
  for (const std::string& args :
       {std::string("--lidar vlp99"), std::string("--scene mars"), std::string("--azimuth-step-deg 0"),
        std::string("--extrinsic \"1 2 3\""), std::string("--trajectory figure-eight"), std::string("--frames 3 --duration-s 1"),
        std::string("--ins-axes z-forward"), std::string("--pcd-encoding lzma")}) {
    const RunResult r = run("simulate --out " + out + " " + args + " --quiet");
    EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.output;
    EXPECT_FALSE(r.output.empty()) << args;
  }
}

}  // namespace
}  // namespace insalign
