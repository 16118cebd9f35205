#include "report/render.hpp"

#include <fmt/format.h>
#include <png.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>

#include "core/voxel_grid.hpp"
#include "files/atomic_file.hpp"

// Header-only bitmap font (static functions only): the labels burnt into the images.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#include <stb_easy_font.h>
#pragma GCC diagnostic pop

namespace insalign::io {
namespace {

constexpr Rgb kWhite{255, 255, 255};
constexpr Rgb kInk{20, 30, 70};
constexpr Rgb kText{25, 25, 25};

// 1, 2 or 5 times a power of ten, closest below x.
double nice_below(double x) {
  if (!(x > 0)) return 1.0;
  const double p = std::pow(10.0, std::floor(std::log10(x)));
  for (double m : {5.0, 2.0, 1.0})
    if (m * p <= x) return m * p;
  return p;
}

std::string metres_label(double m) {
  if (m < 0.01) return fmt::format("{:g} mm", m * 1000.0);
  if (m < 1.0) return fmt::format("{:g} cm", std::round(m * 1000.0) / 10.0);
  return fmt::format("{:g} m", m);
}

// Percentile of a copy (q in [0, 1]).
double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  const auto k = static_cast<std::size_t>(std::clamp(q, 0.0, 1.0) * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

// The plot area framed by a title band above and a band below holding a scale bar of a round
// length near target_px (and, with a colour range, the height legend), so no overlay hides data.
constexpr int kHeaderPx = 28, kFooterPx = 36;
Image framed(const Image& content, const std::string& title, double px_per_m, int target_px,
             std::optional<std::pair<double, double>> colour_range_m = std::nullopt) {
  const int W = std::max(content.width, Image::text_width(title) + 16);
  Image img(W, content.height + kHeaderPx + kFooterPx, kWhite);
  for (int y = 0; y < content.height; ++y) {
    std::copy_n(&content.rgb[static_cast<std::size_t>(y) * content.width * 3], content.width * 3,
                &img.rgb[(static_cast<std::size_t>(y + kHeaderPx) * W) * 3]);
  }
  img.fill_rect(0, kHeaderPx - 1, content.width, kHeaderPx, Rgb{200, 200, 200});
  img.fill_rect(0, kHeaderPx + content.height, content.width, kHeaderPx + content.height + 1, Rgb{200, 200, 200});
  img.text(6, 7, title, kText);
  // Scale bar, bottom left.
  const double len_m = nice_below(target_px / px_per_m);
  const int len_px = std::max(1, static_cast<int>(std::lround(len_m * px_per_m)));
  const int x0 = 8, y0 = img.height - 12;
  img.fill_rect(x0, y0, x0 + len_px, y0 + 4, kText);
  img.fill_rect(x0, y0 - 8, x0 + 2, y0 + 4, kText);
  img.fill_rect(x0 + len_px - 2, y0 - 8, x0 + len_px, y0 + 4, kText);
  img.text(x0 + len_px + 8, y0 - 9, metres_label(len_m), kText);
  if (colour_range_m) {
    // [z lo][colour bar][hi m], right-aligned.
    auto one_decimal = [](double v) { return std::round(v * 10.0) / 10.0 + 0.0; };  // no "-0.0"
    const std::string lo = fmt::format("z {:.1f}", one_decimal(colour_range_m->first));
    const std::string hi = fmt::format("{:.1f} m", one_decimal(colour_range_m->second));
    const int lw = 150, ly = img.height - 18;
    const int hi_x = W - 8 - Image::text_width(hi);
    const int lx = hi_x - 8 - lw;
    const int lo_x = lx - 8 - Image::text_width(lo);
    if (lo_x > x0 + len_px + Image::text_width(metres_label(len_m)) + 24) {
      for (int k = 0; k < lw; ++k) img.fill_rect(lx + k, ly, lx + k + 1, ly + 12, height_colour(k / double(lw - 1)));
      img.text(lo_x, ly - 1, lo, kText);
      img.text(hi_x, ly - 1, hi, kText);
    }
  }
  return img;
}

// Per-voxel point statistics for the section finders.
struct Cell {
  std::size_t n = 0;
  Vec3 sum = Vec3::Zero();
  Mat3 sum_sq = Mat3::Zero();
};
struct CellShape {
  std::size_t n = 0;
  Vec3 mean = Vec3::Zero(), normal = Vec3::UnitZ();
  double l0 = 0, l1 = 0;  // smallest and middle eigenvalues, m^2
};

constexpr double kCellM = 1.0;
using CellKey = std::uint64_t;
CellKey cell_key(int ix, int iy, int iz) { return voxel_key(VoxelCell{ix, iy, iz}); }
// z_shift_m moves the vertical cell boundaries, so a surface lying on one (flat ground at a
// round height) can be found in a second pass.
std::array<int, 3> cell_index(const Vec3& p, double z_shift_m = 0.0) {
  return {static_cast<int>(std::floor(p.x() / kCellM)), static_cast<int>(std::floor(p.y() / kCellM)),
          static_cast<int>(std::floor((p.z() + z_shift_m) / kCellM))};
}

// The shapes of the cells with at least min_points, in the order their first point came (a fixed
// order: the section finders keep the first of equal scores). Open addressing, not
// std::unordered_map: the report's map has millions of points (0.4 s per pass with node maps).
class CellShapes {
 public:
  CellShapes(const std::vector<Vec3f>& p_world, std::size_t min_points, double z_shift_m) {
    VoxelKeyMap<std::uint32_t> slot(p_world.size() / 64);
    std::vector<Cell> cells;
    for (const Vec3f& pf : p_world) {
      const Vec3 p = pf.cast<double>();
      if (!p.allFinite()) continue;
      const auto i = cell_index(p, z_shift_m);
      std::uint32_t& k = slot[cell_key(i[0], i[1], i[2])];
      if (k == 0) cells.emplace_back(), k = static_cast<std::uint32_t>(cells.size());
      Cell& c = cells[k - 1];
      ++c.n;
      c.sum += p;
      c.sum_sq += p * p.transpose();
    }
    std::vector<std::uint32_t> shape_of(cells.size(), 0);
    for (std::size_t k = 0; k < cells.size(); ++k) {
      const Cell& c = cells[k];
      if (c.n < min_points) continue;
      CellShape s;
      s.n = c.n;
      s.mean = c.sum / static_cast<double>(c.n);
      const Mat3 cov = c.sum_sq / static_cast<double>(c.n) - s.mean * s.mean.transpose();
      Eigen::SelfAdjointEigenSolver<Mat3> eig(cov);
      s.l0 = eig.eigenvalues()(0);
      s.l1 = eig.eigenvalues()(1);
      s.normal = eig.eigenvectors().col(0);
      shapes_.push_back(s);
      shape_of[k] = static_cast<std::uint32_t>(shapes_.size());
    }
    slot.for_each([&](std::uint64_t key, std::uint32_t k) {
      if (shape_of[k - 1] > 0) index_[key] = shape_of[k - 1];
    });
  }
  const std::vector<CellShape>& all() const { return shapes_; }
  /// nullptr for a cell with too few points.
  const CellShape* find(CellKey key) const {
    const std::uint32_t* k = index_.find(key);
    return k ? &shapes_[*k - 1] : nullptr;
  }

 private:
  std::vector<CellShape> shapes_;
  VoxelKeyMap<std::uint32_t> index_;
};

// Thin and extended: the patch is a surface, not a pole, a bush or a corner.
bool planar(const CellShape& s) { return s.l1 > 0.03 && s.l0 < 0.02 * s.l1; }

}  // namespace

// ---- Image ------------------------------------------------------------------------------------

Image::Image(int w, int h, Rgb fill) : width(w), height(h), rgb(static_cast<std::size_t>(w) * h * 3) {
  for (std::size_t i = 0; i < rgb.size(); i += 3) {
    rgb[i] = fill.r;
    rgb[i + 1] = fill.g;
    rgb[i + 2] = fill.b;
  }
}

void Image::set(int x, int y, Rgb c) {
  if (x < 0 || y < 0 || x >= width || y >= height) return;
  std::uint8_t* p = &rgb[(static_cast<std::size_t>(y) * width + x) * 3];
  p[0] = c.r;
  p[1] = c.g;
  p[2] = c.b;
}

void Image::blend(int x, int y, Rgb c, double alpha) {
  if (x < 0 || y < 0 || x >= width || y >= height) return;
  const double a = std::clamp(alpha, 0.0, 1.0);
  std::uint8_t* p = &rgb[(static_cast<std::size_t>(y) * width + x) * 3];
  p[0] = static_cast<std::uint8_t>(std::lround(p[0] * (1 - a) + c.r * a));
  p[1] = static_cast<std::uint8_t>(std::lround(p[1] * (1 - a) + c.g * a));
  p[2] = static_cast<std::uint8_t>(std::lround(p[2] * (1 - a) + c.b * a));
}

void Image::fill_rect(int x0, int y0, int x1, int y1, Rgb c) {
  for (int y = std::max(0, y0); y < std::min(height, y1); ++y)
    for (int x = std::max(0, x0); x < std::min(width, x1); ++x) set(x, y, c);
}

void Image::text(int x, int y, const std::string& s, Rgb c, int scale) {
  std::vector<char> buffer(s.size() * 300 + 64);  // ~270 bytes of quads per character
  std::string copy = s;
  const int quads = stb_easy_font_print(0, 0, copy.data(), nullptr, buffer.data(), static_cast<int>(buffer.size()));
  for (int q = 0; q < quads; ++q) {
    // Each quad: 4 vertices of {float x, y, z; uint8 colour[4]}; axis-aligned.
    float xs[4], ys[4];
    for (int v = 0; v < 4; ++v) {
      const char* vert = buffer.data() + (q * 4 + v) * 16;
      std::memcpy(&xs[v], vert, sizeof(float));
      std::memcpy(&ys[v], vert + 4, sizeof(float));
    }
    const float qx0 = *std::min_element(xs, xs + 4), qx1 = *std::max_element(xs, xs + 4);
    const float qy0 = *std::min_element(ys, ys + 4), qy1 = *std::max_element(ys, ys + 4);
    fill_rect(x + static_cast<int>(std::lround(qx0 * scale)), y + static_cast<int>(std::lround(qy0 * scale)),
              x + static_cast<int>(std::lround(qx1 * scale)), y + static_cast<int>(std::lround(qy1 * scale)), c);
  }
}

int Image::text_width(const std::string& s, int scale) {
  std::string copy = s;
  return stb_easy_font_width(copy.data()) * scale;
}

std::string encode_png(const Image& image) {
  if (image.width <= 0 || image.height <= 0) throw std::runtime_error("encode_png: empty image");
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!info) {
    png_destroy_write_struct(&png, nullptr);
    throw std::runtime_error("encode_png: libpng could not start");
  }
  std::string out;
  if (setjmp(png_jmpbuf(png))) {  // libpng reports its errors by longjmp
    png_destroy_write_struct(&png, &info);
    throw std::runtime_error("encode_png: libpng failed");
  }
  png_set_write_fn(
      png, &out,
      [](png_structp p, png_bytep data, png_size_t size) {
        static_cast<std::string*>(png_get_io_ptr(p))->append(reinterpret_cast<const char*>(data), size);
      },
      nullptr);
  png_set_IHDR(png, info, static_cast<png_uint_32>(image.width), static_cast<png_uint_32>(image.height), 8,
               PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  // Point maps on a plain background: unfiltered rows and zlib's fastest level give files a fifth
  // smaller than stb_image_write's, three times faster (15 report images: 0.35 -> 0.11 s).
  png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_NONE);
  png_set_compression_level(png, 1);
  png_write_info(png, info);
  for (int y = 0; y < image.height; ++y)
    png_write_row(png, const_cast<png_bytep>(image.rgb.data() + static_cast<std::size_t>(y) * image.width * 3));
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return out;
}

void write_png(const std::filesystem::path& path, const Image& image) { write_file_atomic(path, encode_png(image)); }

Rgb height_colour(double t) {
  static constexpr std::array<std::array<double, 3>, 5> stops = {{
      {40, 60, 170}, {20, 150, 210}, {50, 175, 80}, {235, 195, 35}, {215, 50, 40}}};
  if (!std::isfinite(t)) t = 0;
  const double s = std::clamp(t, 0.0, 1.0) * (stops.size() - 1);
  const std::size_t i = std::min<std::size_t>(static_cast<std::size_t>(s), stops.size() - 2);
  const double f = s - static_cast<double>(i);
  auto mix = [&](int k) { return static_cast<std::uint8_t>(std::lround(stops[i][k] * (1 - f) + stops[i + 1][k] * f)); };
  return {mix(0), mix(1), mix(2)};
}

// ---- Map views --------------------------------------------------------------------------------

MapFrame frame_map(const std::vector<Vec3f>& p_world) {
  MapFrame frame;
  if (p_world.empty()) {
    frame.max_m = Vec3::Ones();
    return frame;
  }
  const std::size_t stride = std::max<std::size_t>(1, p_world.size() / 200000);
  std::array<std::vector<double>, 3> axis;
  for (std::size_t i = 0; i < p_world.size(); i += stride) {
    if (!p_world[i].allFinite()) continue;
    for (int k = 0; k < 3; ++k) axis[k].push_back(p_world[i][k]);
  }
  for (int k = 0; k < 3; ++k) {
    frame.min_m[k] = percentile(axis[k], 0.003);
    frame.max_m[k] = percentile(axis[k], 0.997);
    const double margin = std::max(0.5, 0.03 * (frame.max_m[k] - frame.min_m[k]));
    frame.min_m[k] -= margin;
    frame.max_m[k] += margin;
  }
  frame.colour_z_min_m = percentile(axis[2], 0.02);
  frame.colour_z_max_m = std::max(frame.colour_z_min_m + 0.5, percentile(axis[2], 0.98));
  return frame;
}

Image render_map_view(const std::vector<Vec3f>& p_world, const MapFrame& frame, MapView view, int width_px,
                      int min_height_px, const std::vector<Vec3f>* p_marked) {
  const int u_axis = view == MapView::kSide ? 1 : 0;
  const int v_axis = view == MapView::kTop ? 1 : 2;
  const double u0 = frame.min_m[u_axis], du = std::max(1e-3, frame.max_m[u_axis] - frame.min_m[u_axis]);
  const double v0 = frame.min_m[v_axis], dv = std::max(1e-3, frame.max_m[v_axis] - frame.min_m[v_axis]);
  const int max_height_px = view == MapView::kTop ? 1000 : 600;
  const double su = std::min(width_px / du, max_height_px / dv);  // px per metre horizontally
  const int W = std::max(64, static_cast<int>(std::lround(du * su)));
  int H = std::max(1, static_cast<int>(std::lround(dv * su)));
  double sv = su;
  if (H < min_height_px) {  // side views of a flat town: stretch the height so it can be read
    H = min_height_px;
    sv = H / dv;
  }
  std::vector<std::uint32_t> count(static_cast<std::size_t>(W) * H, 0);
  std::vector<float> top_z(count.size(), -std::numeric_limits<float>::infinity());
  for (const Vec3f& p : p_world) {
    if (!p.allFinite()) continue;
    const int x = static_cast<int>((p[u_axis] - u0) * su);
    const int y = H - 1 - static_cast<int>((p[v_axis] - v0) * sv);
    if (x < 0 || y < 0 || x >= W || y >= H) continue;
    const std::size_t i = static_cast<std::size_t>(y) * W + x;
    ++count[i];
    top_z[i] = std::max(top_z[i], p.z());
  }
  // Density saturates at the 90th percentile of occupied pixels, so walls and ground both show.
  std::vector<double> occupied;
  for (auto c : count)
    if (c > 0) occupied.push_back(c);
  const double saturation = std::max(2.0, percentile(occupied, 0.9));
  const double zc0 = frame.colour_z_min_m, zc1 = frame.colour_z_max_m;
  Image img(W, H, kWhite);
  for (int y = 0; y < H; ++y) {
    for (int x = 0; x < W; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * W + x;
      if (count[i] == 0) continue;
      const double z = view == MapView::kTop ? top_z[i] : v0 + (H - 1 - y + 0.5) / sv;
      const double alpha = 0.3 + 0.7 * std::min(1.0, std::log1p(count[i]) / std::log1p(saturation));
      img.blend(x, y, height_colour((z - zc0) / (zc1 - zc0)), alpha);
    }
  }
  for (const Vec3f& p : p_marked ? *p_marked : std::vector<Vec3f>{}) {
    if (!p.allFinite()) continue;
    const int x = static_cast<int>((p[u_axis] - u0) * su);
    const int y = H - 1 - static_cast<int>((p[v_axis] - v0) * sv);
    if (x >= 0 && y >= 0 && x < W && y < H) img.blend(x, y, kMarkedColour, 0.8);
  }
  const char* name = view == MapView::kTop ? "top view (x right, y up)"
                     : view == MapView::kFront ? "front view (x right, z up)"
                                               : "side view (y right, z up)";
  std::string label = name;
  if (sv > su * 1.05) label += fmt::format(", height stretched x{:.1f}", sv / su);
  return framed(img, label, su, W / 5, std::make_pair(zc0, zc1));
}

// ---- Cross-sections ---------------------------------------------------------------------------

namespace {

// Thin and extended vertical patch with the same wall continuing above it (a building, not a
// car door or a low fence), the densest such pair.
std::optional<Section> wall_section(const CellShapes& shapes) {
  auto vertical_plane = [](const CellShape& s) { return planar(s) && std::abs(s.normal.z()) < 0.15; };
  const CellShape* best = nullptr;
  double best_score = 0;
  for (const CellShape& s : shapes.all()) {
    if (!vertical_plane(s)) continue;
    const auto i = cell_index(s.mean);
    const CellShape* above = shapes.find(cell_key(i[0], i[1], i[2] + 1));
    if (!above || !vertical_plane(*above) || std::abs(above->normal.dot(s.normal)) < 0.95) {
      continue;
    }
    const double score = static_cast<double>(s.n + above->n);
    if (score > best_score) {
      best_score = score;
      best = &s;
    }
  }
  if (best == nullptr) return std::nullopt;
  Section sec;
  sec.kind = "wall";
  Vec3 n(best->normal.x(), best->normal.y(), 0.0);
  sec.across_axis = n.normalized();
  sec.up_axis = Vec3::UnitZ();
  sec.centre_m = best->mean + Vec3(0, 0, 0.5);  // halfway up the two cells
  sec.half_across_m = 0.5;
  sec.half_up_m = 1.0;
  sec.half_depth_m = 0.4;  // along the wall, which stays flat: a deeper slab gathers points, not blur
  return sec;
}

// The densest horizontal patch whose ground continues 2 m to either side along x (the section's
// extent): road, not a car roof. Cells at two vertical phases, so a road on a cell boundary counts.
std::optional<Section> ground_section(const CellShapes& unshifted, const std::vector<Vec3f>& p_world) {
  auto ground = [](const CellShape& s) { return planar(s) && std::abs(s.normal.z()) > 0.97; };
  std::optional<CellShape> best;
  double best_score = 0;
  const CellShapes shifted(p_world, 40, 0.5 * kCellM);
  for (const auto& [shapes, z_shift_m] : {std::pair{&unshifted, 0.0}, std::pair{&shifted, 0.5 * kCellM}}) {
    for (const CellShape& s : shapes->all()) {
      if (!ground(s)) continue;
      const auto i = cell_index(s.mean, z_shift_m);
      double score = static_cast<double>(s.n);
      bool extended = true;
      for (int dx : {-2, -1, 1, 2}) {
        const CellShape* next = shapes->find(cell_key(i[0] + dx, i[1], i[2]));
        if (!next || !ground(*next)) {
          extended = false;
          break;
        }
        score += static_cast<double>(next->n);
      }
      if (extended && score > best_score) {
        best_score = score;
        best = s;
      }
    }
  }
  if (!best) return std::nullopt;
  Section sec;
  sec.kind = "ground";
  sec.centre_m = best->mean;
  sec.across_axis = Vec3::UnitX();
  sec.up_axis = Vec3::UnitZ();
  sec.half_across_m = 1.5;
  sec.half_up_m = 0.3;
  sec.half_depth_m = 0.3;
  return sec;
}

}  // namespace

MapSections find_sections(const std::vector<Vec3f>& p_world) {
  const CellShapes shapes(p_world, 40, 0.0);  // the wall's cells and the ground's first phase
  return {wall_section(shapes), ground_section(shapes, p_world)};
}

namespace {
// Section coordinates (across, up) of the points inside the box.
std::vector<std::pair<double, double>> section_points(const std::vector<Vec3f>& p_world, const Section& s) {
  const Vec3 depth = s.across_axis.cross(s.up_axis).normalized();
  std::vector<std::pair<double, double>> out;
  for (const Vec3f& pf : p_world) {
    const Vec3 d = pf.cast<double>() - s.centre_m;
    const double a = d.dot(s.across_axis), u = d.dot(s.up_axis), w = d.dot(depth);
    if (std::abs(a) <= s.half_across_m && std::abs(u) <= s.half_up_m && std::abs(w) <= s.half_depth_m) {
      out.emplace_back(a, u);
    }
  }
  return out;
}
}  // namespace

SectionStats section_stats(const std::vector<Vec3f>& p_world, const Section& section) {
  const auto pts = section_points(p_world, section);
  SectionStats stats;
  stats.points = pts.size();
  if (pts.empty()) return stats;
  // Thickness perpendicular to the surface: across for a wall, up for the ground.
  const bool wall = section.kind == "wall";
  std::vector<double> v;
  for (const auto& [a, u] : pts) v.push_back(wall ? a : u);
  const double median = percentile(v, 0.5);
  for (double& x : v) x = std::abs(x - median);
  stats.thickness_m = 1.4826 * percentile(v, 0.5);
  return stats;
}

Image render_section(const std::vector<Vec3f>& p_world, const Section& section, double px_per_m,
                     const std::string& label) {
  const int W = std::max(32, static_cast<int>(std::lround(2 * section.half_across_m * px_per_m)));
  const int H = std::max(32, static_cast<int>(std::lround(2 * section.half_up_m * px_per_m)));
  Image img(W, H, kWhite);
  // Faint 10 cm grid, so a thickness can be read anywhere in the image.
  for (double g = -std::floor(section.half_across_m * 10) / 10; g <= section.half_across_m; g += 0.1) {
    const int x = static_cast<int>(std::lround((g + section.half_across_m) * px_per_m));
    img.fill_rect(x, 0, x + 1, H, Rgb{228, 232, 240});
  }
  for (double g = -std::floor(section.half_up_m * 10) / 10; g <= section.half_up_m; g += 0.1) {
    const int y = static_cast<int>(std::lround((section.half_up_m - g) * px_per_m));
    img.fill_rect(0, y, W, y + 1, Rgb{228, 232, 240});
  }
  std::vector<std::uint32_t> count(static_cast<std::size_t>(W) * H, 0);
  for (const auto& [a, u] : section_points(p_world, section)) {
    const int x = static_cast<int>((a + section.half_across_m) * px_per_m);
    const int y = static_cast<int>((section.half_up_m - u) * px_per_m);
    // A 3 x 3 dot (about a centimetre at 250 px/m), centre weighted: single points stay visible.
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const int xx = x + dx, yy = y + dy;
        if (xx >= 0 && yy >= 0 && xx < W && yy < H) count[static_cast<std::size_t>(yy) * W + xx] += (dx == 0 && dy == 0) ? 3 : 1;
      }
  }
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const auto c = count[static_cast<std::size_t>(y) * W + x];
      if (c > 0) img.blend(x, y, kInk, std::min(1.0, 0.3 + 0.7 * c / 6.0));
    }
  return framed(img, label, px_per_m, std::min(W / 3, 120));
}

