// SPDX-License-Identifier: AGPL-3.0-or-later
#include "pdrmesh/layers.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <queue>
#include <set>
#include <utility>

#include "pdrmesh/bvh.hpp"
#include "pdrmesh/mixed_cells.hpp"
#include "pdrmesh/predicates.hpp"
#include "pdrmesh/surface_check.hpp"

namespace pdrmesh {
namespace {

constexpr double kMaxStretch = 2.0;       // a direction's stretch 1 / (least dot product), capped
constexpr double kLeastVisibility = 1e-3;  // below this dot product a direction does not see a triangle
constexpr double kWallGap = 0.45;         // share of the distance to a wall that grows layers too
constexpr double kPlainGap = 0.8;         // share of the distance to a triangle without layers
constexpr double kGradeSlope = 0.5;       // neighbouring stacks differ by at most this times their distance
constexpr double kShrink = 0.6;           // one round of compression of a stack that failed
constexpr double kLeastShare = 0.5;       // a stack is compressed to this share of its thickness at most, then stops
constexpr int kMaxShrinkRounds = 30;

Vec3 normalized(const Vec3& v) {
  const double n = norm(v);
  return n > 0 ? (1.0 / n) * v : Vec3{0, 0, 0};
}

std::string at(const Vec3& p) { return fmt::format("({}, {}, {})", p[0], p[1], p[2]); }

/// Ray p + t d (t in (0, limit]) against triangle abc, in doubles (a distance,
/// not a decision: the exact checks below decide validity): t, or +inf.
double ray_hit(const Vec3& p, const Vec3& d, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 e1 = b - a, e2 = c - a, h = cross(d, e2);
  const double det = dot(e1, h);
  if (std::abs(det) < 1e-300) return std::numeric_limits<double>::infinity();
  const double f = 1.0 / det;
  const Vec3 s = p - a;
  const double u = f * dot(s, h);
  if (u < 0 || u > 1) return std::numeric_limits<double>::infinity();
  const Vec3 q = cross(s, e1);
  const double v = f * dot(d, q);
  if (v < 0 || u + v > 1) return std::numeric_limits<double>::infinity();
  const double t = f * dot(e2, q);
  return t > 0 ? t : std::numeric_limits<double>::infinity();
}

/// The wall: its triangles, points (local numbering) and what is around each point.
struct Wall {
  std::vector<Index> triangles;      ///< surface triangle indices that grow layers
  std::vector<Index> points;         ///< local -> surface point
  std::vector<Index> local;          ///< surface point -> local (kNoIndex off the wall)
  std::vector<std::vector<Index>> around;  ///< local point -> the wall triangles (positions in `triangles`) at it
  std::vector<std::vector<Index>> neighbours;  ///< local point -> local points sharing an edge, ascending
  std::vector<Vec3> normals;         ///< per wall triangle: unit normal into the volume
};

Result<Wall> find_wall(const SurfaceMesh& s, const LayerOptions& o) {
  const std::set<int> ids(o.walls.begin(), o.walls.end());
  std::vector<char> is_wall(s.triangles.size(), 0);
  for (std::size_t t = 0; t < s.triangles.size(); ++t)
    is_wall[t] = ids.empty() || ids.count(s.surface_ids[t]) > 0 ? 1 : 0;
  // Whole components only: an edge between a wall triangle and another is refused.
  std::map<std::pair<Index, Index>, std::vector<Index>> edges;
  for (Index t = 0; t < s.triangles.size(); ++t)
    for (int i = 0; i < 3; ++i) {
      const Index a = s.triangles[t][i], b = s.triangles[t][(i + 1) % 3];
      edges[{std::min(a, b), std::max(a, b)}].push_back(t);
    }
  for (const auto& [e, ts] : edges) {
    bool any = false, all = true;
    Index with = ts[0], without = ts[0];
    for (Index t : ts) {
      any = any || is_wall[t];
      all = all && is_wall[t];
      (is_wall[t] ? with : without) = t;
    }
    if (any && !all) {
      return invalid_input(fmt::format(
          "layers: surface id {} (with layers) meets surface id {} (without) at edge ({}, {}) at {}; layers grow "
          "only on whole closed components for now: name both in --layers-on or neither",
          s.surface_ids[with], s.surface_ids[without], e.first, e.second, at(s.points[e.first])));
    }
  }
  Wall w;
  w.local.assign(s.points.size(), kNoIndex);
  for (Index t = 0; t < s.triangles.size(); ++t) {
    if (!is_wall[t]) continue;
    w.triangles.push_back(t);
    for (Index v : s.triangles[t])
      if (w.local[v] == kNoIndex) w.local[v] = 0;  // marked; numbered below in point order
  }
  if (w.triangles.empty()) return invalid_input("layers: no surface triangle has an id named by --layers-on");
  for (Index v = 0; v < s.points.size(); ++v)
    if (w.local[v] != kNoIndex) {
      w.local[v] = static_cast<Index>(w.points.size());
      w.points.push_back(v);
    }
  w.around.resize(w.points.size());
  std::vector<std::set<Index>> nb(w.points.size());
  for (Index k = 0; k < w.triangles.size(); ++k) {
    const Tri& t = s.triangles[w.triangles[k]];
    for (int i = 0; i < 3; ++i) {
      w.around[w.local[t[i]]].push_back(k);
      nb[w.local[t[i]]].insert(w.local[t[(i + 1) % 3]]);
      nb[w.local[t[(i + 1) % 3]]].insert(w.local[t[i]]);
    }
    // The surface is outward: into the volume is against the right-hand normal.
    const Vec3 &a = s.points[t[0]], &b = s.points[t[1]], &c = s.points[t[2]];
    w.normals.push_back(normalized(cross(c - a, b - a)));
  }
  for (auto& n : nb) w.neighbours.emplace_back(n.begin(), n.end());
  return w;
}

double least_dot(const Wall& w, Index v, const Vec3& d) {
  double m = std::numeric_limits<double>::infinity();
  for (Index k : w.around[v]) m = std::min(m, dot(d, w.normals[k]));
  return m;
}

/// Marching directions (unit) and the least dot product of each with its triangles.
Result<std::pair<std::vector<Vec3>, std::vector<double>>> directions(const SurfaceMesh& s, const Wall& w) {
  const std::size_t nw = w.points.size();
  std::vector<Vec3> dir(nw, Vec3{0, 0, 0});
  for (Index k = 0; k < w.triangles.size(); ++k) {
    const Tri& t = s.triangles[w.triangles[k]];
    for (int i = 0; i < 3; ++i) {
      const Vec3& p = s.points[t[i]];
      const Vec3 u = normalized(s.points[t[(i + 1) % 3]] - p), v = normalized(s.points[t[(i + 2) % 3]] - p);
      const double angle = std::acos(std::clamp(dot(u, v), -1.0, 1.0));
      dir[w.local[t[i]]] = dir[w.local[t[i]]] + angle * w.normals[k];
    }
  }
  std::vector<double> least(nw);
  for (Index v = 0; v < nw; ++v) {
    Vec3 d = normalized(dir[v]);
    double m = least_dot(w, v, d);
    // Raise the least dot product: step towards the normal seen worst while
    // that helps (a small ascent on the minimum; corners and edges need it).
    double step = 0.5;
    for (int tries = 0; tries < 200 && step > 1e-4 && m < 0.5; ++tries) {
      Index worst = w.around[v][0];
      for (Index k : w.around[v])
        if (dot(d, w.normals[k]) < dot(d, w.normals[worst])) worst = k;
      const Vec3 tried = normalized(d + step * (w.normals[worst] - d));
      const double mt = least_dot(w, v, tried);
      if (mt > m) {
        d = tried;
        m = mt;
      } else {
        step *= 0.5;
      }
    }
    if (!(m > kLeastVisibility))
      return invalid_input(fmt::format("layers: at wall point {} {} no direction sees every triangle around it "
                                       "(the wall folds too sharply there for prism layers)",
                                       w.points[v], at(s.points[w.points[v]])));
    dir[v] = d;
    least[v] = m;
  }
  // Smoothing: each direction blended with its neighbours' mean, kept where
  // its least dot product stays above 0.9 of what it was (Jacobi passes).
  for (int pass = 0; pass < 3; ++pass) {
    std::vector<Vec3> next = dir;
    for (Index v = 0; v < nw; ++v) {
      Vec3 mean{0, 0, 0};
      for (Index u : w.neighbours[v]) mean = mean + dir[u];
      const Vec3 tried = normalized(dir[v] + normalized(mean));
      const double mt = least_dot(w, v, tried);
      if (mt >= 0.9 * least[v] && mt > kLeastVisibility) {
        next[v] = tried;
        least[v] = mt;
      }
    }
    dir = std::move(next);
  }
  return std::make_pair(std::move(dir), std::move(least));
}

/// Grades stack thicknesses: t[v] <= t[u] + slope |p_u - p_v| over wall edges
/// (Dijkstra from the thinnest stacks, ties by index).
void grade(const SurfaceMesh& s, const Wall& w, std::vector<double>& t) {
  using Item = std::pair<double, Index>;
  std::priority_queue<Item, std::vector<Item>, std::greater<>> queue;
  for (Index v = 0; v < t.size(); ++v) queue.emplace(t[v], v);
  while (!queue.empty()) {
    const auto [tv, v] = queue.top();
    queue.pop();
    if (tv > t[v]) continue;
    for (Index u : w.neighbours[v]) {
      const double limit = tv + kGradeSlope * norm(s.points[w.points[u]] - s.points[w.points[v]]);
      if (limit < t[u]) {
        t[u] = limit;
        queue.emplace(limit, u);
      }
    }
  }
}

/// The points of the stacks: how many layers each keeps, the share of the
/// full heights it is scaled by, and the index of each of its points.
class Stacks {
 public:
  Stacks(std::size_t stacks, int layers)
      : n_(layers), count_(stacks, layers), scale_(stacks, 1.0), index_(stacks * (static_cast<std::size_t>(layers) + 1)) {}

