// SPDX-License-Identifier: AGPL-3.0-or-later
#include "mesh_picture.hpp"

#include <fmt/format.h>
#include <png.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <numbers>
#include <vector>

#include "pdrmesh/quality.hpp"

namespace pdrmesh::picture {
namespace {

constexpr double kRegularTet = 70.5288;  // the regular tet's dihedral angle: the colour bar's top

/// A filled polygon in picture coordinates (pixels, y down), with its outline colour.
struct Shape {
  std::vector<std::array<double, 2>> points;
  Rgb fill, stroke;
  double stroke_width;
};

struct Label {
  double x, y;
  std::string text;
  int size;           ///< font size in pixels
  bool right = false; ///< anchored at its right end
};

struct Scene {
  std::vector<Shape> shapes;  ///< in drawing order
  std::vector<Label> labels;
};

Rgb mix(Rgb a, Rgb b, double t) {
  auto c = [t](unsigned char x, unsigned char y) {
    return static_cast<unsigned char>(std::lround(x + (y - x) * std::clamp(t, 0.0, 1.0)));
  };
  return {c(a.r, b.r), c(a.g, b.g), c(a.b, b.b)};
}
Rgb scaled(Rgb a, double s) {
  auto c = [s](unsigned char x) { return static_cast<unsigned char>(std::clamp(std::lround(x * s), 0L, 255L)); };
  return {c(a.r), c(a.g), c(a.b)};
}

/// Camera frame: right, up, and toward the viewer.
struct Frame {
  Vec3 right, up, toward;
};

Vec3 unit(const Vec3& v) { return (1.0 / norm(v)) * v; }

/// Looking at the cut plane (normal `axis`) from its + side, turned 30
/// degrees sideways and 20 degrees up so that the body behind shows.
Frame camera(int axis) {
  Vec3 n{0, 0, 0}, r{0, 0, 0}, u{0, 0, 0};
  n[static_cast<std::size_t>(axis)] = 1;
  if (axis == 2) r = {1, 0, 0}, u = {0, 1, 0};
  if (axis == 0) r = {0, 1, 0}, u = {0, 0, 1};
  if (axis == 1) r = {-1, 0, 0}, u = {0, 0, 1};
  const double yaw = 30 * std::numbers::pi / 180, pitch = 20 * std::numbers::pi / 180;
  const Vec3 toward = unit(std::cos(pitch) * (std::cos(yaw) * n + std::sin(yaw) * r) + std::sin(pitch) * u);
  const Vec3 right = unit(cross(u, toward));
  return {right, cross(toward, right), toward};
}

/// Polygon vertices (3D, convex) sorted around their centroid in the plane of `frame`-free coordinates a, b.
void sort_around(std::vector<Vec3>& poly, int axis) {
  const std::size_t a = static_cast<std::size_t>((axis + 1) % 3), b = static_cast<std::size_t>((axis + 2) % 3);
  double ca = 0, cb = 0;
  for (const Vec3& p : poly) ca += p[a], cb += p[b];
  ca /= static_cast<double>(poly.size());
  cb /= static_cast<double>(poly.size());
  std::sort(poly.begin(), poly.end(), [&](const Vec3& p, const Vec3& q) {
    return std::atan2(p[b] - cb, p[a] - ca) < std::atan2(q[b] - cb, q[a] - ca);
  });
}

/// The part of polygon `poly` where coordinate `axis` is at most `at` (Sutherland-Hodgman, one plane).
std::vector<Vec3> clip_below(const std::vector<Vec3>& poly, int axis, double at) {
  std::vector<Vec3> out;
  const std::size_t k = static_cast<std::size_t>(axis);
  for (std::size_t i = 0; i < poly.size(); ++i) {
    const Vec3& p = poly[i];
    const Vec3& q = poly[(i + 1) % poly.size()];
    const bool p_in = p[k] <= at, q_in = q[k] <= at;
    if (p_in) out.push_back(p);
    if (p_in != q_in) out.push_back(p + ((at - p[k]) / (q[k] - p[k])) * (q - p));
  }
  return out;
}

Result<Scene> build_scene(const VolumeMesh& mesh, const Options& o, Picture& pic) {
  if (mesh.tets.empty()) return invalid_input("the mesh has no tets to draw");
  const std::size_t k = static_cast<std::size_t>(o.axis);
  const char axis_name = static_cast<char>('x' + o.axis);
  Box box;
  for (const Tet& t : mesh.tets)
    for (Index v : t) box.add(mesh.points[v]);
  const double at = o.at.value_or(0.5 * (box.lo[k] + box.hi[k]));
  if (!(at >= box.lo[k] && at <= box.hi[k]))
    return invalid_input(fmt::format("the plane {} = {} misses the mesh: its {} runs from {} to {}", axis_name, at,
                                     axis_name, box.lo[k], box.hi[k]));
  pic.at = at;
  const Frame f = camera(o.axis);

  struct Poly3 {
    std::vector<Vec3> points;
    Rgb fill, stroke;
    double stroke_width;
    double depth;
  };
  // Behind the plane: boundary triangles facing the viewer, clipped to the plane, Lambert-shaded.
  std::vector<Poly3> back;
  const Vec3 light = unit(f.toward + 0.6 * f.up - 0.4 * f.right);
  const Rgb body{178, 192, 210};
  for (const Tri& t : mesh.boundary) {
    const Vec3 &a = mesh.points[t[0]], &b = mesh.points[t[1]], &c = mesh.points[t[2]];
    if (a[k] > at && b[k] > at && c[k] > at) continue;
    const Vec3 nrm = cross(b - a, c - a);
    const double len = norm(nrm);
    if (!(len > 0) || dot(nrm, f.toward) <= 0) continue;
    std::vector<Vec3> poly = clip_below({a, b, c}, o.axis, at);
    if (poly.size() < 3) continue;
    const double shade = 0.35 + 0.65 * std::max(0.0, dot((1.0 / len) * nrm, light));
    double depth = 0;
    for (const Vec3& p : poly) depth += dot(p, f.toward);
    back.push_back({std::move(poly), scaled(body, shade), scaled(body, shade * 0.82), 0.35,
                    depth / 3});
  }
  // Farthest first; ties by position in the mesh (stable), so the order is deterministic.
  std::stable_sort(back.begin(), back.end(), [](const Poly3& p, const Poly3& q) { return p.depth < q.depth; });
  pic.boundary_drawn = back.size();

  // The cut: each cut tet's cross-section, coloured by its smallest dihedral angle.
  std::vector<Poly3> cut;
  for (const Tet& t : mesh.tets) {
    std::array<const Vec3*, 4> p{};
    int above = 0;
    for (int i = 0; i < 4; ++i) {
      p[static_cast<std::size_t>(i)] = &mesh.points[t[static_cast<std::size_t>(i)]];
      above += (*p[static_cast<std::size_t>(i)])[k] >= at ? 1 : 0;
    }
    if (above == 0 || above == 4) continue;
    std::vector<Vec3> poly;
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j) {
        const Vec3 &a = *p[static_cast<std::size_t>(i)], &b = *p[static_cast<std::size_t>(j)];
        if ((a[k] >= at) != (b[k] >= at)) {
          Vec3 q = a + ((at - a[k]) / (b[k] - a[k])) * (b - a);
          q[k] = at;
          poly.push_back(q);
        }
      }
    sort_around(poly, o.axis);
    const Rgb c = angle_colour(dihedral_range(*p[0], *p[1], *p[2], *p[3]).min);
    cut.push_back({std::move(poly), c, scaled(c, 0.55), 0.5, 0});
  }
  pic.cut_tets = cut.size();

