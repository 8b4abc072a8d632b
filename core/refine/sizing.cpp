// SPDX-License-Identifier: AGPL-3.0-or-later
// The point distribution function h(x): construction, queries, serialisation.
// See sizing.hpp for the definition and the determinism guarantee.
#include "pdrmesh/sizing.hpp"

#include "pdrmesh/topology.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <functional>
#include <limits>
#include <utility>

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/parallel_sort.h>

#include "pdrmesh/atomic_extremum.hpp"
#include "pdrmesh/byte_codec.hpp"
#include "pdrmesh/closest_point.hpp"
#include "pdrmesh/predicates.hpp"

namespace pdrmesh {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr std::uint32_t kPointLeaf = 8;  // boundary points per tree leaf at most
constexpr std::uint32_t kTetLeaf = 8;    // tets per tree leaf at most
constexpr int kStack = 128;              // > 2 x tree depth (median splits: <= 32 for 2^32 items)
constexpr char kMagic[8] = {'P', 'D', 'R', 'S', 'I', 'Z', 'E', '1'};
constexpr std::uint32_t kVersion = 1;
constexpr std::uint32_t kModeField = 0;
constexpr std::uint32_t kModeUniform = 1;
constexpr std::uint32_t kModeGraded = 2;

std::string point_str(const Vec3& p) { return fmt::format("({}, {}, {})", p[0], p[1], p[2]); }
double dist2(const Vec3& a, const Vec3& b) { return dot(a - b, a - b); }

// ---------------------------------------------------------------- box trees

/// b grows to hold c (std::min/max: inlined, unlike Box::add's fmin/fmax; all
/// coordinates here are finite).
void box_add(Box& b, const Box& c) {
  for (int k = 0; k < 3; ++k) {
    b.lo[k] = std::min(b.lo[k], c.lo[k]);
    b.hi[k] = std::max(b.hi[k], c.hi[k]);
  }
}

/// Builds a bounding-box tree over n items: median splits of the items' keys
/// across the widest axis, ordered by (key, index), so the tree is a function
/// of the data alone. Fills `nodes` (root first) and `order` (tree order -> item).
template <class BoxOf, class KeyOf>
void build_tree(std::size_t n, std::uint32_t leaf, BoxOf&& box_of, KeyOf&& key_of,
                std::vector<sizing_detail::TreeNode>& nodes, std::vector<Index>& order) {
  order.resize(n);
  for (Index i = 0; i < n; ++i) order[i] = i;
  nodes.clear();
  nodes.reserve(2 * (n / leaf + 1));
  auto build = [&](auto&& self, std::uint32_t begin, std::uint32_t end) -> Index {
    const Index id = static_cast<Index>(nodes.size());
    nodes.emplace_back();
    sizing_detail::TreeNode node;
    node.begin = begin;
    node.end = end;
    Box keys;
    for (std::uint32_t i = begin; i < end; ++i) {
      box_add(node.box, box_of(order[i]));
      box_add(keys, Box{key_of(order[i]), key_of(order[i])});
    }
    if (end - begin > leaf) {
      const Vec3 ext = keys.hi - keys.lo;
      const int axis = ext[0] >= ext[1] && ext[0] >= ext[2] ? 0 : (ext[1] >= ext[2] ? 1 : 2);
      const std::uint32_t mid = begin + (end - begin) / 2;
      std::nth_element(order.begin() + begin, order.begin() + mid, order.begin() + end, [&](Index a, Index b) {
        const double ka = key_of(a)[axis], kb = key_of(b)[axis];
        return ka < kb || (ka == kb && a < b);
      });
      node.left = self(self, begin, mid);
      node.right = self(self, mid, end);
    }
    nodes[id] = node;
    return id;
  };
  if (n > 0) build(build, 0, static_cast<std::uint32_t>(n));
}

// ---------------------------------------------------------------- geometry

/// 6 x signed volume of (x, p, q, r), differences taken from x, so exactly 0
/// when x equals p, q or r.
double vol_from(const Vec3& x, const Vec3& p, const Vec3& q, const Vec3& r) {
  return dot(cross(p - x, q - x), r - x);
}

bool box_contains(const Box& b, const Vec3& x) {
  return x[0] >= b.lo[0] && x[0] <= b.hi[0] && x[1] >= b.lo[1] && x[1] <= b.hi[1] && x[2] >= b.lo[2] &&
         x[2] <= b.hi[2];
}

double box_dist2(const Box& b, const Vec3& x) {
  double d2 = 0;
  for (int a = 0; a < 3; ++a) {
    const double d = x[a] < b.lo[a] ? b.lo[a] - x[a] : (x[a] > b.hi[a] ? x[a] - b.hi[a] : 0.0);
    d2 += d * d;
  }
  return d2;
}

using codec::Reader;
using codec::Writer;

Status decode_error(std::string_view what) { return invalid_input(fmt::format("sizing field: {}", what)); }

Status validate_tets(const std::vector<Vec3>& points, const std::vector<Tet>& tets, std::string_view what) {
  if (tets.empty()) return invalid_input(fmt::format("{}: no tetrahedra", what));
  auto indices_ok = [&](const Tet& v) {
    bool ok = true;
    for (int i = 0; i < 4; ++i) {
      ok = ok && v[i] < points.size();
      for (int j = 0; j < i; ++j) ok = ok && v[i] != v[j];
    }
    return ok;
  };
  auto bad = [&](const Tet& v) {
    return !indices_ok(v) || exact::orient3d(points[v[0]], points[v[1]], points[v[2]], points[v[3]]) <= 0;
  };
  // The lowest bad tet, found in parallel (each chunk keeps its lowest).
  std::atomic<std::size_t> first{tets.size()};
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, tets.size(), 4096), [&](const auto& r) {
    for (std::size_t t = r.begin(); t < r.end() && t < first.load(); ++t) {
      if (!bad(tets[t])) continue;
      detail::atomic_lower(first, t);
      break;
    }
  });
  if (const std::size_t t = first.load(); t < tets.size()) {
    const Tet& v = tets[t];
    if (!indices_ok(v)) {
      return invalid_input(fmt::format("{}: tet {} (points {}, {}, {}, {}) has an index out of range (of {} points) "
                                       "or a repeated point",
                                       what, t, v[0], v[1], v[2], v[3], points.size()));
    }
    return invalid_input(fmt::format("{}: tet {} (points {}, {}, {}, {}) is not positively oriented", what, t,
                                     v[0], v[1], v[2], v[3]));
  }
  return Status::ok_status();
}