  /// From each stack's thickness t[v] (the offsets z of the full stack, z[n]
  /// its thickness): a stack of at least kLeastShare of it keeps every layer,
  /// its heights scaled by t[v] / z[n]; a thinner one keeps the heights of
  /// that least share and stops at the last layer within t[v], so that its
  /// first layers keep their height (the wall distance asked for).
  void shape(const std::vector<double>& t, const std::vector<double>& z) {
    const double full = z[static_cast<std::size_t>(n_)];
    for (std::size_t v = 0; v < t.size(); ++v) {
      const double share = t[v] / full;
      if (share >= kLeastShare) {
        scale_[v] = share;
        count_[v] = n_;
        continue;
      }
      scale_[v] = kLeastShare;
      int k = 0;
      while (k < n_ && kLeastShare * z[static_cast<std::size_t>(k) + 1] <= t[v]) ++k;
      count_[v] = k;
    }
  }

  /// Numbers the points: stack v's foot is feet[v]; from `first` on, layer by
  /// layer, the points of the stacks that reach the layer, in stack order. A
  /// stack's point at a layer above its last is its last point.
  void number(std::size_t first, const std::vector<Index>& feet) {
    const std::size_t stride = static_cast<std::size_t>(n_) + 1;
    std::size_t next = first;
    for (std::size_t v = 0; v < count_.size(); ++v) index_[v * stride] = feet[v];
    for (int k = 1; k <= n_; ++k)
      for (std::size_t v = 0; v < count_.size(); ++v)
        index_[v * stride + k] = k <= count_[v] ? static_cast<Index>(next++) : index_[v * stride + k - 1];
    points_ = next;
  }