  // Fit everything drawn into the plot area (uniform scale, centred).
  const double W = o.width, H = o.height;
  const double left = 16, top = 52, right_edge = W - 110, bottom = H - 16;
  double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
  for (const auto* list : {&back, &cut})
    for (const Poly3& s : *list)
      for (const Vec3& p : s.points) {
        const double x = dot(p, f.right), y = dot(p, f.up);
        x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
      }
  const double scale = std::min((right_edge - left) / std::max(x1 - x0, 1e-300), (bottom - top) / std::max(y1 - y0, 1e-300));
  const double ox = left + 0.5 * (right_edge - left - scale * (x1 - x0)), oy = top + 0.5 * (bottom - top - scale * (y1 - y0));
  Scene scene;
  for (const auto* list : {&back, &cut})
    for (const Poly3& s : *list) {
      Shape shape{{}, s.fill, s.stroke, s.stroke_width};
      for (const Vec3& p : s.points) shape.points.push_back({ox + scale * (dot(p, f.right) - x0), oy + scale * (y1 - dot(p, f.up))});
      scene.shapes.push_back(std::move(shape));
    }

  // The colour bar: 0 at the bottom, the regular tet's angle at the top.
  const double bx = W - 70, bw = 22, btop = top + 20, bbottom = H - 40;
  constexpr int kSteps = 64;
  for (int i = 0; i < kSteps; ++i) {
    const double y_hi = bbottom - (bbottom - btop) * (i + 1) / kSteps, y_lo = bbottom - (bbottom - btop) * i / kSteps;
    const Rgb c = angle_colour(kRegularTet * (i + 0.5) / kSteps);
    scene.shapes.push_back({{{bx, y_hi}, {bx + bw, y_hi}, {bx + bw, y_lo + 0.5}, {bx, y_lo + 0.5}}, c, c, 0});
  }
  for (int deg = 0; deg <= 70; deg += 10) {
    const double y = bbottom - (bbottom - btop) * deg / kRegularTet;
    scene.shapes.push_back({{{bx - 5, y - 0.6}, {bx, y - 0.6}, {bx, y + 0.6}, {bx - 5, y + 0.6}}, {40, 40, 40}, {40, 40, 40}, 0});
    scene.labels.push_back({bx - 8, y + 4, std::to_string(deg), 12, true});
  }
  scene.labels.push_back({W - 100, btop - 10, "min dihedral", 12});
  scene.labels.push_back({bx + bw + 4, bbottom + 4, "deg", 11});
  scene.labels.push_back({left, 22, o.title, 15});
  scene.labels.push_back({left, 42,
                          fmt::format("cut {} = {:.4g}: {} tets, coloured by their smallest dihedral angle",
                                      axis_name, at, cut.size()),
                          12});
  return scene;
}

// ---------------------------------------------------------------- SVG

std::string hex(Rgb c) { return fmt::format("#{:02x}{:02x}{:02x}", c.r, c.g, c.b); }

std::string xml_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '<') out += "&lt;";
    else if (c == '>') out += "&gt;";
    else if (c == '&') out += "&amp;";
    else if (c == '"') out += "&quot;";
    else out += c;
  }
  return out;
}