/// Boundary spacing (step 1 of the header): per surface point the sum and count
/// of the lengths of its distinct edges, and the points used by a triangle.
struct BoundarySpacing {
  std::vector<double> sum;
  std::vector<std::uint32_t> count;
  std::vector<Index> used;
  /// The used points' coordinates and mean edge lengths, in `used` order.
  std::vector<Vec3> points(const SurfaceMesh& surface) const {
    std::vector<Vec3> out;
    out.reserve(used.size());
    for (Index p : used) out.push_back(surface.points[p]);
    return out;
  }
  std::vector<double> means() const {
    std::vector<double> out;
    out.reserve(used.size());
    for (Index p : used) out.push_back(sum[p] / count[p]);
    return out;
  }
};

Result<BoundarySpacing> boundary_spacing(const SurfaceMesh& surface, const std::string& name) {
  if (surface.triangles.empty()) return invalid_input(fmt::format("{}: no triangles to derive a spacing from", name));
  std::vector<std::pair<Index, Index>> edges;
  edges.reserve(3 * surface.triangles.size());
  for (std::size_t t = 0; t < surface.triangles.size(); ++t) {
    const Tri& v = surface.triangles[t];
    const std::size_t n = surface.points.size();
    if (v[0] >= n || v[1] >= n || v[2] >= n || v[0] == v[1] || v[1] == v[2] || v[0] == v[2]) {
      return invalid_input(fmt::format("{}: triangle {} (points {}, {}, {}) has an index out of range (of {} points) "
                                       "or a repeated point",
                                       name, t, v[0], v[1], v[2], n));
    }
    for (int i = 0; i < 3; ++i) edges.emplace_back(std::minmax(v[i], v[(i + 1) % 3]));
  }
  tbb::parallel_sort(edges.begin(), edges.end());  // a total order: the same result as std::sort
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  BoundarySpacing out;
  out.sum.assign(surface.points.size(), 0.0);
  out.count.assign(surface.points.size(), 0);
  for (const auto& [a, b] : edges) {
    const double len = norm(surface.points[a] - surface.points[b]);
    out.sum[a] += len;
    out.sum[b] += len;
    ++out.count[a];
    ++out.count[b];
  }
  for (Index p = 0; p < surface.points.size(); ++p) {
    if (out.count[p] == 0) continue;
    if (!is_finite(surface.points[p])) {
      return invalid_input(fmt::format("{}: point {} has a non-finite coordinate {}", name, p,
                                       point_str(surface.points[p])));
    }
    out.used.push_back(p);
  }
  return out;
}

}  // namespace

// ---------------------------------------------------------------- options

Status validate(const SizingOptions& o) {
  auto positive = [](const std::optional<double>& v, std::string_view name) -> Status {
    if (v && !(std::isfinite(*v) && *v > 0)) {
      return invalid_input(fmt::format("sizing option --{} must be a finite length > 0, got {}", name, *v));
    }
    return Status::ok_status();
  };
  PDR_TRY(positive(o.size, "size"));
  PDR_TRY(positive(o.hmin, "hmin"));
  PDR_TRY(positive(o.hmax, "hmax"));
  if (!(std::isfinite(o.growth) && o.growth > 1)) {
    return invalid_input(fmt::format("sizing option --growth must be finite and > 1, got {}", o.growth));
  }
  if (o.hmin && o.hmax && *o.hmin > *o.hmax) {
    return invalid_input(fmt::format("sizing options --hmin {} and --hmax {}: hmin must not exceed hmax", *o.hmin,
                                     *o.hmax));
  }
  return Status::ok_status();
}