  Index point(Index v, int k) const { return index_[v * (static_cast<std::size_t>(n_) + 1) + k]; }
  int count(Index v) const { return count_[v]; }
  double scale(Index v) const { return scale_[v]; }
  std::size_t point_count() const { return points_; }

 private:
  int n_;
  std::vector<int> count_;
  std::vector<double> scale_;
  std::vector<Index> index_;
  std::size_t points_ = 0;
};

enum class CellKind { kNone, kPrism, kPyramid, kTet };

/// The cell of one layer over one wall triangle, `p` in prism order (bottom
/// 0, 1, 2, vertex i + 3 above vertex i; mixed_cells.hpp), where a stack that
/// stopped below the layer repeats its point (p[i + 3] == p[i]): three rising
/// edges give the prism, two a pyramid on the side quad between them with the
/// stopped point as apex, one a tet, none no cell. Such collapsed prisms share
/// their faces with their neighbours' (a side quad with one stopped corner is
/// a triangle on both sides), so the layers stay conforming where they stop.
CellKind close_stack(const Prism& p, std::vector<Prism>& prisms, std::vector<Pyramid>& pyramids,
                     std::vector<Tet>& tets) {
  int rising = 0;
  for (int i = 0; i < 3; ++i) rising += p[i + 3] != p[i] ? 1 : 0;
  if (rising == 3) {
    prisms.push_back(p);
    return CellKind::kPrism;
  }
  // Seen from corner i (the rotation that makes it corner 0, which keeps the
  // orientation): q = p[i], p[i+1], p[i+2], and the points above them.
  const auto rotated = [&](int i) {
    const int j = (i + 1) % 3, k = (i + 2) % 3;
    return std::array<Index, 6>{p[i], p[j], p[k], p[i + 3], p[j + 3], p[k + 3]};
  };
  for (int i = 0; i < 3; ++i) {
    const bool up = p[i + 3] != p[i];
    const std::array<Index, 6> q = rotated(i);
    if (rising == 2 && !up) {
      // The prism's cut (q0, q1, q2, q5), (q0, q1, q5, q4) with q3 = q0: the
      // base quad q1, q4, q5, q2 (counterclockwise seen from the apex q0).
      pyramids.push_back({q[1], q[4], q[5], q[2], q[0]});
      return CellKind::kPyramid;
    }
    if (rising == 1 && up) {
      // The cut's tet (q0, q4, q5, q3) with q4 = q1, q5 = q2.
      tets.push_back({q[0], q[1], q[2], q[3]});
      return CellKind::kTet;
    }
  }
  return CellKind::kNone;
}

}  // namespace

Status validate(const LayerOptions& o) {
  if (o.layers < 1 || o.layers > 1000)
    return invalid_input(fmt::format("--layers must be a whole number from 1 to 1000, got {}", o.layers));
  if (!(std::isfinite(o.first_height) && o.first_height > 0))
    return invalid_input(fmt::format("--first-height must be a positive length, got {}", o.first_height));
  if (!(std::isfinite(o.growth_ratio) && o.growth_ratio >= 1 && o.growth_ratio <= 10))
    return invalid_input(fmt::format("--growth-ratio must be from 1 to 10, got {}", o.growth_ratio));
  if (o.max_thickness && !(std::isfinite(*o.max_thickness) && *o.max_thickness > 0))
    return invalid_input(fmt::format("--layers-max-thickness must be a positive length, got {}", *o.max_thickness));
  return {};
}

Result<double> first_height_for_yplus(double yplus, double reynolds, double length) {
  const auto positive = [](double x) { return std::isfinite(x) && x > 0; };
  if (!positive(yplus)) return invalid_input(fmt::format("--first-height yplus:Y: Y must be positive, got {}", yplus));
  if (!positive(reynolds)) return invalid_input(fmt::format("--reynolds must be positive, got {}", reynolds));
  if (!positive(length)) return invalid_input(fmt::format("the reference length must be positive, got {}", length));
  const double cf = 0.026 * std::pow(reynolds, -1.0 / 7.0);
  return yplus * length / (reynolds * std::sqrt(cf / 2));
}

Result<LayerMesh> grow_layers(const SurfaceMesh& s, const LayerOptions& o) {
  PDR_TRY(validate(o));
  PDR_ASSIGN_OR_RETURN(const Wall w, find_wall(s, o));
  PDR_ASSIGN_OR_RETURN(const auto marching, directions(s, w));
  const std::vector<Vec3>& dir = marching.first;
  const std::vector<double>& least = marching.second;
  const std::size_t nw = w.points.size(), ns = s.points.size();
  const int n = o.layers;

  // Offsets of the layers from the wall, as shares of the full stack.
  std::vector<double> z(static_cast<std::size_t>(n) + 1, 0.0);
  for (int k = 1; k <= n; ++k) z[k] = z[k - 1] + o.first_height * std::pow(o.growth_ratio, k - 1);
  const double full = z[n];
  std::vector<double> stretch(nw);
  for (Index v = 0; v < nw; ++v) stretch[v] = std::min(kMaxStretch, 1.0 / least[v]);

  // Thickness t[v] of each stack along the normal (before the stretch).
  std::vector<double> t(nw, o.max_thickness ? std::min(full, *o.max_thickness) : full);
  {
    std::vector<char> wall_triangle(s.triangles.size(), 0);
    for (Index k : w.triangles) wall_triangle[k] = 1;
    std::vector<Box> boxes;
    std::vector<Index> ids;
    for (Index k = 0; k < s.triangles.size(); ++k) {
      const Tri& tri = s.triangles[k];
      boxes.push_back(detail::box_of(s.points[tri[0]], s.points[tri[1]], s.points[tri[2]]));
      ids.push_back(k);
    }
    const detail::BoxTree tree(boxes, ids);
    for (Index v = 0; v < nw; ++v) {
      const Vec3& p = s.points[w.points[v]];
      const double reach = stretch[v] * t[v];
      const Vec3 end = p + reach * dir[v];
      double limit = t[v];
      tree.query(detail::box_of(p, end), [&](std::size_t pos) {
        const Index k = tree.id(pos);
        const Tri& tri = s.triangles[k];
        if (tri[0] == w.points[v] || tri[1] == w.points[v] || tri[2] == w.points[v]) return;
        const double hit = ray_hit(p, dir[v], s.points[tri[0]], s.points[tri[1]], s.points[tri[2]]);
        if (hit <= reach) limit = std::min(limit, (wall_triangle[k] ? kWallGap : kPlainGap) * hit / stretch[v]);
      });
      t[v] = limit;
    }
  }
  grade(s, w, t);

  LayerMesh out;
  out.wall_triangles = w.triangles.size();
  out.wall_points = nw;
  // The fill boundary: the tops (their corners, the last points of the
  // stacks, set by place()), then the triangles without layers.
  std::vector<char> on_wall(s.triangles.size(), 0);
  for (Index k : w.triangles) on_wall[k] = 1;
  std::vector<Tri> fill_tris;
  std::vector<int> fill_ids;
  for (Index k : w.triangles) {
    fill_tris.push_back(s.triangles[k]);  // the top's corners: set by place()
    fill_ids.push_back(s.surface_ids[k]);
  }
  for (Index k = 0; k < s.triangles.size(); ++k)
    if (!on_wall[k]) {
      fill_tris.push_back(s.triangles[k]);
      fill_ids.push_back(s.surface_ids[k]);
    }

  Stacks stacks(nw, n);
  // Per cell, the wall triangle (position in w.triangles) it stands on.
  std::vector<Index> prism_on, pyramid_on, tet_on;
  const auto place = [&] {
    stacks.shape(t, z);
    stacks.number(ns, w.points);
    out.points.assign(stacks.point_count(), Vec3{0, 0, 0});
    std::copy(s.points.begin(), s.points.end(), out.points.begin());
    for (Index v = 0; v < nw; ++v)
      for (int k = 1; k <= stacks.count(v); ++k)
        out.points[stacks.point(v, k)] =
            s.points[w.points[v]] + (stacks.scale(v) * z[k] * stretch[v]) * dir[v];
    out.prisms.clear();
    out.pyramids.clear();
    out.tets.clear();
    prism_on.clear();
    pyramid_on.clear();
    tet_on.clear();
    // The wall triangle (a, b, c) is outward, so its bottom in prism order is
    // (a, c, b), turning counterclockwise seen from the top.
    for (int k = 1; k <= n; ++k)
      for (Index tri = 0; tri < w.triangles.size(); ++tri) {
        const Tri& f = s.triangles[w.triangles[tri]];
        const Index a = w.local[f[0]], b = w.local[f[1]], c = w.local[f[2]];
        const Prism cell{stacks.point(a, k - 1), stacks.point(c, k - 1), stacks.point(b, k - 1),
                         stacks.point(a, k),     stacks.point(c, k),     stacks.point(b, k)};
        switch (close_stack(cell, out.prisms, out.pyramids, out.tets)) {
          case CellKind::kPrism: prism_on.push_back(tri); break;
          case CellKind::kPyramid: pyramid_on.push_back(tri); break;
          case CellKind::kTet: tet_on.push_back(tri); break;
          case CellKind::kNone: break;
        }
      }
    for (Index tri = 0; tri < w.triangles.size(); ++tri) {
      const Tri& f = s.triangles[w.triangles[tri]];
      fill_tris[tri] = {stacks.point(w.local[f[0]], n), stacks.point(w.local[f[1]], n),
                        stacks.point(w.local[f[2]], n)};
    }
  };

  CheckOptions check;
  check.max_defects_per_kind = std::numeric_limits<std::size_t>::max();
  for (int round = 0;; ++round) {
    place();
    std::vector<char> bad(nw, 0);
    bool any = false;
    const auto mark = [&](Index tri) {
      for (Index v : s.triangles[w.triangles[tri]]) bad[w.local[v]] = 1;
      any = true;
    };
    for (std::size_t c = 0; c < out.prisms.size(); ++c)
      if (!prism_positive(out.points, out.prisms[c])) mark(prism_on[c]);
    for (std::size_t c = 0; c < out.pyramids.size(); ++c)
      if (!pyramid_positive(out.points, out.pyramids[c])) mark(pyramid_on[c]);
    for (std::size_t c = 0; c < out.tets.size(); ++c) {
      const Tet& k = out.tets[c];
      if (exact::orient3d(out.points[k[0]], out.points[k[1]], out.points[k[2]], out.points[k[3]]) <= 0)
        mark(tet_on[c]);
    }
    std::string why = "a layer cell would not be positive";
    if (!any) {
      // The fill boundary must be a valid surface: tops that cross each other
      // or the surface make the stacks under them thinner.
      SurfaceMesh fill;
      fill.points = out.points;
      fill.triangles = fill_tris;
      fill.surface_ids = fill_ids;
      const SurfaceReport report = check_surface(fill, check);
      for (const Defect& d : report.defects) {
        if (d.kind == DefectKind::kIndexOutOfRange || d.kind == DefectKind::kOpenEdge) continue;
        for (Index tri : d.triangles)
          if (tri < w.triangles.size()) mark(tri);
      }
      why = "the top of the layers would cross itself or the surface";
    }
    if (!any) {
      out.shrink_rounds = round;
      break;
    }
    if (round == kMaxShrinkRounds) {
      const Index v = static_cast<Index>(std::find(bad.begin(), bad.end(), 1) - bad.begin());
      return invalid_input(fmt::format("layers: near wall point {} {} {} even with the stack {} times thinner; "
                                       "try fewer layers or a smaller --first-height",
                                       w.points[v], at(s.points[w.points[v]]), why, std::pow(1 / kShrink, round)));
    }
    for (Index v = 0; v < nw; ++v)
      if (bad[v]) t[v] *= kShrink;
    grade(s, w, t);
  }

  // The fill surface on the used points, numbered afresh in point order.
  std::vector<Index> to_fill(out.points.size(), kNoIndex);
  for (const Tri& f : fill_tris)
    for (Index v : f) to_fill[v] = 0;
  for (Index v = 0; v < out.points.size(); ++v)
    if (to_fill[v] != kNoIndex) {
      to_fill[v] = static_cast<Index>(out.fill_points.size());
      out.fill_points.push_back(v);
      out.fill.points.push_back(out.points[v]);
    }
  for (const Tri& f : fill_tris) out.fill.triangles.push_back({to_fill[f[0]], to_fill[f[1]], to_fill[f[2]]});
  out.fill.surface_ids = fill_ids;
  out.fill.surface_names = s.surface_names;
  out.fill.name = s.name + " (inside the layers)";
  for (Index k = 0; k < w.triangles.size(); ++k) out.top_triangles.push_back(k);

  out.thickness_min = std::numeric_limits<double>::infinity();
  out.thickness_max = 0;
  const double wanted = o.max_thickness ? std::min(full, *o.max_thickness) : full;
  for (Index v = 0; v < nw; ++v) {
    const int kept = stacks.count(v);
    const double along = kept == n ? t[v] * stretch[v] : stacks.scale(v) * z[kept] * stretch[v];
    out.thickness_min = std::min(out.thickness_min, along);
    out.thickness_max = std::max(out.thickness_max, along);
    if (t[v] < wanted) ++out.compressed_points;
    if (kept < n) ++out.stopped_points;
  }
  // The layers reached per wall triangle: a stack only ever gets thinner, so
  // one that kept `wanted` exactly was never compressed.
  const double smooth_cos = std::cos(LayerMesh::kSmoothAngle * std::acos(-1.0) / 180);
  for (Index k = 0; k < w.triangles.size(); ++k) {
    const Tri& f = s.triangles[w.triangles[k]];
    bool full_stack = true, smooth = true;
    for (Index v : f) {
      full_stack = full_stack && t[w.local[v]] >= wanted;
      for (Index other : w.around[w.local[v]]) smooth = smooth && dot(w.normals[other], w.normals[k]) >= smooth_cos;
    }
    out.full_faces += full_stack ? 1 : 0;
    out.smooth_faces += smooth ? 1 : 0;
    out.smooth_full_faces += smooth && full_stack ? 1 : 0;
  }
  return out;
}

}  // namespace pdrmesh
