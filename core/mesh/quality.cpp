// SPDX-License-Identifier: AGPL-3.0-or-later
#include "pdrmesh/quality.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <nlohmann/json.hpp>
#include <numbers>
#include <span>
#include <utility>
#include <vector>

#include <oneapi/tbb/parallel_for.h>

#include "pdrmesh/fixed_chunks.hpp"
#include "pdrmesh/topology.hpp"

namespace pdrmesh {
namespace {

constexpr double kDegrees = 180.0 / std::numbers::pi;

/// The dihedral angle, in degrees, whose outward face normals have this cosine.
double angle_of_cosine(double cosine) { return 180.0 - std::acos(cosine) * kDegrees; }

double angle_between_normals(const Vec3& n1, const Vec3& n2) {
  // Interior dihedral angle = pi - angle between the two outward face normals.
  const double l = norm(n1) * norm(n2);
  if (l == 0.0) return 0.0;
  return angle_of_cosine(std::clamp(dot(n1, n2) / l, -1.0, 1.0));
}

/// The outward normals (for a positive tet; unnormalised) of the faces
/// opposite a, b, c, d (see dihedral_angles) and their lengths.
struct FaceNormals {
  std::array<Vec3, 4> n;
  std::array<double, 4> len;
};
FaceNormals face_normals(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  FaceNormals f{{cross(c - b, d - b), cross(d - a, c - a), cross(b - a, d - a), cross(c - a, b - a)}, {}};
  for (int i = 0; i < 4; ++i) f.len[i] = norm(f.n[i]);
  return f;
}
/// The two faces (by opposite vertex) at each of the six edges.
constexpr int kEdgeFaces[6][2] = {{2, 3}, {1, 3}, {1, 2}, {0, 3}, {0, 2}, {0, 1}};

/// The 10-degree histogram bin of an angle (the last bin takes 170 to 180).
std::size_t bin_of_angle(double angle) {
  return std::min<std::size_t>(17, static_cast<std::size_t>(std::max(0.0, angle) / 10.0));
}

/// The bins by cosine, without an arc cosine per angle: thresholds[k - 1] is
/// the smallest double cosine whose angle falls in bin k or above, found by
/// bisection over the doubles in [-1, 1] with the very expressions above, so
/// bin(c) = bin_of_angle(angle_of_cosine(c)) for every c (both rise with c).
class CosineBins {
 public:
  CosineBins() {
    // Doubles in [-1, 1] as integers in the same order.
    const auto order = [](double d) {
      const auto b = std::bit_cast<std::int64_t>(d);
      return b >= 0 ? b : std::numeric_limits<std::int64_t>::min() - b;
    };
    const auto value = [](std::int64_t o) {
      return std::bit_cast<double>(o >= 0 ? o : std::numeric_limits<std::int64_t>::min() - o);
    };
    for (std::size_t k = 1; k <= 17; ++k) {
      std::int64_t below = order(-1.0), at = order(1.0);  // bin(-1) = 0 < k <= 17 = bin(1)
      while (at - below > 1) {
        const std::int64_t mid = below + (at - below) / 2;
        (bin_of_angle(angle_of_cosine(value(mid))) >= k ? at : below) = mid;
      }
      thresholds_[k - 1] = value(at);
    }
  }
  std::size_t operator()(double cosine) const {
    std::size_t bin = 0;  // a count without branches: the bins are as likely as the angles
    for (const double t : thresholds_) bin += cosine >= t ? 1 : 0;
    return bin;
  }