// ---------------------------------------------------------------- build

Result<SizingField> SizingField::build(const SurfaceMesh& surface, const VolumeMesh& background,
                                       const SizingOptions& options) {
  PDR_TRY(validate(options));
  SizingField f;
  f.point_count_ = background.points.size();
  f.growth_ = options.growth;
  f.lo_ = options.hmin.value_or(0.0);
  f.hi_ = options.hmax.value_or(kInf);
  if (options.size) {
    PDR_ASSIGN_OR_RETURN(SizingField sized, from_surface(surface, options));
    sized.point_count_ = f.point_count_;
    return sized;
  }
  const std::string name = surface.name.empty() ? std::string("surface") : surface.name;
  PDR_ASSIGN_OR_RETURN(const BoundarySpacing spacing, boundary_spacing(surface, name));
  const std::vector<double>& sum = spacing.sum;
  const std::vector<std::uint32_t>& count = spacing.count;
  const std::vector<Index>& used = spacing.used;

  // Background checks, then match boundary points to background points by coordinates.
  for (std::size_t p = 0; p < background.points.size(); ++p) {
    if (!is_finite(background.points[p])) {
      return invalid_input(fmt::format("background mesh: point {} has a non-finite coordinate {}", p,
                                       point_str(background.points[p])));
    }
  }
  PDR_TRY(validate_tets(background.points, background.tets, "background mesh"));
  std::vector<Index> by_xyz(background.points.size());
  for (Index i = 0; i < by_xyz.size(); ++i) by_xyz[i] = i;
  auto xyz_less = [&](Index a, Index b) {
    return std::pair(background.points[a], a) < std::pair(background.points[b], b);
  };
  tbb::parallel_sort(by_xyz.begin(), by_xyz.end(), xyz_less);  // a total order (index last)
  std::vector<Index> match(background.points.size(), kNoIndex);  // background -> surface point
  for (Index p : used) {
    const Vec3& x = surface.points[p];
    auto it = std::lower_bound(by_xyz.begin(), by_xyz.end(), x,
                               [&](Index b, const Vec3& v) { return background.points[b] < v; });
    if (it == by_xyz.end() || background.points[*it] != x) {
      return invalid_input(fmt::format("{}: point {} at {} is not a point of the background mesh", name, p,
                                       point_str(x)));
    }
    if (match[*it] != kNoIndex) {
      return invalid_input(fmt::format("{}: points {} and {} coincide at {}", name, match[*it], p, point_str(x)));
    }
    match[*it] = p;
  }

  f.points_ = background.points;
  f.tets_ = background.tets;
  f.values_.assign(background.points.size(), 0.0);
  for (Index b = 0; b < match.size(); ++b) {
    if (match[b] == kNoIndex) continue;
    f.boundary_.push_back(b);
    f.values_[b] = sum[match[b]] / count[match[b]];
  }
  PDR_TRY(f.finish());

  // Interior background points: Shepard (1/d^2) mean over the nearest boundary points.
  tbb::parallel_for(std::size_t{0}, match.size(), [&](std::size_t b) {
    if (match[b] == kNoIndex) f.values_[b] = f.idw(f.points_[b]);
  });
  return f;
}

Result<SizingField> SizingField::from_surface(const SurfaceMesh& surface, const SizingOptions& options) {
  PDR_TRY(validate(options));
  if (!options.size) return invalid_input("a sizing field from the surface alone needs a size");
  const std::string name = surface.name.empty() ? std::string("surface") : surface.name;
  PDR_ASSIGN_OR_RETURN(const BoundarySpacing spacing, boundary_spacing(surface, name));
  return sized_field(options, spacing.points(surface), spacing.means());
}

std::vector<double> SizingField::at_surface_points(const SurfaceMesh& surface) const {
  std::vector<double> out(surface.points.size(), kNaN);
  for (const Tri& t : surface.triangles)
    for (const Index p : t)
      if (std::isnan(out[p])) out[p] = at(surface.points[p]);
  return out;
}

Result<SizingField> SizingField::sized_field(const SizingOptions& options, std::vector<Vec3> points,
                                             std::vector<double> spacing) {
  SizingField f;
  f.lo_ = options.hmin.value_or(0.0);
  f.hi_ = options.hmax.value_or(kInf);
  f.uniform_ = true;
  f.uniform_value_ = std::clamp(*options.size, f.lo_, f.hi_);
  PDR_TRY(f.grade(std::move(points), std::move(spacing)));
  return f;
}

