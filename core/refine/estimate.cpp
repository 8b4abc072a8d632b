// SPDX-License-Identifier: AGPL-3.0-or-later
// The cost estimate of a mesh (see estimate.hpp).
#include "pdrmesh/estimate.hpp"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace pdrmesh {
namespace {

constexpr double kSqrt2 = 1.4142135623730951;

/// Density (tets per unit volume) for a target edge length h.
double density(double h) { return kTetsPerRegularVolume * 6.0 * kSqrt2 / (h * h * h); }

/// The enclosed volume by the divergence theorem (points taken relative to the
/// bounding-box centre, which keeps the sum accurate far from the origin).
double enclosed_volume(const SurfaceMesh& surface, const Vec3& centre) {
  double six_v = 0;
  for (const Tri& t : surface.triangles) {
    const Vec3 a = surface.points[t[0]] - centre, b = surface.points[t[1]] - centre, c = surface.points[t[2]] - centre;
    six_v += dot(a, cross(b, c));
  }
  return six_v / 6.0;
}

/// A coarse grid of cubic cells over the surface's bounding box.
struct Grid {
  Vec3 lo{};
  double cell = 1;
  std::array<int, 3> n{1, 1, 1};

  std::size_t size() const { return static_cast<std::size_t>(n[0]) * n[1] * n[2]; }
  std::size_t index(int i, int j, int k) const { return (static_cast<std::size_t>(k) * n[1] + j) * n[0] + i; }
  // Row centres are offset from the cell middle by different small fractions
  // in y and z, so that rows rarely pass exactly through surface edges
  // (an axis-aligned body's diagonals included).
  double x(int i) const { return lo[0] + (i + 0.5) * cell; }
  double y(int j) const { return lo[1] + (j + 0.5137) * cell; }
  double z(int k) const { return lo[2] + (k + 0.5291) * cell; }
  Vec3 centre(int i, int j, int k) const { return {x(i), y(j), z(k)}; }
  int clamp_cell(double v, int axis) const {
    const double f = std::floor((v - lo[axis]) / cell);
    return static_cast<int>(std::clamp(f, 0.0, static_cast<double>(n[axis] - 1)));
  }
};

/// Which cell centres lie inside the surface: per grid row along x, the
/// crossings of the row with the triangles (signed by the triangle's facing),
/// then a winding count along the row.
std::vector<std::uint8_t> inside_cells(const SurfaceMesh& surface, const Grid& g) {
  struct Crossing {
    double x;
    int sign;
  };
  std::vector<std::vector<Crossing>> rows(static_cast<std::size_t>(g.n[1]) * g.n[2]);
  for (const Tri& t : surface.triangles) {
    const Vec3& a = surface.points[t[0]];
    const Vec3& b = surface.points[t[1]];
    const Vec3& c = surface.points[t[2]];
    const double d = (b[1] - a[1]) * (c[2] - a[2]) - (b[2] - a[2]) * (c[1] - a[1]);  // x of the normal
    if (d == 0) continue;                                                             // parallel to the rows
    const double ylo = std::min({a[1], b[1], c[1]}), yhi = std::max({a[1], b[1], c[1]});
    const double zlo = std::min({a[2], b[2], c[2]}), zhi = std::max({a[2], b[2], c[2]});
    const int j0 = std::max(0, static_cast<int>(std::ceil((ylo - g.lo[1]) / g.cell - 0.5137)));
    const int j1 = std::min(g.n[1] - 1, static_cast<int>(std::floor((yhi - g.lo[1]) / g.cell - 0.5137)));
    const int k0 = std::max(0, static_cast<int>(std::ceil((zlo - g.lo[2]) / g.cell - 0.5291)));
    const int k1 = std::min(g.n[2] - 1, static_cast<int>(std::floor((zhi - g.lo[2]) / g.cell - 0.5291)));
    for (int k = k0; k <= k1; ++k) {
      for (int j = j0; j <= j1; ++j) {
        const double py = g.y(j) - a[1], pz = g.z(k) - a[2];
        const double wb = (py * (c[2] - a[2]) - pz * (c[1] - a[1])) / d;
        const double wc = ((b[1] - a[1]) * pz - (b[2] - a[2]) * py) / d;
        if (wb < 0 || wc < 0 || wb + wc > 1) continue;
        const double x = a[0] + wb * (b[0] - a[0]) + wc * (c[0] - a[0]);
        rows[static_cast<std::size_t>(k) * g.n[1] + j].push_back({x, d > 0 ? 1 : -1});
      }
    }
  }
  std::vector<std::uint8_t> inside(g.size(), 0);
  for (int k = 0; k < g.n[2]; ++k) {
    for (int j = 0; j < g.n[1]; ++j) {
      auto& row = rows[static_cast<std::size_t>(k) * g.n[1] + j];
      std::sort(row.begin(), row.end(), [](const Crossing& p, const Crossing& q) {
        return p.x < q.x || (p.x == q.x && p.sign < q.sign);
      });
      // Entering the body along +x crosses a triangle facing -x: the winding
      // number is minus the sum of the signs passed.
      int winding = 0;
      std::size_t next = 0;
      for (int i = 0; i < g.n[0]; ++i) {
        const double x = g.x(i);
        while (next < row.size() && row[next].x < x) winding -= row[next++].sign;
        inside[g.index(i, j, k)] = winding != 0;
      }
    }
  }
  return inside;
}

/// Per cell, the boundary point minimising `cost(point, centre)`, found by
/// seeding each point's own cell and two forward and backward raster sweeps
/// over the 26 neighbours (ties: the lower point index).
template <class Cost>
std::vector<Index> propagate_seeds(const Grid& g, const std::vector<Vec3>& pts, Cost cost) {
  std::vector<Index> seed(g.size(), kNoIndex);
  std::vector<double> best(g.size());  // cost(seed[cell], centre of cell), kept with the seed
  auto offer = [&](std::size_t cell, const Vec3& x, Index candidate) {
    const Index cur = seed[cell];
    if (candidate == cur) return;
    const double c_new = cost(candidate, x);
    if (cur == kNoIndex || c_new < best[cell] || (c_new == best[cell] && candidate < cur)) {
      seed[cell] = candidate;
      best[cell] = c_new;
    }
  };
  for (Index p = 0; p < pts.size(); ++p) {
    const int i = g.clamp_cell(pts[p][0], 0), j = g.clamp_cell(pts[p][1], 1), k = g.clamp_cell(pts[p][2], 2);
    offer(g.index(i, j, k), g.centre(i, j, k), p);
  }
  auto visit = [&](int i, int j, int k) {
    const std::size_t cell = g.index(i, j, k);
    const Vec3 x = g.centre(i, j, k);
    Index last = kNoIndex;  // a candidate offered again changes nothing
    for (int dk = -1; dk <= 1; ++dk) {
      for (int dj = -1; dj <= 1; ++dj) {
        for (int di = -1; di <= 1; ++di) {
          const int a = i + di, b = j + dj, c = k + dk;
          if (a < 0 || b < 0 || c < 0 || a >= g.n[0] || b >= g.n[1] || c >= g.n[2]) continue;
          const Index s = seed[g.index(a, b, c)];
          if (s != kNoIndex && s != last) offer(cell, x, s);
          last = s;
        }
      }
    }
  };
  for (int pass = 0; pass < 2; ++pass) {
    for (int k = 0; k < g.n[2]; ++k)
      for (int j = 0; j < g.n[1]; ++j)
        for (int i = 0; i < g.n[0]; ++i) visit(i, j, k);
    for (int k = g.n[2] - 1; k >= 0; --k)
      for (int j = g.n[1] - 1; j >= 0; --j)
        for (int i = g.n[0] - 1; i >= 0; --i) visit(i, j, k);
  }
  return seed;
}

/// Nearest-point searches at most: beyond this many surface components, the
/// smaller ones share the last search (blended_groups).
constexpr std::size_t kMaxBlendedComponents = 8;

/// The used points (original[k]: the surface point of used point k) grouped
/// by the connected component of the surface's triangles they lie on, as
/// used-point numbers, components in the order of their first point.
std::vector<std::vector<Index>> point_components(const SurfaceMesh& surface, const std::vector<Index>& original) {
  std::vector<Index> parent(surface.points.size());
  for (Index i = 0; i < parent.size(); ++i) parent[i] = i;
  const auto root = [&](Index v) {
    while (parent[v] != v) v = parent[v] = parent[parent[v]];
    return v;
  };
  for (const Tri& t : surface.triangles)
    for (int c = 1; c < 3; ++c) {
      const Index a = root(t[0]), b = root(t[c]);
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  std::vector<std::vector<Index>> out;
  std::vector<Index> slot(surface.points.size(), kNoIndex);
  for (Index k = 0; k < original.size(); ++k) {
    Index& c = slot[root(original[k])];
    if (c == kNoIndex) {
      c = static_cast<Index>(out.size());
      out.emplace_back();
    }
    out[c].push_back(k);
  }
  return out;
}

/// The components as groups of used points, one nearest-point search each:
/// every component alone when there are at most kMaxBlendedComponents, else
/// the kMaxBlendedComponents - 1 widest (bounding-box diagonal; ties: the
/// first) alone and the others together. The widest keep their own blend, so
/// an enclosing far field stays apart from the bodies inside it.
std::vector<std::vector<Index>> blended_groups(std::vector<std::vector<Index>> components, const std::vector<Vec3>& pts) {
  if (components.size() <= kMaxBlendedComponents) return components;
  std::vector<double> width(components.size());
  for (std::size_t c = 0; c < components.size(); ++c) {
    Box b;
    for (Index p : components[c]) b.add(pts[p]);
    width[c] = b.diagonal();
  }
  std::vector<std::size_t> order(components.size());
  for (std::size_t c = 0; c < order.size(); ++c) order[c] = c;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return width[a] > width[b]; });
  std::vector<char> alone(components.size(), 0);
  for (std::size_t k = 0; k + 1 < kMaxBlendedComponents; ++k) alone[order[k]] = 1;
  std::vector<std::vector<Index>> groups;
  std::vector<Index> rest;
  for (std::size_t c = 0; c < components.size(); ++c) {
    if (alone[c]) {
      groups.push_back(std::move(components[c]));
    } else {
      rest.insert(rest.end(), components[c].begin(), components[c].end());
    }
  }
  std::sort(rest.begin(), rest.end());
  groups.push_back(std::move(rest));
  return groups;
}