std::string render_svg(const Scene& scene, const Options& o) {
  fmt::memory_buffer b;
  auto it = std::back_inserter(b);
  fmt::format_to(it,
                 "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{0}\" height=\"{1}\" viewBox=\"0 0 {0} {1}\" "
                 "font-family=\"sans-serif\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n",
                 o.width, o.height);
  for (const Shape& s : scene.shapes) {
    fmt::format_to(it, "<polygon points=\"");
    for (const auto& p : s.points) fmt::format_to(it, "{:.2f},{:.2f} ", p[0], p[1]);
    if (s.stroke_width > 0)
      fmt::format_to(it, "\" fill=\"{}\" stroke=\"{}\" stroke-width=\"{}\" stroke-linejoin=\"round\"/>\n", hex(s.fill),
                     hex(s.stroke), s.stroke_width);
    else
      fmt::format_to(it, "\" fill=\"{}\"/>\n", hex(s.fill));
  }
  for (const Label& l : scene.labels)
    fmt::format_to(it, "<text x=\"{:.1f}\" y=\"{:.1f}\" font-size=\"{}\"{}>{}</text>\n", l.x, l.y, l.size,
                   l.right ? " text-anchor=\"end\"" : "", xml_escape(l.text));
  fmt::format_to(it, "</svg>\n");
  return fmt::to_string(b);
}