Result<std::vector<double>> SizingField::surface_values(const SurfaceMesh& surface, const SizingOptions& options) {
  PDR_TRY(validate(options));
  std::vector<double> out(surface.points.size(), kNaN);
  SizingField f;
  f.growth_ = options.growth;
  f.lo_ = options.hmin.value_or(0.0);
  f.hi_ = options.hmax.value_or(kInf);
  const std::string name = surface.name.empty() ? std::string("surface") : surface.name;
  PDR_ASSIGN_OR_RETURN(const BoundarySpacing spacing, boundary_spacing(surface, name));
  if (options.size) {
    PDR_ASSIGN_OR_RETURN(const SizingField sized, sized_field(options, spacing.points(surface), spacing.means()));
    return sized.at_surface_points(surface);
  }
  // The field of the boundary points alone: no tets, so only at_point's
  // value and growth limit apply (what at() gives at a background vertex).
  f.point_count_ = spacing.used.size();
  f.points_.reserve(spacing.used.size());
  f.values_.reserve(spacing.used.size());
  for (Index p : spacing.used) {
    f.boundary_.push_back(static_cast<Index>(f.points_.size()));
    f.points_.push_back(surface.points[p]);
    f.values_.push_back(spacing.sum[p] / spacing.count[p]);
  }
  PDR_TRY(f.finish());
  tbb::parallel_for(std::size_t{0}, spacing.used.size(), [&](std::size_t i) {
    out[spacing.used[i]] = f.at_point(static_cast<Index>(i));
  });
  return out;
}

Status SizingField::grade(std::vector<Vec3> points, std::vector<double> spacing) {
  // Nothing to raise: no spacing above the size, or the size already at hmax.
  if (uniform_value_ >= hi_ || std::none_of(spacing.begin(), spacing.end(), [&](double v) { return v > uniform_value_; }))
    return Status::ok_status();
  graded_ = true;
  points_ = std::move(points);
  values_ = std::move(spacing);
  boundary_.resize(points_.size());
  for (Index i = 0; i < boundary_.size(); ++i) boundary_[i] = i;
  return finish();
}

Status SizingField::finish() {
  if (uniform_ && !graded_) return Status::ok_status();
  // Boundary points, with per-node least spacing for the growth bound.
  const std::size_t nb = boundary_.size();
  build_tree(
      nb, kPointLeaf, [&](Index i) { return Box{points_[boundary_[i]], points_[boundary_[i]]}; },
      [&](Index i) -> const Vec3& { return points_[boundary_[i]]; }, kd_, kd_item_);
  kd_xyz_.resize(nb);
  kd_h_.resize(nb);
  for (std::size_t i = 0; i < nb; ++i) {
    kd_xyz_[i] = points_[boundary_[kd_item_[i]]];
    kd_h_[i] = values_[boundary_[kd_item_[i]]];
  }
  kd_h_min_.resize(kd_.size());
  kd_h_max_.resize(kd_.size());
  for (std::size_t n = 0; n < kd_.size(); ++n) {
    kd_h_min_[n] = *std::min_element(kd_h_.begin() + kd_[n].begin, kd_h_.begin() + kd_[n].end);
    kd_h_max_[n] = *std::max_element(kd_h_.begin() + kd_[n].begin, kd_h_.begin() + kd_[n].end);
  }
  if (graded_) return Status::ok_status();  // no background tets

  // Background tets, split by bounding-box centre.
  std::vector<Box> boxes(tets_.size());
  std::vector<Vec3> centres(tets_.size());
  for (std::size_t t = 0; t < tets_.size(); ++t) {
    for (Index v : tets_[t]) box_add(boxes[t], Box{points_[v], points_[v]});
    centres[t] = 0.5 * (boxes[t].lo + boxes[t].hi);
  }
  build_tree(
      tets_.size(), kTetLeaf, [&](Index t) { return boxes[t]; }, [&](Index t) -> const Vec3& { return centres[t]; },
      bvh_, bvh_item_);
  bvh_box_.resize(tets_.size());
  for (std::size_t i = 0; i < tets_.size(); ++i) bvh_box_[i] = boxes[bvh_item_[i]];

  // Face neighbours, for the walks of at(x, hint): faces sorted by their
  // vertices, equal neighbours paired (a face of three or more tets pairs none).
  std::vector<std::pair<Tri, Index>> faces(4 * tets_.size());
  tbb::parallel_for(std::size_t{0}, tets_.size(), [&](std::size_t t) {
    for (int f = 0; f < 4; ++f)
      faces[4 * t + f] = {topo::sorted_key(topo::face_of(tets_[t], f)), static_cast<Index>(4 * t + f)};
  });
  tbb::parallel_sort(faces.begin(), faces.end());
  neighbours_.assign(tets_.size(), {kNoIndex, kNoIndex, kNoIndex, kNoIndex});
  for (std::size_t i = 0; i < faces.size();) {
    std::size_t j = i + 1;
    while (j < faces.size() && faces[j].first == faces[i].first) ++j;
    if (j == i + 2) {
      const Index a = faces[i].second, b = faces[i + 1].second;
      neighbours_[a / 4][a % 4] = b / 4;
      neighbours_[b / 4][b % 4] = a / 4;
    }
    i = j;
  }
  return Status::ok_status();
}

// ---------------------------------------------------------------- queries