std::string with_thousands(double v) {
  const std::string digits = fmt::format("{:.0f}", v);
  std::string out;
  for (std::size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) out += ',';
    out += digits[i];
  }
  return out;
}

}  // namespace

Result<MeshEstimate> estimate_mesh(const SurfaceMesh& surface, const SizingOptions& options) {
  // h at the boundary points (validates the options and the triangles): with
  // a size, from its field from the surface, built once for both uses here
  // (surface_values would build the same field).
  std::optional<SizingField> sized;
  std::vector<double> h_surface;
  if (options.size) {
    PDR_ASSIGN_OR_RETURN(SizingField f, SizingField::from_surface(surface, options));
    sized.emplace(std::move(f));
    h_surface = sized->at_surface_points(surface);
  } else {
    PDR_ASSIGN_OR_RETURN(h_surface, SizingField::surface_values(surface, options));
  }
  const double lo = options.hmin.value_or(0.0);
  const double hi = options.hmax.value_or(std::numeric_limits<double>::infinity());
  std::vector<Vec3> pts;
  std::vector<double> h;
  std::vector<Index> original;  // pts[k] is surface point original[k]
  for (std::size_t p = 0; p < surface.points.size(); ++p) {
    if (std::isnan(h_surface[p])) continue;  // used by no triangle
    pts.push_back(surface.points[p]);
    h.push_back(h_surface[p]);
    original.push_back(static_cast<Index>(p));
  }
  Box box;
  for (const Vec3& p : pts) box.add(p);
  MeshEstimate e;
  if (pts.empty()) return e;
  e.volume = std::max(0.0, enclosed_volume(surface, 0.5 * (box.lo + box.hi)));

  const auto grid = [&] {
    Grid g;
    g.lo = box.lo;
    const double longest = std::max({box.hi[0] - box.lo[0], box.hi[1] - box.lo[1], box.hi[2] - box.lo[2]});
    g.cell = longest > 0 ? longest / kEstimateGridCells : 1.0;
    for (int k = 0; k < 3; ++k) {
      g.n[k] = std::clamp(static_cast<int>(std::ceil((box.hi[k] - box.lo[k]) / g.cell)), 1, kEstimateGridCells);
    }
    return g;
  };
  double mean_density = 0;
  if (options.size) {
    const SizingField& field = *sized;
    mean_density = density(std::clamp(*options.size, lo, hi));
    if (!field.uniform()) {
      // The size rises next to wider triangles: h at the centres of the cells inside.
      const Grid g = grid();
      const std::vector<std::uint8_t> inside = inside_cells(surface, g);
      SizingHint hint;
      double sum = 0;
      std::size_t count = 0;
      for (int k = 0; k < g.n[2]; ++k)
        for (int j = 0; j < g.n[1]; ++j)
          for (int i = 0; i < g.n[0]; ++i)
            if (inside[g.index(i, j, k)]) {
              sum += density(field.at(g.centre(i, j, k), hint));
              ++count;
            }
      if (count > 0) mean_density = sum / static_cast<double>(count);
    }
  } else {
    const Grid g = grid();
    const std::vector<std::uint8_t> inside = inside_cells(surface, g);
    const double rate = options.growth - 1;
    const auto squared_distance = [&](Index p, const Vec3& x) {
      const Vec3 d = x - pts[p];
      return dot(d, d);
    };
    // The nearest boundary point of each group of surface components
    // (blended_groups: each component alone, up to kMaxBlendedComponents).
    std::vector<std::vector<Index>> nearest;
    for (const std::vector<Index>& c : blended_groups(point_components(surface, original), pts)) {
      std::vector<Vec3> cp;
      for (const Index p : c) cp.push_back(pts[p]);
      std::vector<Index> seeds = propagate_seeds(g, cp, [&](Index q, const Vec3& x) { return squared_distance(c[q], x); });
      for (Index& q : seeds) q = c[q];
      nearest.push_back(std::move(seeds));
    }
    // h between components as the background interpolation gives it: the
    // nearest points' spacings weighted by inverse distance (one component:
    // its nearest point's).
    const auto interpolated = [&](std::size_t cell, const Vec3& x) {
      if (nearest.size() == 1) return h[nearest[0][cell]];
      double sum_w = 0, sum_wh = 0;
      for (const std::vector<Index>& n : nearest) {
        const double d = std::sqrt(squared_distance(n[cell], x));
        if (d == 0) return h[n[cell]];
        sum_w += 1 / d;
        sum_wh += h[n[cell]] / d;
      }
      return sum_wh / sum_w;
    };
    const auto growth = propagate_seeds(g, pts, [&](Index p, const Vec3& x) { return h[p] + rate * norm(x - pts[p]); });
    double sum = 0;
    std::size_t count = 0;
    for (int k = 0; k < g.n[2]; ++k) {
      for (int j = 0; j < g.n[1]; ++j) {
        for (int i = 0; i < g.n[0]; ++i) {
          const std::size_t cell = g.index(i, j, k);
          if (!inside[cell]) continue;
          const Index q = growth[cell];
          const double gx = h[q] + rate * norm(g.centre(i, j, k) - pts[q]);
          sum += density(std::clamp(std::min(interpolated(cell, g.centre(i, j, k)), gx), lo, hi));
          ++count;
        }
      }
    }
    if (count == 0) {  // thinner than a cell: the density at the boundary
      for (double v : h) sum += density(v);
      count = h.size();
    }
    mean_density = sum / static_cast<double>(count);
  }
  e.tets = e.volume * mean_density;
  e.mean_h = mean_density > 0 ? std::cbrt(density(1.0) / mean_density) : 0;
  e.peak_bytes = kPeakBytesFixed + kPeakBytesPerTet * e.tets;
  return e;
}

