// What `--config` and `--set` can say about reading the inputs (the `input:` section of a tool
// config): the text export column mapping, the clock rules and what a cut-off recording may do.
// Command-line options override it.
#pragma once

#include <optional>
#include <string>

#include "input/clock_alignment.hpp"

namespace insalign::io {

struct InputConfig {
  /// Text exports: the column mapping (parse_text_export_columns' spec); --poses-columns overrides.
  std::string poses_columns;
  /// A known whole-second clock offset, t_ins = t_lidar + this (s); null: found from the data.
  std::optional<double> clock_offset_s;
  ClockCheckConfig clock;
  /// A ROS 1 bag whose file ends inside a chunk (a recording cut off mid-chunk): false, exit 2
  /// naming the cut chunk's byte; true, read the whole chunks before it, with a warning.
  bool read_cut_off = false;
};

template <class V>
void visit_config(V& v, InputConfig& c) {
  v("poses_columns", c.poses_columns,
    "text export column mapping, e.g. \"time=GPSTime:gps-sow,lat=Latitude,...\" (see README; --poses-columns overrides)");
  v("clock_offset_s", c.clock_offset_s, "known LiDAR-to-INS clock offset t_ins = t_lidar + this, s (null: detect from the data)");
  v("read_cut_off", c.read_cut_off,
    "ROS 1 bag cut off mid-chunk: false stops (exit 2, the message names the byte), true reads the whole chunks before "
    "the cut, with a warning");
  v.section("clock", c.clock);
}

}  // namespace insalign::io