// ---------------------------------------------------------------- PNG

/// 5x7 glyphs (rows top to bottom, 5 bits each) of the characters the labels use.
const std::array<unsigned char, 7>* glyph(char c) {
  static const std::array<std::pair<char, std::array<unsigned char, 7>>, 44> kFont{{
      {'0', {0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E}}, {'1', {0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E}},
      {'2', {0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F}}, {'3', {0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E}},
      {'4', {0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02}}, {'5', {0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E}},
      {'6', {0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E}}, {'7', {0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08}},
      {'8', {0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E}}, {'9', {0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C}},
      {'.', {0, 0, 0, 0, 0, 0x0C, 0x0C}},                {'-', {0, 0, 0, 0x1F, 0, 0, 0}},
      {'+', {0, 0x04, 0x04, 0x1F, 0x04, 0x04, 0}},       {'=', {0, 0, 0x1F, 0, 0x1F, 0, 0}},
      {':', {0, 0x0C, 0x0C, 0, 0x0C, 0x0C, 0}},          {',', {0, 0, 0, 0, 0x0C, 0x04, 0x08}},
      {'(', {0x02, 0x04, 0x08, 0x08, 0x08, 0x04, 0x02}}, {')', {0x08, 0x04, 0x02, 0x02, 0x02, 0x04, 0x08}},
      {'a', {0, 0, 0x0E, 0x01, 0x0F, 0x11, 0x0F}},       {'b', {0x10, 0x10, 0x16, 0x19, 0x11, 0x11, 0x1E}},
      {'c', {0, 0, 0x0E, 0x10, 0x10, 0x11, 0x0E}},       {'d', {0x01, 0x01, 0x0D, 0x13, 0x11, 0x11, 0x0F}},
      {'e', {0, 0, 0x0E, 0x11, 0x1F, 0x10, 0x0E}},       {'f', {0x06, 0x09, 0x08, 0x1C, 0x08, 0x08, 0x08}},
      {'g', {0, 0x0F, 0x11, 0x11, 0x0F, 0x01, 0x0E}},    {'h', {0x10, 0x10, 0x16, 0x19, 0x11, 0x11, 0x11}},
      {'i', {0x04, 0, 0x0C, 0x04, 0x04, 0x04, 0x0E}},    {'l', {0x0C, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E}},
      {'m', {0, 0, 0x1A, 0x15, 0x15, 0x11, 0x11}},       {'n', {0, 0, 0x16, 0x19, 0x11, 0x11, 0x11}},
      {'o', {0, 0, 0x0E, 0x11, 0x11, 0x11, 0x0E}},       {'p', {0, 0, 0x1E, 0x11, 0x1E, 0x10, 0x10}},
      {'r', {0, 0, 0x16, 0x19, 0x10, 0x10, 0x10}},       {'s', {0, 0, 0x0E, 0x10, 0x0E, 0x01, 0x1E}},
      {'t', {0x08, 0x08, 0x1C, 0x08, 0x08, 0x09, 0x06}}, {'u', {0, 0, 0x11, 0x11, 0x11, 0x13, 0x0D}},
      {'v', {0, 0, 0x11, 0x11, 0x11, 0x0A, 0x04}},       {'w', {0, 0, 0x11, 0x11, 0x15, 0x15, 0x0A}},
      {'x', {0, 0, 0x11, 0x0A, 0x04, 0x0A, 0x11}},       {'y', {0, 0, 0x11, 0x11, 0x0F, 0x01, 0x0E}},
      {'z', {0, 0, 0x1F, 0x02, 0x04, 0x08, 0x1F}},       {'k', {0x10, 0x10, 0x12, 0x14, 0x18, 0x14, 0x12}},
      {'/', {0x01, 0x01, 0x02, 0x04, 0x08, 0x10, 0x10}}, {'_', {0, 0, 0, 0, 0, 0, 0x1F}},
  }};
  for (const auto& [ch, rows] : kFont)
    if (ch == c) return &rows;
  return nullptr;
}