 private:
  std::array<double, 17> thresholds_{};
};

}  // namespace

std::array<double, 6> dihedral_angles(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  // Outward normals (for a positive tet) of the faces opposite a, b, c, d. Face
  // bcd: (a,b,c,d) -> (b,c,d,a) is odd, so a lies below (c-b)x(d-b); face acd:
  // (a,c,d,b) is even, so b lies above (c-a)x(d-a) and outward is the reverse;
  // face abd: odd; face abc: d lies above (b-a)x(c-a), outward is the reverse.
  const Vec3 na = cross(c - b, d - b);
  const Vec3 nb = cross(d - a, c - a);
  const Vec3 nc = cross(b - a, d - a);
  const Vec3 ndo = cross(c - a, b - a);
  // The edge xy is shared by the faces opposite the two other vertices.
  return {angle_between_normals(nc, ndo),   // ab: faces opposite c and d
          angle_between_normals(nb, ndo),   // ac
          angle_between_normals(nb, nc),    // ad
          angle_between_normals(na, ndo),   // bc
          angle_between_normals(na, nc),    // bd
          angle_between_normals(na, nb)};   // cd
}

namespace {

/// The extreme cosines of a tet's six pairs of outward face normals, and
/// how many pairs have a degenerate face (an angle of 0 there).
struct CosineRange {
  double lo = 2.0, hi = -2.0;
  int flat = 0;
  /// The extreme dihedral angles: the angle rises with the cosine, so these
  /// are the extremes of dihedral_angles, with two arc cosines instead of six.
  AngleRange angles() const {
    if (hi < -1.0) return {0.0, 0.0};  // every face degenerate
    return {flat > 0 ? 0.0 : angle_of_cosine(lo), angle_of_cosine(hi)};
  }
};

/// The six cosines, as angle_between_normals computes them: on_cosine(c) for
/// each (skipped at a degenerate face), and their range.
template <class OnCosine>
CosineRange edge_cosines(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d, OnCosine&& on_cosine) {
  const auto [n, len] = face_normals(a, b, c, d);
  CosineRange r;
  for (const auto& [i, j] : kEdgeFaces) {
    const double l = len[i] * len[j];
    if (l == 0.0) {
      ++r.flat;
      continue;
    }
    const double cosine = std::clamp(dot(n[i], n[j]) / l, -1.0, 1.0);
    r.lo = std::min(r.lo, cosine);
    r.hi = std::max(r.hi, cosine);
    on_cosine(cosine);
  }
  return r;
}

}  // namespace

AngleRange dihedral_range(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  return edge_cosines(a, b, c, d, [](double) {}).angles();
}

DihedralBounds::DihedralBounds(double min, double max)
    // The angle is 180 - acos(cosine), cosine that of the outward face normals:
    // under min where the cosine is under -cos(min), over max where it is over -cos(max).
    : flat_is_outside_(min > 0), below_(-std::cos(min / kDegrees)), above_(-std::cos(max / kDegrees)) {}

bool DihedralBounds::outside(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) const {
  const auto [n, len] = face_normals(a, b, c, d);
  for (const auto& [i, j] : kEdgeFaces) {
    const double l = len[i] * len[j];
    if (l == 0.0) {
      if (flat_is_outside_) return true;
      continue;
    }
    const double x = dot(n[i], n[j]);
    if (x < below_ * l || x > above_ * l) return true;
  }
  return false;
}

double verdict_shape(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  const Vec3 u = b - a, v = c - a, w = d - a;
  const double jacobian = dot(u, cross(v, w));
  if (jacobian <= 0.0) return 0.0;
  const double num = 3.0 * std::cbrt(2.0 * jacobian * jacobian);
  const double den = 1.5 * (dot(u, u) + dot(v, v) + dot(w, w)) - dot(u, v) - dot(u, w) - dot(v, w);
  return den > 0.0 ? num / den : 0.0;
}

double verdict_relative_size_squared(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d,
                                     double average_volume) {
  const double vol = signed_volume(a, b, c, d);
  if (vol <= 0.0 || average_volume <= 0.0) return 0.0;
  const double r = vol / average_volume;
  const double m = std::min(r, 1.0 / r);
  return m * m;
}

std::vector<double> min_dihedral_per_tet(const VolumeMesh& mesh) {
  std::vector<double> out(mesh.tets.size());
  const auto& p = mesh.points;
  tbb::parallel_for(std::size_t{0}, mesh.tets.size(), [&](std::size_t t) {
    const Tet& k = mesh.tets[t];
    out[t] = dihedral_range(p[k[0]], p[k[1]], p[k[2]], p[k[3]]).min;
  });
  return out;
}

namespace {

/// Per point: on a face that only one tet has (the hull). Faces bucketed by
/// their smallest point (fixed_chunks.hpp), the buckets in parallel; a hull
/// face marks its points with idempotent stores.
std::vector<char> hull_points(const VolumeMesh& mesh) {
  std::vector<char> on(mesh.points.size(), 0);
  const detail::Buckets<detail::FaceRef> faces = detail::faces_by_smallest_point(mesh.tets, mesh.points.size());
  tbb::parallel_for(std::size_t{0}, mesh.points.size(), [&](std::size_t a) {
    detail::for_each_face_group(faces, a, [&](std::span<const detail::FaceRef> group) {
      if (group.size() != 1) return;
      for (Index v : topo::face_of(mesh.tets[group[0].tet], static_cast<int>(group[0].slot)))
        std::atomic_ref<char>(on[v]).store(1, std::memory_order_relaxed);
    });
  });
  return on;
}

/// The figures of one block of tets, summed in tet order.
struct BlockFigures {
  double volume = 0;
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  std::array<std::size_t, 18> histogram{};
  std::size_t below = 0, above = 0, interior = 0;
  double interior_lo = 180.0, interior_hi = 0.0;
  double min_shape = std::numeric_limits<double>::infinity();
  double min_shape_and_size = std::numeric_limits<double>::infinity();
  double shape_sum = 0, shape_size_sum = 0;
};

}  // namespace

QualityReport measure_quality(const VolumeMesh& mesh, bool interior) {
  QualityReport q;
  q.tets = mesh.tets.size();
  q.points = mesh.points.size();
  if (mesh.tets.empty()) return q;
  const auto& p = mesh.points;
  // Blocks of a fixed size, each summed in tet order and the blocks combined
  // in order: the report is the same bit for bit whatever the thread count.
  constexpr std::size_t kBlock = 1 << 16;
  const std::size_t blocks = (mesh.tets.size() + kBlock - 1) / kBlock;
  const auto block_range = [&](std::size_t b) {
    return std::pair{b * kBlock, std::min(mesh.tets.size(), (b + 1) * kBlock)};
  };
  std::vector<double> block_volume(blocks, 0.0);
  tbb::parallel_for(std::size_t{0}, blocks, [&](std::size_t b) {
    const auto [first, last] = block_range(b);
    for (std::size_t t = first; t < last; ++t) {
      const Tet& k = mesh.tets[t];
      block_volume[b] += signed_volume(p[k[0]], p[k[1]], p[k[2]], p[k[3]]);
    }
  });
  for (double v : block_volume) q.volume += v;
  const double average_volume = q.volume / static_cast<double>(q.tets);

  q.interior_measured = interior;
  const std::vector<char> on_hull = interior ? hull_points(mesh) : std::vector<char>();
  std::vector<BlockFigures> figures(blocks);
  static const CosineBins bins;
  tbb::parallel_for(std::size_t{0}, blocks, [&](std::size_t b) {
    BlockFigures& f = figures[b];
    const auto [first, last] = block_range(b);
    for (std::size_t t = first; t < last; ++t) {
      const Tet& k = mesh.tets[t];
      const Vec3 &a = p[k[0]], &bb = p[k[1]], &c = p[k[2]], &d = p[k[3]];
      // The six angles binned by their cosines (a degenerate face's angle, 0,
      // in the first bin), and the extremes from the extreme cosines.
      const CosineRange range = edge_cosines(a, bb, c, d, [&](double cosine) { ++f.histogram[bins(cosine)]; });
      f.histogram[0] += static_cast<std::size_t>(range.flat);
      double lo = range.flat > 0 ? 0.0 : 180.0, hi = 0.0;  // the minimum and maximum of the six
      if (range.hi >= -1.0) {
        lo = std::min(lo, angle_of_cosine(range.lo));
        hi = std::max(hi, angle_of_cosine(range.hi));
      }
      f.lo = std::min(f.lo, lo);
      f.hi = std::max(f.hi, hi);
      if (interior && !on_hull[k[0]] && !on_hull[k[1]] && !on_hull[k[2]] && !on_hull[k[3]]) {
        ++f.interior;
        f.interior_lo = std::min(f.interior_lo, lo);
        f.interior_hi = std::max(f.interior_hi, hi);
      }
      f.below += lo < 10.0;
      f.above += hi > 165.0;
      const double shape = verdict_shape(a, bb, c, d);
      const double shape_size = shape * verdict_relative_size_squared(a, bb, c, d, average_volume);
      f.min_shape = std::min(f.min_shape, shape);
      f.min_shape_and_size = std::min(f.min_shape_and_size, shape_size);
      f.shape_sum += shape;
      f.shape_size_sum += shape_size;
    }
  });
  q.min_dihedral = q.min_shape = q.min_shape_and_size = std::numeric_limits<double>::infinity();
  q.max_dihedral = -std::numeric_limits<double>::infinity();
  std::size_t below = 0, above = 0;
  double shape_sum = 0, shape_size_sum = 0, interior_lo = 180.0, interior_hi = 0.0;
  for (const BlockFigures& f : figures) {
    q.min_dihedral = std::min(q.min_dihedral, f.lo);
    q.max_dihedral = std::max(q.max_dihedral, f.hi);
    for (std::size_t i = 0; i < f.histogram.size(); ++i) q.histogram[i] += f.histogram[i];
    q.interior_tets += f.interior;
    interior_lo = std::min(interior_lo, f.interior_lo);
    interior_hi = std::max(interior_hi, f.interior_hi);
    below += f.below;
    above += f.above;
    q.min_shape = std::min(q.min_shape, f.min_shape);
    q.min_shape_and_size = std::min(q.min_shape_and_size, f.min_shape_and_size);
    shape_sum += f.shape_sum;
    shape_size_sum += f.shape_size_sum;
  }
  const double n = static_cast<double>(q.tets);
  q.share_below_10 = static_cast<double>(below) / n;
  q.share_above_165 = static_cast<double>(above) / n;
  q.mean_shape = shape_sum / n;
  q.mean_shape_and_size = shape_size_sum / n;
  if (q.interior_tets > 0) {
    q.interior_min_dihedral = interior_lo;
    q.interior_max_dihedral = interior_hi;
  }
  return q;
}

std::string format_quality(const QualityReport& q) {
  std::string s = fmt::format(
      "tets {}  points {}  volume {:.6g}\n"
      "dihedral angle min {:.2f}  max {:.2f} degrees; tets under 10: {:.3f}%  over 165: {:.3f}%\n"
      "{}"
      "verdict shape min {:.4f} mean {:.4f}; shape and size min {:.4f} mean {:.4f}\n"
      "dihedral angle histogram (all angles, 10-degree bins):\n",
      q.tets, q.points, q.volume, q.min_dihedral, q.max_dihedral, 100 * q.share_below_10,
      100 * q.share_above_165,
      q.interior_measured ? fmt::format("interior tets (no hull vertex) {}: dihedral angle min {:.2f}  max {:.2f} degrees\n",
                                        q.interior_tets, q.interior_min_dihedral, q.interior_max_dihedral)
                          : std::string(),
      q.min_shape, q.mean_shape, q.min_shape_and_size,
      q.mean_shape_and_size);
  std::size_t total = 0, peak = 0;
  for (auto c : q.histogram) {
    total += c;
    peak = std::max(peak, c);
  }
  for (std::size_t i = 0; i < q.histogram.size(); ++i) {
    const auto bar = peak ? q.histogram[i] * 50 / peak : 0;
    s += fmt::format("  {:3d}-{:3d} {:>10} {:6.2f}% {}\n", 10 * i, 10 * (i + 1), q.histogram[i],
                     total ? 100.0 * static_cast<double>(q.histogram[i]) / static_cast<double>(total) : 0.0,
                     std::string(bar, '#'));
  }
  return s;
}

std::string quality_to_json(const QualityReport& q) {
  nlohmann::json j = {{"tets", q.tets},
                      {"points", q.points},
                      {"volume", q.volume},
                      {"min_dihedral", q.min_dihedral},
                      {"max_dihedral", q.max_dihedral},
                      {"dihedral_histogram_10deg", q.histogram},
                      {"share_below_10", q.share_below_10},
                      {"share_above_165", q.share_above_165},
                      {"min_shape", q.min_shape},
                      {"mean_shape", q.mean_shape},
                      {"min_shape_and_size", q.min_shape_and_size},
                      {"mean_shape_and_size", q.mean_shape_and_size}};
  if (q.interior_measured) {
    j["interior_tets"] = q.interior_tets;
    j["interior_min_dihedral"] = q.interior_min_dihedral;
    j["interior_max_dihedral"] = q.interior_max_dihedral;
  }
  return j.dump();
}

std::string quality_histogram_svg(const QualityReport& q, const std::string& title) {
  // Bars on a logarithmic count axis (from 0.5, so that a single angle shows),
  // the angle axis labelled at the bin edges, and the two tails an engineer
  // looks for (under 10 and over 165 degrees) shaded with their tet shares.
  constexpr int kW = 680, kH = 380, kLeft = 70, kRight = 20, kBottom = 46, kTop = 56;
  const int plot_h = kH - kBottom - kTop, plot_w = kW - kLeft - kRight;
  const double bin_w = plot_w / 18.0;
  std::size_t peak = 1;
  for (auto c : q.histogram) peak = std::max<std::size_t>(peak, c);
  int decades = 1;
  while (std::pow(10.0, decades) < static_cast<double>(peak)) ++decades;
  const double lo = std::log10(0.5), hi = decades;
  auto y_of = [&](double count) { return kTop + plot_h - (std::log10(count) - lo) / (hi - lo) * plot_h; };
  auto x_of = [&](double degrees) { return kLeft + degrees / 10.0 * bin_w; };
  auto escape = [](const std::string& t) {
    std::string out;
    for (char c : t) out += c == '<' ? std::string("&lt;") : c == '>' ? std::string("&gt;") : c == '&' ? std::string("&amp;") : std::string(1, c);
    return out;
  };
  std::string s = fmt::format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{}\" height=\"{}\" font-family=\"sans-serif\" font-size=\"11\">\n"
      "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
      "<text x=\"{}\" y=\"20\" font-size=\"14\">{}</text>\n"
      "<text x=\"{}\" y=\"38\">dihedral angles of {} tets: min {:.2f}, max {:.2f} degrees</text>\n",
      kW, kH, kLeft, escape(title), kLeft, q.tets, q.min_dihedral, q.max_dihedral);
  // The tails, shaded behind the bars, with their shares of the tets.
  s += fmt::format("<rect x=\"{:.1f}\" y=\"{}\" width=\"{:.1f}\" height=\"{}\" fill=\"#fbe3e1\"/>\n", x_of(0), kTop,
                   x_of(10) - x_of(0), plot_h);
  s += fmt::format("<rect x=\"{:.1f}\" y=\"{}\" width=\"{:.1f}\" height=\"{}\" fill=\"#fbe3e1\"/>\n", x_of(165), kTop,
                   x_of(180) - x_of(165), plot_h);
  s += fmt::format("<text x=\"{:.1f}\" y=\"{}\" fill=\"#a02020\">&lt; 10&#176;: {:.3f}% of tets</text>\n", x_of(0) + 3,
                   kTop + 12, 100 * q.share_below_10);
  s += fmt::format("<text x=\"{:.1f}\" y=\"{}\" fill=\"#a02020\" text-anchor=\"end\">&gt; 165&#176;: {:.3f}% of tets</text>\n",
                   x_of(180) - 3, kTop + 12, 100 * q.share_above_165);
  // Count axis: a grid line and a label per decade.
  for (int d = 0; d <= decades; ++d) {
    const double y = y_of(std::pow(10.0, d));
    const char* units[] = {"", "", "", "k", "k", "k", "M", "M", "M", "G"};
    const int shown = d < 3 ? static_cast<int>(std::pow(10.0, d)) : static_cast<int>(std::pow(10.0, d % 3));
    s += fmt::format("<line x1=\"{}\" y1=\"{:.1f}\" x2=\"{}\" y2=\"{:.1f}\" stroke=\"#dddddd\"/>\n", kLeft, y,
                     kLeft + plot_w, y);
    s += fmt::format("<text x=\"{}\" y=\"{:.1f}\" text-anchor=\"end\">{}{}</text>\n", kLeft - 6, y + 4, shown,
                     units[std::min(d, 9)]);
  }
  for (std::size_t i = 0; i < 18; ++i) {
    if (q.histogram[i] == 0) continue;
    const double y = y_of(static_cast<double>(q.histogram[i]));
    s += fmt::format("<rect x=\"{:.1f}\" y=\"{:.1f}\" width=\"{:.1f}\" height=\"{:.1f}\" fill=\"#4a78b5\"><title>{}-{} degrees: {} angles</title></rect>\n",
                     x_of(10.0 * static_cast<double>(i)) + 1, y, bin_w - 2, kTop + plot_h - y, 10 * i, 10 * (i + 1),
                     q.histogram[i]);
  }
  // Angle axis: labels at the bin edges.
  s += fmt::format("<line x1=\"{}\" y1=\"{}\" x2=\"{}\" y2=\"{}\" stroke=\"black\"/>\n", kLeft, kTop + plot_h,
                   kLeft + plot_w, kTop + plot_h);
  for (int e = 0; e <= 18; ++e) {
    const double x = x_of(10.0 * e);
    s += fmt::format("<line x1=\"{:.1f}\" y1=\"{}\" x2=\"{:.1f}\" y2=\"{}\" stroke=\"black\"/>\n", x, kTop + plot_h, x,
                     kTop + plot_h + 4);
    s += fmt::format("<text x=\"{:.1f}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n", x, kTop + plot_h + 16, 10 * e);
  }
  s += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">dihedral angle (degrees)</text>\n",
                   kLeft + plot_w / 2, kH - 8);
  s += fmt::format("<text x=\"14\" y=\"{0}\" transform=\"rotate(-90 14 {0})\" text-anchor=\"middle\">angles (log scale)</text>\n",
                   kTop + plot_h / 2);
  s += "</svg>\n";
  return s;
}

}  // namespace pdrmesh