double smallest_size_for(double volume, double max_tets) {
  if (!(volume > 0) || !(max_tets > 0)) return 0;
  const double h = std::cbrt(density(1.0) * volume / max_tets);
  const double unit = std::pow(10.0, std::floor(std::log10(h)) - 1);  // two significant digits
  return std::ceil(h / unit * (1 - 1e-12)) * unit;
}

double available_memory_bytes() {
  double available = 0;
  std::ifstream meminfo("/proc/meminfo");
  std::string key;
  double kb = 0;
  std::string unit;
  while (meminfo >> key >> kb >> unit) {
    if (key == "MemAvailable:") {
      available = kb * 1024.0;
      break;
    }
  }
  if (available <= 0) {
    const long pages = sysconf(_SC_AVPHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    if (pages > 0 && page > 0) available = static_cast<double>(pages) * static_cast<double>(page);
  }
  // A cgroup (container) memory limit below the machine's memory is the real one.
  std::ifstream max_file("/sys/fs/cgroup/memory.max"), current_file("/sys/fs/cgroup/memory.current");
  double cg_max = 0, cg_current = 0;
  if (max_file >> cg_max && current_file >> cg_current && cg_max > cg_current) {
    available = available > 0 ? std::min(available, cg_max - cg_current) : cg_max - cg_current;
  }
  return available;
}

double tets_for_bytes(double bytes) { return std::max(0.0, (bytes - kPeakBytesFixed) / kPeakBytesPerTet); }

double default_max_tets() { return tets_for_bytes(available_memory_bytes()); }

Status check_tet_limit(const MeshEstimate& estimate, const SizingOptions& options, double max_tets,
                       std::string_view limit_source) {
  if (!(estimate.tets > max_tets)) return Status::ok_status();
  const std::string what = options.size ? fmt::format("--size {:g}", *options.size) : std::string("the default sizing");
  return invalid_input(fmt::format(
      "{} would make about {:.2g} tets (about {:.2g} bytes); the limit is {} tets ({}); use --size {:.2g} or larger",
      what, estimate.tets, estimate.peak_bytes, with_thousands(max_tets), limit_source,
      smallest_size_for(estimate.volume, max_tets)));
}

}  // namespace pdrmesh