namespace {

/// Branch and bound over the boundary-point tree: the best value(i) of all
/// points by the strict order `better` (less: the least; greater: the
/// largest), from `best`, visiting a node only when its bound is better than
/// the best so far, the nearer child first (ties: the left one). `point`, when
/// given, gets the slot that set a new best.
template <class Value, class Bound, class Better>
double best_point(const std::vector<sizing_detail::TreeNode>& kd, double best, Value&& value, Bound&& bound,
                  Better&& better, std::uint32_t* point) {
  Index stack[kStack];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Index n = stack[--top];
    const sizing_detail::TreeNode& node = kd[n];
    if (!better(bound(n), best)) continue;
    if (node.left == kNoIndex) {
      for (std::uint32_t i = node.begin; i < node.end; ++i) {
        if (const double v = value(i); better(v, best)) {
          best = v;
          if (point != nullptr) *point = i;
        }
      }
      continue;
    }
    const double bl = bound(node.left), br = bound(node.right);
    const bool right_first = better(br, bl);
    const Index near = right_first ? node.right : node.left, far = right_first ? node.left : node.right;
    if (better(right_first ? bl : br, best)) stack[top++] = far;
    if (better(right_first ? br : bl, best)) stack[top++] = near;
  }
  return best;
}

}  // namespace

double SizingField::growth_limit(const Vec3& x, double best, std::uint32_t* point) const {
  // A node's bound h_min + (G - 1) |x - box| is computed with the same
  // operations, in the same order, as a point's value h + (G - 1) |x - p|, and
  // every operation rounds monotonically, so the bound never exceeds the
  // computed value of any point below the node: pruning at bound >= best drops
  // nothing that could lower the minimum, and the result equals a brute-force
  // loop bit for bit, whatever value `best` starts from (so a caller's `point`,
  // the slot that set the last query's minimum, may start it).
  const double gm1 = growth_ - 1;
  const auto value = [&](std::uint32_t i) { return kd_h_[i] + gm1 * std::sqrt(dist2(x, kd_xyz_[i])); };
  if (point != nullptr && *point < kd_h_.size()) best = std::min(best, value(*point));
  const auto bound = [&](Index n) { return kd_h_min_[n] + gm1 * std::sqrt(box_dist2(kd_[n].box, x)); };
  return best_point(kd_, best, value, bound, std::less<>(), point);
}

double SizingField::graded(const Vec3& x, std::uint32_t* point) const {
  // The growth limit's search, maximising s(p) - |x - p|: a node's bound
  // h_max - |x - box| is computed as a point's value is, so it is never below
  // the computed value of a point under it, and the result is a brute-force
  // loop's maximum bit for bit.
  const auto value = [&](std::uint32_t i) { return kd_h_[i] - std::sqrt(dist2(x, kd_xyz_[i])); };
  double best = uniform_value_;
  if (point != nullptr && *point < kd_h_.size()) best = std::max(best, value(*point));
  const auto bound = [&](Index n) { return kd_h_max_[n] - std::sqrt(box_dist2(kd_[n].box, x)); };
  return std::min(best_point(kd_, best, value, bound, std::greater<>(), point), hi_);  // uniform_value_ is clamped
}

double SizingField::idw(const Vec3& x) const {
  // The kIdwNeighbours nearest boundary points, ties to the lower index.
  std::array<std::pair<double, Index>, kIdwNeighbours> near;  // (d2, boundary slot), ascending
  std::size_t count = 0;
  const std::size_t k = std::min(kIdwNeighbours, boundary_.size());
  auto worst = [&] { return count < k ? kInf : near[count - 1].first; };
  Index stack[kStack];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const sizing_detail::TreeNode& node = kd_[stack[--top]];
    if (box_dist2(node.box, x) > worst()) continue;
    if (node.left == kNoIndex) {
      for (std::uint32_t i = node.begin; i < node.end; ++i) {
        const std::pair<double, Index> cand{dist2(x, kd_xyz_[i]), kd_item_[i]};
        if (count == k && !(cand < near[count - 1])) continue;
        if (count < k) ++count;
        auto pos = std::upper_bound(near.begin(), near.begin() + long(count) - 1, cand);
        std::move_backward(pos, near.begin() + long(count) - 1, near.begin() + long(count));
        *pos = cand;
      }
      continue;
    }
    const double dl = box_dist2(kd_[node.left].box, x), dr = box_dist2(kd_[node.right].box, x);
    stack[top++] = dl <= dr ? node.right : node.left;
    stack[top++] = dl <= dr ? node.left : node.right;
  }
  double num = 0, den = 0;
  for (std::size_t i = 0; i < count; ++i) {
    const auto [d2, slot] = near[i];
    const double h = values_[boundary_[slot]];
    if (d2 == 0) return h;
    num += h / d2;
    den += 1 / d2;
  }
  return num / den;
}

double SizingField::combine(double interpolated, const Vec3& x, std::uint32_t* point) const {
  return std::max(lo_, growth_limit(x, std::min(interpolated, hi_), point));
}

