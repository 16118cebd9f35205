// OUT_DIR/extrinsic.json: the result, its uncertainty, what the data determined, and per-stage
// metrics and wall times (CONVENTIONS.md).
#pragma once

#include <nlohmann/json.hpp>

#include "core/drive_summary.hpp"
#include "core/pipeline.hpp"
#include "io/dataset.hpp"

namespace insalign::io {

/// The extrinsic alone in the result shape: T_ins_lidar, translation_m, rpy_deg, quaternion_wxyz.
nlohmann::json extrinsic_fields(const Iso3& T_ins_lidar);

nlohmann::json result_to_json(const CalibrationResult& result, const LoadReport& load, const DriveSummary& drive);

}  // namespace insalign::io
