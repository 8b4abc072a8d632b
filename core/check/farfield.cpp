// SPDX-License-Identifier: AGPL-3.0-or-later
// The domain between a body and a far-field box or sphere (farfield.hpp).
#include "pdrmesh/farfield.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <string>
#include <utility>
#include <set>
#include <vector>

#include "pdrmesh/boundary_names.hpp"
#include "pdrmesh/predicates.hpp"
#include "pdrmesh/surface_check.hpp"

namespace pdrmesh {
namespace {

/// The far field being built: points after the body's, triangles with their ids.
struct FarfieldBuilder {
  std::vector<Vec3> points;
  std::vector<Tri> triangles;
  std::vector<int> ids;
  Index first_point = 0;  ///< the body's point count: the far field's indices start there

  Index add_point(const Vec3& p) {
    points.push_back(p);
    return first_point + static_cast<Index>(points.size() - 1);
  }
  void add_triangle(Index a, Index b, Index c, int id) {
    triangles.push_back({a, b, c});
    ids.push_back(id);
  }
};

/// Each face of the box [lo, hi] a grid of n[u] x n[v] squares, each split in
/// two triangles along the same diagonal, normals pointing out of the box.
/// Grid points on the box's edges are shared by the faces that meet there.
void make_box(const Vec3& lo, const Vec3& hi, const std::array<int, 3>& n, const std::array<int, 3>& ids,
              FarfieldBuilder& out) {
  std::map<std::array<int, 3>, Index> index;
  const auto coordinate = [&](int axis, int i) {
    if (i == 0) return lo[axis];
    if (i == n[axis]) return hi[axis];
    return lo[axis] + (hi[axis] - lo[axis]) * i / n[axis];
  };
  const auto point = [&](const std::array<int, 3>& g) {
    const auto [it, fresh] = index.try_emplace(g, 0);
    if (fresh) it->second = out.add_point({coordinate(0, g[0]), coordinate(1, g[1]), coordinate(2, g[2])});
    return it->second;
  };
  for (int axis = 0; axis < 3; ++axis) {
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;  // e_u x e_v = e_axis
    for (int side = 0; side < 2; ++side) {
      // The -x face is the inlet, the +x face the outlet, the others the sides.
      const int id = axis == 0 ? ids[side] : ids[2];
      for (int i = 0; i < n[u]; ++i) {
        for (int j = 0; j < n[v]; ++j) {
          const auto at = [&](int di, int dj) {
            std::array<int, 3> g{};
            g[axis] = side == 0 ? 0 : n[axis];
            g[u] = i + di;
            g[v] = j + dj;
            return point(g);
          };
          const Index p00 = at(0, 0), p10 = at(1, 0), p11 = at(1, 1), p01 = at(0, 1);
          if (side == 1) {
            out.add_triangle(p00, p10, p11, id);
            out.add_triangle(p00, p11, p01, id);
          } else {
            out.add_triangle(p00, p11, p10, id);
            out.add_triangle(p00, p01, p11, id);
          }
        }
      }
    }
  }
}

/// The sphere of `radius` about `center`: every face of an icosahedron cut
/// into `n` x `n` triangles, the points pushed out onto the sphere. A point is
/// keyed by its integer barycentric weights on the icosahedron's vertices, and
/// its coordinates summed in vertex order, so the faces that share it agree on
/// it bit for bit.
void make_sphere(const Vec3& center, double radius, int n, int id, FarfieldBuilder& out) {
  const double t = (1 + std::sqrt(5.0)) / 2;
  const std::array<Vec3, 12> v{{{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                                {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}}};
  std::array<std::array<int, 3>, 20> faces{{{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                            {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                            {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                            {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}}};
  // Outward: the centre lies behind every face (exactly decided, whatever the listing's order).
  for (auto& f : faces)
    if (exact::orient3d(v[f[0]], v[f[1]], v[f[2]], Vec3{0, 0, 0}) > 0) std::swap(f[1], f[2]);

  using Key = std::array<std::pair<int, int>, 3>;  // (vertex, weight), by vertex, weight 0 entries last
  std::map<Key, Index> index;
  const auto point = [&](const std::array<int, 3>& face, const std::array<int, 3>& w) {
    Key key{};
    int k = 0;
    for (int c = 0; c < 3; ++c)
      if (w[c] > 0) key[k++] = {face[c], w[c]};
    for (; k < 3; ++k) key[k] = {99, 0};
    std::sort(key.begin(), key.end());
    const auto [it, fresh] = index.try_emplace(key, 0);
    if (fresh) {
      Vec3 p{0, 0, 0};
      for (const auto& [vertex, weight] : key)
        if (weight > 0) p = p + static_cast<double>(weight) * v[vertex];
      const double scale = radius / norm(p);
      it->second = out.add_point(center + scale * p);
    }
    return it->second;
  };
  for (const auto& f : faces) {
    // P(i, j) = ((n - i - j) A + i B + j C) / n keeps the face's orientation.
    const auto at = [&](int i, int j) { return point(f, {n - i - j, i, j}); };
    for (int i = 0; i < n; ++i) {
      for (int j = 0; i + j < n; ++j) {
        out.add_triangle(at(i, j), at(i + 1, j), at(i, j + 1), id);
        if (i + j + 2 <= n) out.add_triangle(at(i + 1, j), at(i + 1, j + 1), at(i, j + 1), id);
      }
    }
  }
}

/// OK when every corner of `body` lies strictly inside the far field: the far
/// field is convex (no edge folds outward) and every corner is behind every
/// far-field triangle, all decided exactly.
Status check_encloses(const FarfieldBuilder& ff, const Box& body) {
  const auto p = [&](Index i) -> const Vec3& { return ff.points[i - ff.first_point]; };
  std::map<std::pair<Index, Index>, Index> apex;  // directed edge -> the third point of its triangle
  for (const Tri& t : ff.triangles)
    for (int k = 0; k < 3; ++k) apex[{t[k], t[(k + 1) % 3]}] = t[(k + 2) % 3];
  for (const Tri& t : ff.triangles) {
    for (int k = 0; k < 3; ++k) {
      const auto it = apex.find({t[(k + 1) % 3], t[k]});
      if (it == apex.end() || exact::orient3d(p(t[0]), p(t[1]), p(t[2]), p(it->second)) > 0)
        return internal_error("the far field made for --farfield is not a closed convex surface");
    }
    for (int c = 0; c < 8; ++c) {
      const Vec3 corner{(c & 1) ? body.hi[0] : body.lo[0], (c & 2) ? body.hi[1] : body.lo[1],
                        (c & 4) ? body.hi[2] : body.lo[2]};
      if (exact::orient3d(p(t[0]), p(t[1]), p(t[2]), corner) >= 0)
        return internal_error("the far field made for --farfield does not enclose the body's bounding box");
    }
  }
  return {};
}

/// The body's names and the far field's: an unnamed body id becomes "wall"
/// (each "wall_<id>" when several are unnamed, or "wall" is taken); a body
/// name that is a far-field name is refused.
Result<std::map<int, std::string>> domain_names(const SurfaceMesh& body, const std::vector<int>& body_ids,
                                                const std::map<int, std::string>& farfield) {
  std::map<int, std::string> names;
  for (const auto& [id, name] : body.surface_names)
    if (std::binary_search(body_ids.begin(), body_ids.end(), id)) names[id] = name;
  std::vector<std::string> far;
  for (const auto& [id, name] : farfield) far.push_back(name);
  for (const auto& [id, name] : names)
    if (std::find(far.begin(), far.end(), name) != far.end())
      return invalid_input(fmt::format("the body's surface id {} is named '{}', a name of the far field "
                                       "({}); give it another name (--names)",
                                       id, name, fmt::join(far, ", ")));
  std::vector<int> unnamed;
  bool wall_taken = false;
  for (int id : body_ids) {
    if (!names.count(id)) unnamed.push_back(id);
    else if (names[id] == "wall") wall_taken = true;
  }
  for (int id : unnamed) names[id] = unnamed.size() == 1 && !wall_taken ? "wall" : fmt::format("wall_{}", id);
  for (const auto& [id, name] : farfield) names[id] = name;
  PDR_TRY(check_boundary_names(names, "--farfield"));
  return names;
}

}  // namespace

std::string_view to_string(FarfieldShape shape) { return shape == FarfieldShape::kSphere ? "sphere" : "box"; }

std::optional<FarfieldShape> parse_farfield_shape(std::string_view name) {
  if (name == "box") return FarfieldShape::kBox;
  if (name == "sphere") return FarfieldShape::kSphere;
  return std::nullopt;
}

Status check_farfield_distance(double distance, std::string_view what) {
  if (!std::isfinite(distance) || distance <= kMinFarfieldDistance || distance > kMaxFarfieldDistance)
    return invalid_input(fmt::format("{} {}: the far field's distance is in body lengths, over {} and at most {} "
                                     "(10 to 20 is usual for external flow)",
                                     what, distance, kMinFarfieldDistance, kMaxFarfieldDistance));
  return {};
}

Result<FarfieldDomain> make_farfield(const SurfaceMesh& body, const FarfieldOptions& options) {
  PDR_TRY(check_farfield_distance(options.distance, "--farfield"));
  if (!body.surface_ids.empty() && body.surface_ids.size() != body.triangles.size())
    return invalid_input(fmt::format("{}: {} surface ids for {} triangles", body.name, body.surface_ids.size(),
                                     body.triangles.size()));
  // Closed, manifold and outward: the far field's own check (self-intersections
  // are left to the check of the whole domain, which finds them anyway).
  CheckOptions check;
  check.self_intersections = false;
  if (Status s = require_meshable(check_surface(body, check), body.name); !s.ok())
    return invalid_input(fmt::format("--farfield needs a closed, outward body: {}", s.message()));

  FarfieldDomain d;
  const Box box = body.bounds();
  const Vec3 extent = box.hi - box.lo;
  d.body_length = std::max({extent[0], extent[1], extent[2]});
  if (!(d.body_length > 0)) return invalid_input(fmt::format("{}: the body has no extent", body.name));
  const double gap = options.distance * d.body_length;
  d.farfield_size = gap / 4;

  std::vector<int> body_ids = body.surface_ids;
  if (body_ids.empty()) body_ids.assign(body.triangles.size(), 1);
  std::vector<int> distinct = body_ids;
  std::sort(distinct.begin(), distinct.end());
  distinct.erase(std::unique(distinct.begin(), distinct.end()), distinct.end());
  const int next = distinct.back() + 1;

  FarfieldBuilder ff;
  ff.first_point = static_cast<Index>(body.points.size());
  std::map<int, std::string> far_names;
  if (options.shape == FarfieldShape::kBox) {
    const Vec3 lo = box.lo - Vec3{gap, gap, gap}, hi = box.hi + Vec3{gap, gap, gap};
    std::array<int, 3> n{};
    for (int k = 0; k < 3; ++k) n[k] = std::max(1, static_cast<int>(std::ceil((hi[k] - lo[k]) / d.farfield_size)));
    make_box(lo, hi, n, {next, next + 1, next + 2}, ff);
    far_names = {{next, "inlet"}, {next + 1, "outlet"}, {next + 2, "sides"}};
  } else {
    const double radius = box.diagonal() / 2 + gap;
    // An icosahedron's edge is 1.0515 times its circumradius.
    const int n = std::max(1, static_cast<int>(std::ceil(1.0515 * radius / d.farfield_size)));
    make_sphere(0.5 * (box.lo + box.hi), radius, n, next, ff);
    far_names = {{next, "farfield"}};
  }
  PDR_TRY(check_encloses(ff, box));
  PDR_ASSIGN_OR_RETURN(d.surface.surface_names, domain_names(body, distinct, far_names));

  SurfaceMesh& s = d.surface;
  s.name = body.name;
  s.points = body.points;
  s.points.insert(s.points.end(), ff.points.begin(), ff.points.end());
  s.triangles.reserve(body.triangles.size() + ff.triangles.size());
  for (const Tri& t : body.triangles) s.triangles.push_back({t[0], t[2], t[1]});  // into the body
  s.triangles.insert(s.triangles.end(), ff.triangles.begin(), ff.triangles.end());
  s.surface_ids = std::move(body_ids);
  s.surface_ids.insert(s.surface_ids.end(), ff.ids.begin(), ff.ids.end());
  d.farfield_triangles = ff.triangles.size();
  return d;
}

std::vector<int> FarfieldDomain::body_ids() const {
  const auto& ids = surface.surface_ids;
  const std::set<int> body(ids.begin(), ids.end() - static_cast<std::ptrdiff_t>(farfield_triangles));
  return {body.begin(), body.end()};
}

}  // namespace pdrmesh