double SizingField::combine(double interpolated, const Vec3& x, SizingHint& hint) const {
  const double best = std::min(interpolated, hi_);
  // g(x) >= g(at) - (G - 1) |x - at|. With a relative slack far above the
  // rounding of the computed values (a few ulps), a bound at or above `best`
  // means no boundary point's computed value falls below it: the search
  // would return `best`, so it is skipped. Otherwise the search runs from
  // +inf (the hint point's value then starts it), so that it finds g itself
  // for the queries after this one.
  constexpr double kSlack = 1e-12;
  if (!std::isnan(hint.limit)) {
    const double reach = (growth_ - 1) * std::sqrt(dist2(x, hint.at));
    if (hint.limit * (1 - kSlack) - reach * (1 + kSlack) >= best * (1 + kSlack)) return std::max(lo_, best);
  }
  hint.limit = growth_limit(x, kInf, &hint.point);
  hint.at = x;
  return std::max(lo_, std::min(best, hint.limit));
}

double SizingField::interpolate_in(Index tet, const Vec3& x) const {
  const Tet& t = tets_[tet];
  const Vec3 &a = points_[t[0]], &b = points_[t[1]], &c = points_[t[2]], &d = points_[t[3]];
  // w_i: volume of the tet with x in place of vertex i (x first, positively ordered).
  double w[4] = {vol_from(x, b, c, d), vol_from(x, a, d, c), vol_from(x, a, b, d), vol_from(x, a, c, b)};
  double total = 0;
  for (double& v : w) {
    v = std::max(v, 0.0);
    total += v;
  }
  double h = 0;
  if (total > 0) {
    for (int i = 0; i < 4; ++i) h += (w[i] / total) * values_[t[i]];
  } else {
    for (int i = 0; i < 4; ++i) h += 0.25 * values_[t[i]];
  }
  return h;
}

Index SizingField::locate(const Vec3& x) const {
  // Every tet whose box holds x is tested (exactly) unless one holds x in its
  // interior: in a conforming mesh that tet is then the only one containing x.
  Index best = kNoIndex;
  Index stack[kStack];
  int top = 0;
  if (box_contains(bvh_[0].box, x)) stack[top++] = 0;
  while (top > 0) {
    const sizing_detail::TreeNode& node = bvh_[stack[--top]];  // its box holds x
    if (node.left != kNoIndex) {
      // Test both children here, so that only nodes holding x are visited.
      if (box_contains(bvh_[node.right].box, x)) stack[top++] = node.right;
      if (box_contains(bvh_[node.left].box, x)) stack[top++] = node.left;
      continue;
    }
    for (std::uint32_t s = node.begin; s < node.end; ++s) {
      const Index t = bvh_item_[s];
      if (t >= best || !box_contains(bvh_box_[s], x)) continue;
      const Tet& v = tets_[t];
      const Vec3 &a = points_[v[0]], &b = points_[v[1]], &c = points_[v[2]], &d = points_[v[3]];
      int o[4];
      if ((o[0] = exact::orient3d(x, b, c, d)) < 0 || (o[1] = exact::orient3d(a, x, c, d)) < 0 ||
          (o[2] = exact::orient3d(a, b, x, d)) < 0 || (o[3] = exact::orient3d(a, b, c, x)) < 0) {
        continue;
      }
      if (o[0] > 0 && o[1] > 0 && o[2] > 0 && o[3] > 0) return t;
      best = t;
    }
  }
  return best;
}

Index SizingField::nearest_tet(const Vec3& x, Vec3& closest) const {
  // Branch and bound over the tet tree, nearer child first; ties to the lower tet.
  double best = kInf;
  Index best_tet = kNoIndex;
  Index stack[kStack];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const sizing_detail::TreeNode& node = bvh_[stack[--top]];
    if (box_dist2(node.box, x) > best) continue;
    if (node.left != kNoIndex) {
      const bool left_first = box_dist2(bvh_[node.left].box, x) <= box_dist2(bvh_[node.right].box, x);
      stack[top++] = left_first ? node.right : node.left;
      stack[top++] = left_first ? node.left : node.right;
      continue;
    }
    for (std::uint32_t s = node.begin; s < node.end; ++s) {
      if (box_dist2(bvh_box_[s], x) > best) continue;
      const Index t = bvh_item_[s];
      const Tet& v = tets_[t];
      for (const auto& face : topo::kFaceVertex) {
        const Vec3 y = closest_on_triangle(x, points_[v[face[0]]], points_[v[face[1]]], points_[v[face[2]]]);
        const double d2 = dist2(x, y);
        if (d2 < best || (d2 == best && t < best_tet)) {
          best = d2;
          best_tet = t;
          closest = y;
        }
      }
    }
  }
  return best_tet;
}

double SizingField::at(const Vec3& x) const {
  if (uniform_ && !graded_) return uniform_value_;
  if (!is_finite(x)) return kNaN;
  if (graded_) return graded(x, nullptr);
  const Index t = locate(x);
  if (t != kNoIndex) return combine(interpolate_in(t, x), x);
  Vec3 y{};
  const Index n = nearest_tet(x, y);
  return combine(interpolate_in(n, y), y);
}

