#include "io/result_json.hpp"

#include <cmath>

#include "io/extrinsic_json.hpp"

namespace insalign::io {
namespace {

using nlohmann::json;

// JSON has no NaN or infinity: unknown numbers are null.
json number(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

json vec(const Vec3& v) { return json::array({number(v.x()), number(v.y()), number(v.z())}); }

json dof_map(const Vec6& v, bool angles_in_deg_already) {
  const double k = angles_in_deg_already ? 1.0 : kDegPerRad;
  return {{"tx_m", number(v[0])},         {"ty_m", number(v[1])},          {"tz_m", number(v[2])},
          {"roll_deg", number(v[3] * k)}, {"pitch_deg", number(v[4] * k)}, {"yaw_deg", number(v[5] * k)}};
}

}  // namespace

json extrinsic_fields(const Iso3& T_ins_lidar) {
  const Eigen::Quaterniond q(T_ins_lidar.linear());
  return {{"T_ins_lidar", transform_to_json(T_ins_lidar)},
          {"translation_m", vec(T_ins_lidar.translation())},
          {"rpy_deg", vec(rpy_from_rotation(T_ins_lidar.linear()) * kDegPerRad)},
          {"quaternion_wxyz", json::array({q.w(), q.x(), q.y(), q.z()})}};
}

json result_to_json(const CalibrationResult& r, const LoadReport& load, const DriveSummary& drive) {
  json out = extrinsic_fields(r.T_ins_lidar);
  out["time_offset_s"] = r.time_offset_s;
  out["stddev"] = dof_map(r.stddev, true);
  if (r.refine) out["stddev"]["time_offset_s"] = number(r.refine->time_offset_stddev_s);
  json determined = json::object();
  for (int i = 0; i < 6; ++i) determined[kDofNames[i]] = r.determined[i];
  out["determined"] = determined;
  out["tz_source"] = r.z.method;
  out["warnings"] = r.warnings;
  out["wall_time_s"] = r.wall_time_s;

  json stages = json::object();
  stages["init"] = {{"source", r.init.source},
                    {"explanation", r.init.explanation},
                    {"wall_time_s", r.init.wall_time_s},
                    {"extrinsic", extrinsic_fields(r.init.T_ins_lidar)}};
  for (const InitCandidate& c : r.init.candidates) {
    stages["init"]["candidates"].push_back(
        {{"label", c.label}, {"score", c.score}, {"extrinsic", extrinsic_fields(c.T_ins_lidar)}});
  }
  json rounds = json::array();
  for (const RoundLog& log : r.rough.convergence) {
    rounds.push_back({{"round", log.round}, {"cost", log.cost}, {"planes", log.planes}, {"residuals", log.residuals},
                      {"extrinsic", extrinsic_fields(log.T_ins_lidar)}});
  }
  stages["rough"] = {{"extrinsic", extrinsic_fields(r.rough.T_ins_lidar)},
                     {"cost_before_m2", r.rough.cost_before},
                     {"cost_after_m2", r.rough.cost_after},
                     {"residual_sigma_m", r.rough.residual_sigma_m},
                     {"frames_used", r.rough.frames_used},
                     {"planes", r.rough.planes},
                     {"residuals", r.rough.residuals},
                     {"tz_estimated", r.rough.tz_estimated},
                     {"observability",
                      {{"stddev", dof_map(r.rough.observability.stddev, false)},
                       {"explanation", r.rough.observability.explanation}}},
                     {"rounds", rounds},
                     {"wall_time_s", r.rough.wall_time_s}};
  if (r.refine) {
    const RefineResult& f = *r.refine;
    json refine_rounds = json::array();
    for (const RefineRound& log : f.rounds) {
      refine_rounds.push_back({{"round", log.round}, {"cost", log.cost}, {"time_offset_s", log.time_offset_s},
                               {"extrinsic", extrinsic_fields(log.T_ins_lidar)}});
    }
    stages["refine"] = {{"extrinsic", extrinsic_fields(f.T_ins_lidar)},
                        {"time_offset_s", f.time_offset_s},
                        {"time_offset_estimated", f.time_offset_estimated},
                        {"measure", f.measure},
                        {"crispness_before", f.crispness_before},
                        {"crispness_after", f.crispness_after},
                        {"occupied_voxels_before", f.occupied_voxels_before},
                        {"occupied_voxels_after", f.occupied_voxels_after},
                        {"frames_used", f.frames_used},
                        {"points_used", f.points_used},
                        {"evaluations", f.evaluations},
                        {"converged", f.converged},
                        {"rounds", refine_rounds},
                        {"wall_time_s", f.wall_time_s}};
  }
  json fiducials = json::array();
  for (const FiducialResidual& f : r.z.fiducials) {
    fiducials.push_back({{"id", f.id},
                         {"residual_before_m", number(f.residual_before_m)},
                         {"residual_after_m", number(f.residual_after_m)},
                         {"used", f.used},
                         {"reason_rejected", f.reason_rejected},
                         {"map_points", f.map_points}});
  }
  stages["z"] = {{"determined", r.z.determined},   {"method", r.z.method},
                 {"explanation", r.z.explanation}, {"dz_m", r.z.dz_m},
                 {"tz_stddev_m", number(r.z.tz_stddev_m)}, {"fiducials", fiducials},
                 {"wall_time_s", r.z.wall_time_s}};
  out["stages"] = stages;

  json segments = json::array();
  for (const SegmentResult& s : r.segments) {
    json seg = {{"t_begin_s", s.t_begin_s}, {"t_end_s", s.t_end_s}, {"frames", s.frames}, {"ok", s.ok}};
    if (s.ok) {
      seg["extrinsic"] = extrinsic_fields(s.T_ins_lidar);
      seg["time_offset_s"] = s.time_offset_s;
    } else {
      seg["message"] = s.message;
    }
    segments.push_back(seg);
  }
  out["repeatability"] = {{"segments", segments}, {"spread", dof_map(r.segment_spread, true)}};

  out["motion"] = {{"distance_m", r.motion.distance_m},
                   {"heading_change_deg", r.motion.heading_change_deg},
                   {"max_speed_mps", r.motion.max_speed_mps},
                   {"duration_s", r.motion.duration_s}};
  out["input"] = {{"frames_total", load.frames_total},
                  {"frames_used", load.frames_used},
                  {"time_field", load.time_field},
                  {"frame_time_source", load.frame_time_source},
                  {"pose_format", load.pose_format},
                  {"poses", drive.poses},
                  {"distance_m", drive.distance_m},
                  {"heading_change_deg", drive.heading_change_deg},
                  {"speed_max_mps", drive.speed_max_mps},
                  {"warnings", load.warnings}};
  return out;
}

}  // namespace insalign::io
