// What `--config` and `--set` can say about reading the inputs (the `input:` section of a tool
// config): the text export column mapping and the clock rules. Command-line options override it.
#pragma once

#include <optional>
#include <string>

#include "io/clock_alignment.hpp"

namespace insalign::io {

struct InputConfig {
  /// Text exports: the column mapping (parse_text_export_columns' spec); --poses-columns overrides.
  std::string poses_columns;
  /// A known whole-second clock offset, t_ins = t_lidar + this (s); null: found from the data.
  std::optional<double> clock_offset_s;
  ClockCheckConfig clock;
};

template <class V>
void visit_config(V& v, InputConfig& c) {
  v("poses_columns", c.poses_columns,
    "text export column mapping, e.g. \"time=GPSTime:gps-sow,lat=Latitude,...\" (see README; --poses-columns overrides)");
  v("clock_offset_s", c.clock_offset_s, "known LiDAR-to-INS clock offset t_ins = t_lidar + this, s (null: detect from the data)");
  v.section("clock", c.clock);
}

}  // namespace insalign::io
