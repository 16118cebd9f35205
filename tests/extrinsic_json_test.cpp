// OpenCalib extrinsic JSON: the real file, exact round trips.
#include "files/extrinsic_json.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>
#include <random>

namespace insalign::io {
namespace {

namespace fs = std::filesystem;

const fs::path kSampleJson =
    fs::path(INSALIGN_SHARED_DATA_DIR) / "opencalib-sample" / "gnss-to-top_center_lidar-extrinsic.json";

TEST(ExtrinsicJson, RealSampleIsTheInverseOfTheStoredMatrix) {
  if (!fs::exists(kSampleJson)) GTEST_SKIP() << "shared sample data not found at " << kSampleJson;
  const Iso3 T_ins_lidar = read_opencalib_extrinsic(kSampleJson);
  const Iso3 T_lidar_ins = T_ins_lidar.inverse();
  // Stored: translation (-1.7079, -0.5218, -1.3773), first row 0.1712262 0.9681076 0.1828910.
  EXPECT_NEAR(T_lidar_ins.translation().x(), -1.7079, 1e-6);
  EXPECT_NEAR(T_lidar_ins.translation().y(), -0.5218, 1e-6);
  EXPECT_NEAR(T_lidar_ins.translation().z(), -1.3773, 1e-6);
  EXPECT_NEAR(T_lidar_ins.linear()(0, 0), 0.1712262, 1e-6);
  EXPECT_NEAR(T_lidar_ins.linear()(0, 1), 0.9681076, 1e-6);
  EXPECT_NEAR(T_lidar_ins.linear()(2, 1), -0.2099706, 1e-6);
  EXPECT_NEAR(T_ins_lidar.linear().determinant(), 1.0, 1e-12);
}

TEST(ExtrinsicJson, RoundTripExact) {
  const fs::path p = fs::temp_directory_path() / ("insalign_ext_" + std::to_string(::getpid()) + ".json");
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    const Iso3 T = make_transform(Vec3(u(rng) * 3, u(rng) * 3, u(rng) * 3),
                                  Vec3(u(rng) * 180, u(rng) * 89, u(rng) * 180));
    write_opencalib_extrinsic(p, T);
    const Iso3 back = read_opencalib_extrinsic(p);
    EXPECT_LT((back.matrix() - T.matrix()).cwiseAbs().maxCoeff(), 1e-12) << trial;
  }
  // The shape OpenCalib expects.
  std::ifstream in(p);
  const nlohmann::json j = nlohmann::json::parse(in);
  ASSERT_TRUE(j.contains("gnss-to-top_center_lidar-extrinsic"));
  const auto& e = j["gnss-to-top_center_lidar-extrinsic"];
  EXPECT_EQ(e["target_sensor_name"], "top_center_lidar");
  EXPECT_EQ(e["param"]["sensor_calib"]["data"].size(), 4u);
  fs::remove(p);
}

TEST(ExtrinsicJson, TransformJsonRoundTrip) {
  const Iso3 T = make_transform(Vec3(0.1, -2.0 / 3, 1e-7), Vec3(10, -20, 170));
  const nlohmann::json j = nlohmann::json::parse(transform_to_json(T).dump());
  EXPECT_LT((transform_from_json(j, "x").matrix() - T.matrix()).cwiseAbs().maxCoeff(), 1e-12);
}

}  // namespace
}  // namespace insalign::io
