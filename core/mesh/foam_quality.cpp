// SPDX-License-Identifier: AGPL-3.0-or-later
#include "pdrmesh/foam_quality.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>

namespace pdrmesh {
namespace {

constexpr double kDegreesPerRadian = 180.0 / std::numbers::pi;
// OpenFOAM's guards: ROOTVSMALL keeps divisions finite, `small` is the cosine
// at or below which a face counts as a non-orthogonality error.
constexpr double kRootVSmall = 1e-150;
constexpr double kSmall = 1e-15;
const double kCos70 = std::cos(70.0 / kDegreesPerRadian);

Vec3 tet_centroid(std::span<const Vec3> p, const Tet& t) {
  Vec3 c{0, 0, 0};
  for (Index v : t) c = c + p[v];
  return 0.25 * c;
}

// checkMesh's skewness of a face with centroid fc, area vector s and points f,
// seen from the cell centre `own` along d (to the neighbour, or the mirror
// image), with the normalising floor `floor_share` * |d|.
double face_skewness(std::span<const Vec3> p, const Tri& f, const Vec3& fc, const Vec3& s, const Vec3& own,
                const Vec3& d, double floor_share) {
  const Vec3 cpf = fc - own;
  const Vec3 sv = cpf - (dot(s, cpf) / (dot(s, d) + kRootVSmall)) * d;
  const Vec3 sv_hat = (1.0 / (norm(sv) + kRootVSmall)) * sv;
  double fd = floor_share * norm(d) + kRootVSmall;
  for (Index v : f) fd = std::max(fd, std::abs(dot(sv_hat, p[v] - fc)));
  return norm(sv) / fd;
}

}  // namespace

FoamQuality measure_foam_quality(std::span<const Vec3> points, std::span<const Tet> tets, const CellFaces& faces) {
  FoamQuality q;
  q.internal_faces = faces.internal();
  q.boundary_faces = faces.faces.size() - faces.internal();
  double min_cos = 1.0, sum_cos = 0.0;
  for (std::size_t i = 0; i < faces.faces.size(); ++i) {
    const Tri& f = faces.faces[i];
    const Vec3& a = points[f[0]];
    const Vec3& b = points[f[1]];
    const Vec3& c = points[f[2]];
    const Vec3 fc = (1.0 / 3.0) * (a + b + c);
    const Vec3 s = 0.5 * cross(b - a, c - a);
    const Vec3 own = tet_centroid(points, tets[faces.owner[i]]);
    if (i < faces.internal()) {
      const Vec3 d = tet_centroid(points, tets[faces.neighbour[i]]) - own;
      const double cosine = dot(d, s) / (norm(d) * norm(s) + kRootVSmall);
      min_cos = std::min(min_cos, cosine);
      sum_cos += cosine;
      if (cosine < kCos70) ++q.faces_over_70;
      if (cosine <= kSmall) ++q.faces_over_90;
      q.max_skewness = std::max(q.max_skewness, face_skewness(points, f, fc, s, own, d, 0.2));
    } else {
      const Vec3 n = (1.0 / (norm(s) + kRootVSmall)) * s;
      const Vec3 d = dot(n, fc - own) * n;
      q.max_skewness = std::max(q.max_skewness, face_skewness(points, f, fc, s, own, d, 0.4));
    }
  }
  if (q.internal_faces > 0) {
    const auto angle = [](double cosine) { return std::acos(std::clamp(cosine, -1.0, 1.0)) * kDegreesPerRadian; };
    q.max_non_orthogonality = angle(min_cos);
    q.mean_non_orthogonality = angle(sum_cos / static_cast<double>(q.internal_faces));
  }
  return q;
}

Result<FoamQuality> measure_foam_quality(const VolumeMesh& mesh) {
  PDR_ASSIGN_OR_RETURN(const CellFaces faces, cell_faces(mesh.tets, mesh.points.size()));
  return measure_foam_quality(mesh.points, mesh.tets, faces);
}

std::string format_foam_quality(const FoamQuality& q) {
  return fmt::format(
      "OpenFOAM (checkMesh): non-orthogonality max {:.2f} mean {:.2f} degrees, {} of {} internal faces over 70{}; "
      "max skewness {:.3f}\n",
      q.max_non_orthogonality, q.mean_non_orthogonality, q.faces_over_70, q.internal_faces,
      q.faces_over_90 > 0 ? fmt::format(" ({} at 90 or more)", q.faces_over_90) : std::string(), q.max_skewness);
}

std::string foam_quality_to_json(const FoamQuality& q) {
  const nlohmann::json j = {{"internal_faces", q.internal_faces},
                            {"boundary_faces", q.boundary_faces},
                            {"max_non_orthogonality", q.max_non_orthogonality},
                            {"mean_non_orthogonality", q.mean_non_orthogonality},
                            {"faces_over_70", q.faces_over_70},
                            {"faces_over_90", q.faces_over_90},
                            {"max_skewness", q.max_skewness}};
  return j.dump();
}

}  // namespace pdrmesh