// ---- SVG plots --------------------------------------------------------------------------------

std::string html_escape(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string svg_line_plot(const Plot& plot) {
  double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y0 = x0, y1 = -x0;
  for (const auto& s : plot.series)
    for (std::size_t i = 0; i < std::min(s.x.size(), s.y.size()); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      x0 = std::min(x0, s.x[i]);
      x1 = std::max(x1, s.x[i]);
      y0 = std::min(y0, s.y[i]);
      y1 = std::max(y1, s.y[i]);
    }
  if (!std::isfinite(x0)) x0 = 0, x1 = 1, y0 = 0, y1 = 1;
  if (x1 - x0 < 1e-12) x1 = x0 + 1;
  if (y1 - y0 < 1e-12) y0 -= 0.5 * std::max(1e-6, std::abs(y0)), y1 += 0.5 * std::max(1e-6, std::abs(y1));
  const double pad = 0.06 * (y1 - y0);
  y0 -= pad;
  y1 += pad;
  const int W = plot.width_px, H = plot.height_px;
  const double left = 64, right = W - 130, top = 28, bottom = H - 44;  // legend on the right
  auto px = [&](double x) { return left + (x - x0) / (x1 - x0) * (right - left); };
  auto py = [&](double y) { return bottom - (y - y0) / (y1 - y0) * (bottom - top); };
  std::string svg = fmt::format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{0}\" height=\"{1}\" viewBox=\"0 0 {0} {1}\" "
      "font-family=\"sans-serif\" font-size=\"12\">\n"
      "<rect x=\"0\" y=\"0\" width=\"{0}\" height=\"{1}\" fill=\"#ffffff\"/>\n"
      "<text x=\"{2}\" y=\"18\" font-weight=\"bold\">{3}</text>\n",
      W, H, left, html_escape(plot.title));
  // Grid and ticks.
  const double ystep = nice_below((y1 - y0) / 4.0);
  for (double y = std::ceil(y0 / ystep) * ystep; y <= y1; y += ystep) {
    const double yy = py(y);
    svg += fmt::format("<line x1=\"{}\" y1=\"{:.1f}\" x2=\"{}\" y2=\"{:.1f}\" stroke=\"#e3e3e3\"/>", left, yy, right, yy);
    svg += fmt::format("<text x=\"{}\" y=\"{:.1f}\" text-anchor=\"end\">{:.4g}</text>\n", left - 6, yy + 4,
                       std::abs(y) < 1e-9 * ystep ? 0.0 : y);
  }
  const double xstep = std::max(1.0, nice_below((x1 - x0) / 8.0));
  for (double x = std::ceil(x0 / xstep) * xstep; x <= x1; x += xstep) {
    svg += fmt::format("<text x=\"{:.1f}\" y=\"{}\" text-anchor=\"middle\">{:g}</text>", px(x), bottom + 16, x);
  }
  svg += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"#888\"/>\n", left, top,
                     right - left, bottom - top);
  svg += fmt::format("<text x=\"{:.1f}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n", (left + right) / 2, H - 8,
                     html_escape(plot.x_label));
  svg += fmt::format("<text transform=\"translate(14,{:.1f}) rotate(-90)\" text-anchor=\"middle\">{}</text>\n",
                     (top + bottom) / 2, html_escape(plot.y_label));
  for (const auto& [x, label] : plot.x_marks) {
    if (x < x0 || x > x1) continue;
    svg += fmt::format(
        "<line x1=\"{0:.1f}\" y1=\"{1}\" x2=\"{0:.1f}\" y2=\"{2}\" stroke=\"#999\" stroke-dasharray=\"4 3\"/>"
        "<text x=\"{3:.1f}\" y=\"{4}\" fill=\"#666\">{5}</text>\n",
        px(x), top, bottom, px(x) + 3, top + 12, html_escape(label));
  }
  int legend_y = static_cast<int>(top) + 8;
  for (const auto& s : plot.series) {
    std::string points;
    for (std::size_t i = 0; i < std::min(s.x.size(), s.y.size()); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      points += fmt::format("{:.1f},{:.1f} ", px(s.x[i]), py(s.y[i]));
    }
    svg += fmt::format("<polyline fill=\"none\" stroke=\"{0}\" stroke-width=\"1.8\" points=\"{1}\"/>\n",
                       html_escape(s.colour), points);
    for (std::size_t i = 0; i < std::min(s.x.size(), s.y.size()); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      svg += fmt::format("<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"2.2\" fill=\"{}\"/>", px(s.x[i]), py(s.y[i]),
                         html_escape(s.colour));
    }
    svg += fmt::format(
        "\n<line x1=\"{0}\" y1=\"{1}\" x2=\"{2}\" y2=\"{1}\" stroke=\"{3}\" stroke-width=\"2.5\"/>"
        "<text x=\"{4}\" y=\"{5}\">{6}</text>\n",
        right + 10, legend_y, right + 30, html_escape(s.colour), right + 36, legend_y + 4, html_escape(s.name));
    legend_y += 18;
  }
  return svg + "</svg>\n";
}

}  // namespace insalign::io
