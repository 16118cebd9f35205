// What was read, said the same way everywhere: `insalign info`, the terminal before a calibration,
// extrinsic.json's "input" block and the report's input rows. One LoadReport in, text or JSON out.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "input/clock_alignment.hpp"
#include "input/dataset.hpp"
#include "inslog/pose_source.hpp"

namespace insalign::io {

/// extrinsic.json "input": frames, time convention, the pose source's facts, the clock decision
/// with its evidence, fiducials, initial guess, warnings.
nlohmann::json input_json(const LoadReport& load);

/// The report's input rows (what, value).
std::vector<std::pair<std::string, std::string>> input_rows(const LoadReport& load);

/// The pose source in lines for people: format, records and rate, time base, `ins`, datum,
/// world, solution fractions.
std::string describe_pose_source(const PoseSourceFacts& facts);

/// The clock decision and its evidence, in lines.
std::string describe_clock(const ClockAlignment& clock);

/// "time (float32 seconds relative to the sweep)": a per-point time field in words.
std::string describe_time_field(const std::string& field);

}  // namespace insalign::io