Index SizingField::walk_to(Index tet, const Vec3& x) const {
  // A visibility walk: through a face whose plane has x strictly outside,
  // tried from a face that turns with the step (no cycle is kept up), until a
  // tet holds x strictly. kNoIndex where x is on a face, outside the mesh, or
  // past the step limit: the caller then searches the tree.
  constexpr int kSteps = 64;
  for (int step = 0; step < kSteps && tet < tets_.size(); ++step) {
    const Tet& v = tets_[tet];
    std::array<Vec3, 4> q{points_[v[0]], points_[v[1]], points_[v[2]], points_[v[3]]};
    int through = -1;
    bool on_face = false;
    for (int k = 0; k < 4 && through < 0; ++k) {
      const int f = (k + step) & 3;
      const Vec3 corner = q[f];
      q[f] = x;
      const int o = exact::orient3d(q[0], q[1], q[2], q[3]);
      q[f] = corner;
      if (o < 0) through = f;
      on_face = on_face || o == 0;
    }
    if (through < 0) return on_face ? kNoIndex : tet;
    tet = neighbours_[tet][through];
  }
  return kNoIndex;
}

double SizingField::at(const Vec3& x, SizingHint& hint) const {
  if (uniform_ && !graded_) return uniform_value_;
  if (!is_finite(x)) return kNaN;
  if (graded_) return graded(x, &hint.point);
  // A tet that holds x strictly is what locate() returns: no other tet holds x.
  Index t = walk_to(hint.tet, x);
  if (t == kNoIndex) t = locate(x);
  if (t != kNoIndex) {
    hint.tet = t;
    return combine(interpolate_in(t, x), x, hint);
  }
  Vec3 y{};
  const Index n = nearest_tet(x, y);
  return combine(interpolate_in(n, y), y, hint);
}

double SizingField::lower_bound(const Box& box) const {
  if (box.empty()) return kNaN;
  constexpr double kBelow = 1 - 1e-9;  // at() rounds a convex combination: stay under it
  if (uniform_) return kBelow * uniform_value_;
  auto meets = [&](const Box& b) {
    for (int a = 0; a < 3; ++a)
      if (b.hi[a] < box.lo[a] || b.lo[a] > box.hi[a]) return false;
    return true;
  };
  auto box_box_dist = [&](const Box& b) {
    double d2 = 0;
    for (int a = 0; a < 3; ++a) {
      const double d = std::max({0.0, b.lo[a] - box.hi[a], box.lo[a] - b.hi[a]});
      d2 += d * d;
    }
    return std::sqrt(d2);
  };
  // The interpolant at x is a convex combination of the values of a tet holding x.
  double interpolated = hi_;
  Index stack[kStack];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const sizing_detail::TreeNode& node = bvh_[stack[--top]];
    if (!meets(node.box)) continue;
    if (node.left != kNoIndex) {
      stack[top++] = node.right;
      stack[top++] = node.left;
      continue;
    }
    for (std::uint32_t s = node.begin; s < node.end; ++s) {
      if (!meets(bvh_box_[s])) continue;
      for (Index v : tets_[bvh_item_[s]]) interpolated = std::min(interpolated, values_[v]);
    }
  }
  // The growth limit: the same branch and bound as growth_limit(), from a box.
  const double gm1 = growth_ - 1;
  double best = interpolated;
  top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Index n = stack[--top];
    const sizing_detail::TreeNode& node = kd_[n];
    if (kd_h_min_[n] + gm1 * box_box_dist(node.box) >= best) continue;
    if (node.left != kNoIndex) {
      stack[top++] = node.right;
      stack[top++] = node.left;
      continue;
    }
    for (std::uint32_t i = node.begin; i < node.end; ++i)
      best = std::min(best, kd_h_[i] + gm1 * std::sqrt(box_dist2(box, kd_xyz_[i])));
  }
  return kBelow * std::max(lo_, best);
}

double SizingField::at_point(Index i) const {
  if (i >= point_count_ || graded_) return kNaN;
  if (uniform_) return uniform_value_;
  return combine(values_[i], points_[i]);
}

// ---------------------------------------------------------------- serialisation

std::string SizingField::encode() const {
  Writer w;
  w.bytes(kMagic, sizeof kMagic);
  w.u32(kVersion);
  if (uniform_) {
    w.u32(graded_ ? kModeGraded : kModeUniform);
    w.f64(uniform_value_);
    w.u64(point_count_);
    if (!graded_) return w.take();
    w.f64(hi_);
    w.u64(points_.size());
    for (std::size_t i = 0; i < points_.size(); ++i) {
      for (double v : points_[i]) w.f64(v);
      w.f64(values_[i]);
    }
    return w.take();
  }
  w.u32(kModeField);
  w.f64(growth_);
  w.f64(lo_);
  w.f64(hi_);
  w.u64(points_.size());
  for (const Vec3& p : points_)
    for (double v : p) w.f64(v);
  for (double v : values_) w.f64(v);
  w.u64(tets_.size());
  for (const Tet& t : tets_)
    for (Index v : t) w.u32(v);
  w.u64(boundary_.size());
  for (Index b : boundary_) w.u32(b);
  return w.take();
}

