// `insalign info`: what any input holds, in the words a calibration engineer checks before
// calibrating. A recording: every topic with its type and count, the chosen LiDAR and INS topics
// and why, the per-point time convention, the clocks; any pose source: format, records and rate,
// time base, which frame `ins` is, height datum, GNSS solution fractions; then the drive summary.
#pragma once

#include <cstddef>
#include <functional>
#include <string>

#include "core/drive_summary.hpp"
#include "input/dataset.hpp"
#include "input/input_source.hpp"

namespace insalign::io {

/// Receives the description piece by piece (the topic listing comes before a choice that fails).
using InfoSink = std::function<void(const std::string&)>;

/// Describes what `spec` names (as load_input takes it, or --poses alone) into `out`. Throws
/// InputError as load_input does (an ambiguous topic, a bad file, clocks nothing explains).
void describe_input(const InputSpec& spec, const InputConfig& config, const InfoSink& out, std::size_t sample_frames = 5);

/// What a command prints before it works: the input, frames, per-point time, frame times, the pose
/// source, the clock decision, fiducials, the initial guess and the warnings.
std::string describe_load(const LoadReport& load);

/// The drive figures (poses; frames and points when the summary has them).
std::string describe_drive(const DriveSummary& summary);

}  // namespace insalign::io
