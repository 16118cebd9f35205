// Pictures for the report: the stitched map as PNG images (top and side views coloured by height,
// zoomed edge-on cross-sections of a wall and of the ground with a metric scale bar) and line
// plots as inline SVG. All views of one report share their framing, so images of the map at
// different extrinsics compare pixel for pixel.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "core/geometry.hpp"

namespace insalign::io {

struct Rgb {
  std::uint8_t r = 0, g = 0, b = 0;
};

/// An 8-bit RGB raster, top row first.
struct Image {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;

  Image() = default;
  Image(int w, int h, Rgb fill);
  void set(int x, int y, Rgb c);                 ///< ignores pixels outside
  void blend(int x, int y, Rgb c, double alpha); ///< alpha in [0, 1]
  void fill_rect(int x0, int y0, int x1, int y1, Rgb c);  ///< [x0, x1) x [y0, y1), clipped
  /// ASCII text, top-left at (x, y), each font pixel drawn as scale x scale pixels.
  void text(int x, int y, const std::string& s, Rgb c, int scale = 2);
  static int text_width(const std::string& s, int scale = 2);
};

/// PNG bytes (libstb). Throws std::runtime_error if encoding fails.
std::string encode_png(const Image& image);
/// Atomic (files/atomic_file.hpp).
void write_png(const std::filesystem::path& path, const Image& image);

/// Height colour map (dark blue - teal - green - yellow), t in [0, 1] (clamped).
Rgb height_colour(double t);
inline constexpr Rgb kMarkedColour{230, 0, 200};

/// The framing shared by all map views of a report: an axis-aligned box in the world frame with
/// a small fraction of outlying points clipped, and the height range of the colour map.
struct MapFrame {
  Vec3 min_m = Vec3::Zero(), max_m = Vec3::Zero();
  double colour_z_min_m = 0.0, colour_z_max_m = 1.0;
};
MapFrame frame_map(const std::vector<Vec3f>& p_world);

enum class MapView {
  kTop,     ///< looking down: x right, y up
  kFront,   ///< looking along +y: x right, z up
  kSide,    ///< looking along -x: y right, z up
};

/// The map from one direction, each pixel coloured by the height of its highest point (top
/// view) or by its height (side views) and shaded by point density, with a scale bar.
/// width_px is the image width; the height follows from the frame at equal scale (side views are
/// stretched vertically to at least min_height_px, which the image then says).
/// p_marked (optional): points drawn on top in kMarkedColour (magenta: the moving things left out).
Image render_map_view(const std::vector<Vec3f>& p_world, const MapFrame& frame, MapView view, int width_px = 900,
                      int min_height_px = 220, const std::vector<Vec3f>* p_marked = nullptr);

/// A thin box through the map viewed edge-on: image x along `across_axis`, image y along `up_axis`
/// (up), points within +-half_depth_m along depth_axis = across x up.
struct Section {
  std::string kind;               ///< "wall" or "ground"
  Vec3 centre_m = Vec3::Zero();   ///< world
  Vec3 across_axis = Vec3::UnitX(), up_axis = Vec3::UnitZ();
  double half_across_m = 0.5, half_up_m = 1.0, half_depth_m = 0.15;
};

/// The map's two sections, each nullopt if the map has none:
/// - wall: a dense vertical planar patch with a planar patch above it (a wall, not a car door):
///   across = the wall normal (the wall shows as a vertical band whose width is its
///   thickness), up = world z;
/// - ground: a dense horizontal planar patch (road): across = horizontal, up = world z.
struct MapSections {
  std::optional<Section> wall, ground;
};
MapSections find_sections(const std::vector<Vec3f>& p_world);

/// Robust thickness of the section's points about their median across-coordinate
/// (1.4826 * MAD, metres) and how many points the box holds.
struct SectionStats {
  double thickness_m = 0.0;
  std::size_t points = 0;
};
SectionStats section_stats(const std::vector<Vec3f>& p_world, const Section& section);

/// The section at px_per_m, points as density-shaded ink, with a metric scale bar and a label.
Image render_section(const std::vector<Vec3f>& p_world, const Section& section, double px_per_m,
                     const std::string& label);

/// A line plot as an inline <svg> element (no external references).
struct PlotSeries {
  std::string name;
  std::string colour;  ///< CSS colour
  std::vector<double> x, y;
};
struct Plot {
  std::string title, x_label, y_label;
  std::vector<PlotSeries> series;
  std::vector<std::pair<double, std::string>> x_marks;  ///< vertical dashed lines with labels (stage starts)
  int width_px = 640, height_px = 300;
};
std::string svg_line_plot(const Plot& plot);

/// Escapes &, <, >, " and ' for HTML text and attributes.
std::string html_escape(const std::string& s);

}  // namespace insalign::io