Result<SizingField> SizingField::decode(std::string_view bytes) {
  Reader r(bytes);
  char magic[sizeof kMagic] = {};
  if (!r.bytes(magic, sizeof magic) || !std::equal(magic, magic + sizeof magic, kMagic)) {
    return decode_error("not an encoded sizing field (bad magic)");
  }
  std::uint32_t version = 0, mode = 0;
  if (!r.u32(version) || version != kVersion) return decode_error(fmt::format("unsupported version {}", version));
  if (!r.u32(mode) || (mode != kModeField && mode != kModeUniform && mode != kModeGraded)) {
    return decode_error(fmt::format("unknown mode {}", mode));
  }
  SizingField f;
  if (mode == kModeUniform || mode == kModeGraded) {
    std::uint64_t n = 0;
    if (!r.f64(f.uniform_value_) || !r.u64(n)) return decode_error("truncated uniform field");
    if (!(std::isfinite(f.uniform_value_) && f.uniform_value_ > 0)) {
      return decode_error(fmt::format("uniform value {} is not a finite length > 0", f.uniform_value_));
    }
    if (n > std::numeric_limits<Index>::max()) return decode_error(fmt::format("{} points is too many", n));
    f.uniform_ = true;
    f.point_count_ = static_cast<std::size_t>(n);
    if (mode == kModeGraded) {
      f.graded_ = true;
      if (!r.f64(f.hi_) || !(f.hi_ >= f.uniform_value_)) {
        return decode_error(fmt::format("graded field: hmax {} is below the size {}", f.hi_, f.uniform_value_));
      }
      std::size_t nb = 0;
      if (!r.count(32, nb) || nb == 0) return decode_error("graded field: no boundary points, or more than the buffer");
      for (std::size_t i = 0; i < nb; ++i) {
        Vec3 p{};
        double v = 0;
        for (double& c : p) (void)r.f64(c);  // sizes checked by count()
        (void)r.f64(v);
        if (!is_finite(p) || !(std::isfinite(v) && v > 0)) {
          return decode_error(fmt::format("graded field: boundary point {} at {} with spacing {}", i, point_str(p), v));
        }
        f.boundary_.push_back(static_cast<Index>(i));
        f.points_.push_back(p);
        f.values_.push_back(v);
      }
    }
    if (r.left() != 0) return decode_error(fmt::format("{} trailing bytes", r.left()));
    if (f.graded_) PDR_TRY(f.finish());
    return f;
  }
  if (!r.f64(f.growth_) || !r.f64(f.lo_) || !r.f64(f.hi_)) return decode_error("truncated header");
  if (!(std::isfinite(f.growth_) && f.growth_ > 1)) return decode_error(fmt::format("growth {} is not > 1", f.growth_));
  if (!(std::isfinite(f.lo_) && f.lo_ >= 0 && f.hi_ > 0 && f.lo_ <= f.hi_)) {
    return decode_error(fmt::format("clamp range [{}, {}] is invalid", f.lo_, f.hi_));
  }
  std::size_t n = 0;
  if (!r.count(32, n)) return decode_error("point count exceeds the buffer");
  if (n > std::numeric_limits<Index>::max()) return decode_error(fmt::format("{} points is too many", n));
  f.points_.resize(n);
  for (Vec3& p : f.points_) {
    for (double& v : p) (void)r.f64(v);  // sizes checked by count()
    if (!is_finite(p)) return decode_error(fmt::format("point {} is not finite", point_str(p)));
  }
  f.values_.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    (void)r.f64(f.values_[i]);
    if (!(std::isfinite(f.values_[i]) && f.values_[i] > 0)) {
      return decode_error(fmt::format("value {} at point {} is not a finite length > 0", f.values_[i], i));
    }
  }
  std::size_t m = 0;
  if (!r.count(16, m)) return decode_error("tet count exceeds the buffer");
  f.tets_.resize(m);
  for (Tet& t : f.tets_)
    for (Index& v : t) (void)r.u32(v);
  PDR_TRY(validate_tets(f.points_, f.tets_, "sizing field"));
  std::size_t nb = 0;
  if (!r.count(4, nb)) return decode_error("boundary point count exceeds the buffer");
  if (nb == 0) return decode_error("no boundary points");
  f.boundary_.resize(nb);
  for (std::size_t i = 0; i < nb; ++i) {
    (void)r.u32(f.boundary_[i]);
    if (f.boundary_[i] >= n || (i > 0 && f.boundary_[i] <= f.boundary_[i - 1])) {
      return decode_error(fmt::format("boundary point {} (index {}) is out of range or out of order", i,
                                      f.boundary_[i]));
    }
  }
  if (r.left() != 0) return decode_error(fmt::format("{} trailing bytes", r.left()));
  f.point_count_ = n;
  PDR_TRY(f.finish());
  return f;
}

}  // namespace pdrmesh