/// An RGB image drawn at kSuper times the size and averaged down.
class Raster {
 public:
  static constexpr int kSuper = 3;
  Raster(int width, int height) : w_(width * kSuper), h_(height * kSuper), px_(3 * static_cast<std::size_t>(w_) * h_, 255) {}

  /// A polygon (convex or not: even-odd rule) in picture coordinates.
  void fill(const std::vector<std::array<double, 2>>& pts, Rgb c) {
    double y0 = 1e300, y1 = -1e300;
    for (const auto& p : pts) y0 = std::min(y0, p[1]), y1 = std::max(y1, p[1]);
    const int r0 = std::max(0, static_cast<int>(std::floor(y0 * kSuper))), r1 = std::min(h_ - 1, static_cast<int>(std::ceil(y1 * kSuper)));
    std::vector<double> xs;
    for (int row = r0; row <= r1; ++row) {
      const double y = (row + 0.5) / kSuper;
      xs.clear();
      for (std::size_t i = 0; i < pts.size(); ++i) {
        const auto& a = pts[i];
        const auto& b = pts[(i + 1) % pts.size()];
        if ((a[1] <= y) != (b[1] <= y)) xs.push_back(a[0] + (y - a[1]) / (b[1] - a[1]) * (b[0] - a[0]));
      }
      std::sort(xs.begin(), xs.end());
      for (std::size_t i = 0; i + 1 < xs.size(); i += 2) {
        const int c0 = std::max(0, static_cast<int>(std::ceil(xs[i] * kSuper - 0.5)));
        const int c1 = std::min(w_ - 1, static_cast<int>(std::ceil(xs[i + 1] * kSuper - 0.5)) - 1);
        for (int col = c0; col <= c1; ++col) set(col, row, c);
      }
    }
  }

  /// A line `width` pixels wide (at least one sample wide).
  void line(std::array<double, 2> a, std::array<double, 2> b, double width, Rgb c) {
    const double len = std::hypot(b[0] - a[0], b[1] - a[1]);
    const int steps = std::max(1, static_cast<int>(std::ceil(len * kSuper * 2)));
    const int half = std::max(0, static_cast<int>(std::lround(width * kSuper / 2)) - 1);
    for (int s = 0; s <= steps; ++s) {
      const double t = static_cast<double>(s) / steps;
      const int x = static_cast<int>(std::floor((a[0] + t * (b[0] - a[0])) * kSuper));
      const int y = static_cast<int>(std::floor((a[1] + t * (b[1] - a[1])) * kSuper));
      for (int dy = -half; dy <= half; ++dy)
        for (int dx = -half; dx <= half; ++dx) set(x + dx, y + dy, c);
    }
  }

  /// Text in the 5x7 font, `size` pixels high (the baseline at y).
  void text(double x, double y, const std::string& s, int size, bool right) {
    const double cell = size / 9.0;  // one font pixel
    if (right) x -= static_cast<double>(s.size()) * 6 * cell;
    for (char ch : s) {
      if (const auto* g = glyph(static_cast<char>(std::tolower(static_cast<unsigned char>(ch))))) {
        for (int row = 0; row < 7; ++row)
          for (int col = 0; col < 5; ++col)
            if (((*g)[static_cast<std::size_t>(row)] >> (4 - col)) & 1) {
              const double px = x + col * cell, py = y - (7 - row) * cell;
              fill({{px, py}, {px + cell, py}, {px + cell, py + cell}, {px, py + cell}}, {30, 30, 30});
            }
      }
      x += 6 * cell;
    }
  }

  /// The picture at its final size, each pixel the mean of its kSuper^2 samples.
  std::vector<unsigned char> reduce() const {
    const int w = w_ / kSuper, h = h_ / kSuper;
    std::vector<unsigned char> out(3 * static_cast<std::size_t>(w) * h);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int ch = 0; ch < 3; ++ch) {
          int sum = 0;
          for (int dy = 0; dy < kSuper; ++dy)
            for (int dx = 0; dx < kSuper; ++dx)
              sum += px_[3 * (static_cast<std::size_t>(y * kSuper + dy) * w_ + x * kSuper + dx) + ch];
          out[3 * (static_cast<std::size_t>(y) * w + x) + ch] = static_cast<unsigned char>((sum + kSuper * kSuper / 2) / (kSuper * kSuper));
        }
    return out;
  }

 private:
  void set(int x, int y, Rgb c) {
    if (x < 0 || y < 0 || x >= w_ || y >= h_) return;
    unsigned char* p = &px_[3 * (static_cast<std::size_t>(y) * w_ + x)];
    p[0] = c.r, p[1] = c.g, p[2] = c.b;
  }
  int w_, h_;
  std::vector<unsigned char> px_;
};

Result<std::string> render_png(const Scene& scene, const Options& o) {
  Raster r(o.width, o.height);
  for (const Shape& s : scene.shapes) {
    r.fill(s.points, s.fill);
    if (s.stroke_width > 0)
      for (std::size_t i = 0; i < s.points.size(); ++i) r.line(s.points[i], s.points[(i + 1) % s.points.size()], s.stroke_width, s.stroke);
  }
  for (const Label& l : scene.labels) r.text(l.x, l.y, l.text, l.size, l.right);
  const std::vector<unsigned char> rgb = r.reduce();
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  image.width = static_cast<png_uint_32>(o.width);
  image.height = static_cast<png_uint_32>(o.height);
  image.format = PNG_FORMAT_RGB;
  png_alloc_size_t size = 0;
  if (!png_image_write_to_memory(&image, nullptr, &size, 0, rgb.data(), 0, nullptr))
    return internal_error(fmt::format("libpng: {}", image.message));
  std::string out(size, '\0');
  if (!png_image_write_to_memory(&image, out.data(), &size, 0, rgb.data(), 0, nullptr))
    return internal_error(fmt::format("libpng: {}", image.message));
  out.resize(size);
  return out;
}

}  // namespace

Rgb angle_colour(double degrees) {
  struct Stop {
    double at;
    Rgb c;
  };
  static constexpr std::array<Stop, 7> kStops{{{0, {110, 0, 30}},
                                               {10, {215, 25, 28}},
                                               {20, {245, 130, 50}},
                                               {30, {250, 215, 95}},
                                               {42, {170, 215, 130}},
                                               {55, {60, 160, 110}},
                                               {kRegularTet, {40, 90, 170}}}};
  if (!(degrees > 0)) return kStops.front().c;
  for (std::size_t i = 1; i < kStops.size(); ++i)
    if (degrees <= kStops[i].at)
      return mix(kStops[i - 1].c, kStops[i].c, (degrees - kStops[i - 1].at) / (kStops[i].at - kStops[i - 1].at));
  return kStops.back().c;
}

Result<Picture> draw(const VolumeMesh& mesh, const Options& options, Format format) {
  Picture pic;
  PDR_ASSIGN_OR_RETURN(const Scene scene, build_scene(mesh, options, pic));
  if (format == Format::kSvg) {
    pic.bytes = render_svg(scene, options);
  } else {
    PDR_ASSIGN_OR_RETURN(pic.bytes, render_png(scene, options));
  }
  return pic;
}

}  // namespace pdrmesh::picture
