// SPDX-License-Identifier: AGPL-3.0-or-later
// Local reconnection: flips 2-3, 3-2, 4-4 and general edge removal, each taking
// the quality criterion that decides whether to replace the old tets by the new
// (see Criterion); by default AFLR's min-max rule (MaxDihedral): accepted only
// when the worst largest dihedral angle of the replaced tets drops.
//
// Decisions: every new tet must be positive by exact::orient3d (no epsilon).
// Measurements: dihedral angles in doubles. A flip never touches a frozen face:
// a frozen face is never removed, and an edge on a frozen face is never removed.
#pragma once

#include <algorithm>
#include <array>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>
#include <string_view>
#include <utility>

#include "pdrmesh/predicates.hpp"
#include "pdrmesh/tet_mesh.hpp"
#include "pdrmesh/topology.hpp"
#include "pdrmesh/types.hpp"

namespace pdrmesh {

/// What a local operation (a flip here; an insertion, removal, collapse or move
/// in the optimizer) did. Only kDone changes the mesh; the others are expected,
/// ordinary answers ("declined"), never errors.
enum class Outcome : std::uint8_t {
  kDone,           ///< done; a flip's new tets are mesh.last_created()
  kNotBetter,      ///< declined: no candidate is strictly better (some may also invert)
  kConstrained,    ///< declined: a frozen, hull or region face, or a fixed point, is in the way
  kWouldInvert,    ///< declined: every candidate has a tet with orient3d <= 0 (flip23
                   ///< checks orientation before quality, so this takes precedence)
  kNotApplicable,  ///< declined: the configuration does not fit (hull face or
                   ///< edge, dead tet, wrong ring size, ring longer than kMaxRemovalRing)
  kTooClose,       ///< declined: a new point would lie too close to another (insertion)
};
/// The number of Outcome values (for counts indexed by outcome).
inline constexpr std::size_t kOutcomeCount = static_cast<std::size_t>(Outcome::kTooClose) + 1;
/// The flips' name for Outcome.
using FlipOutcome = Outcome;
std::string_view to_string(Outcome o);

/// Cosine of the largest interior dihedral angle of tet (a, b, c, d): the flip
/// criterion (higher is better; 1 > regular tet's 1/3 > ... > -1 for a flat one).
/// Only meaningful for positive tets.
double max_dihedral_cosine(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);

/// max_dihedral_cosine of tet k of `mesh`, evaluated in a canonical vertex
/// order so that the value depends on the vertex set only (which makes repeated
/// flipping terminate: the same tet always measures the same).
double tet_quality(const TetMesh& mesh, const Tet& k);

/// A quality criterion: how a local operation that replaces the tets `old` by
/// new ones decides. The operation checks validity itself (every new tet
/// positive by exact::orient3d, no frozen face removed, one region) and asks the
/// criterion, in this order:
///   bar(old)        once: every new tet's score must lie strictly above it;
///   score(k)        the score of the positive new tet k (higher is better);
///   accepts(fresh)  the last word on the chosen new tets (e.g. floors per class);
///   done(created, scores)  after the replacement, with the new tets' slots.
/// A criterion is a small final class taken by reference, so that its rule
/// inlines into the operation's search.
template <class C>
concept Criterion = requires(C& c, std::span<const Index> old, const Tet& k, std::span<const Tet> fresh,
                             std::span<const Index> created, std::span<const double> scores) {
  { c.bar(old) } -> std::convertible_to<double>;
  { c.score(k) } -> std::convertible_to<double>;
  { c.accepts(fresh) } -> std::convertible_to<bool>;
  c.done(created, scores);
};

/// AFLR's min-max rule, the flips' default: a tet scores tet_quality (through
/// the mesh's cache, TetMesh::cached_quality); the new tets must all beat the
/// old ones' worst, or min(that worst, floor) when a floor is given
/// (remove_long_edge: a flip may lower the local worst down to the floor).
class MaxDihedral final {
 public:
  explicit MaxDihedral(TetMesh& mesh, double floor = std::numeric_limits<double>::infinity())
      : mesh_(mesh), floor_(floor) {}
  double bar(std::span<const Index> old) const;
  double score(const Tet& k) const { return tet_quality(mesh_, k); }
  bool accepts(std::span<const Tet>) const { return true; }
  /// Caches the new tets' scores (TetMesh::set_cached_quality).
  void done(std::span<const Index> created, std::span<const double> scores) const;

 private:
  TetMesh& mesh_;
  double floor_;
};

/// Edge removal's default restriction on the ring's triangulations: none.
struct AnyTriangulation {
  bool operator()(const EdgeRing&, int, int, int) const { return false; }
};

/// Longest ring remove_edge handles (Klincsek's O(n^3) triangulation search).
inline constexpr int kMaxRemovalRing = 8;

/// The ring of the edge e of tet t when edge removal may replace its tets:
/// kDone (used here as "removable") with r holding the closed ring of
/// 3..kMaxRemovalRing tets (exactly `required` when it is not 0), or why not:
/// kNotApplicable (dead tet, hull face or edge, ring size), kConstrained (a
/// frozen face on the edge, or tets of different regions).
FlipOutcome removable_edge_ring(const TetMesh& mesh, Index t, int e, int required, EdgeRing& r);

/// A triangulation of an edge ring's polygon, as new tets (see best_ring_triangulation).
struct RingTriangulation {
  static constexpr int kMaxTets = 2 * (kMaxRemovalRing - 2);
  int count = 0;                          ///< new tets, 2 (n - 2); 0 when none was found
  std::array<Tet, kMaxTets> tets;         ///< the first `count` are set
  std::array<double, kMaxTets> quality;   ///< quality() of each new tet
  bool pruned = false;  ///< a candidate was declined by `floor` or `excluded` (not only for inverting)
};

/// Klincsek's O(n^3) search over the triangulations of the polygon r.ring[0..n)
/// (n = r.size <= kMaxRemovalRing) of a closed edge ring: the one maximising
/// the smallest quality of its new tets. Triangle (i, k, j), i < k < j, yields
/// the tets (ring[i], ring[k], ring[j], b) and (ring[k], ring[i], ring[j], a).
/// `quality(const Tet&) -> double` is the objective; it returns -infinity for
/// a tet that is not positive (exact::orient3d) and is called only where the
/// tet could still win. A tet whose quality is <= `floor` and a triangle for
/// which `excluded(i, k, j)` holds are never used (both set out.pruned).
/// Returns whether a triangulation survived (then out.count = 2 (n - 2), the
/// tets in a fixed order, and every quality > floor). The one search behind
/// every edge removal (remove_edge with any criterion): a template so that
/// the objective inlines into the loop.
template <class Quality, class Excluded>
bool best_ring_triangulation(const EdgeRing& r, double floor, Quality&& quality, Excluded&& excluded,
                             RingTriangulation& out) {
  constexpr double kInvalid = -std::numeric_limits<double>::infinity();
  constexpr double kEmpty = std::numeric_limits<double>::infinity();
  constexpr int kM = kMaxRemovalRing;
  const int n = r.size;
  const Index a = r.a, b = r.b;
  const auto& p = r.ring;
  out.count = 0;
  out.pruned = false;
  // A candidate's quality, kInvalid when not positive or (pruned) not above floor.
  const auto candidate = [&](const Tet& k) {
    const double q = quality(k);
    if (q == kInvalid) return kInvalid;
    if (q <= floor) {
      out.pruned = true;
      return kInvalid;
    }
    return q;
  };
  // best[i][j]: the best smallest quality over triangulations of the
  // sub-polygon ring[i..j]; filled before read (left uninitialised on purpose).
  using Table = std::array<std::array<double, kM>, kM>;
  Table best, quality_b, quality_a;
  std::array<std::array<int, kM>, kM> apex;
  for (int i = 0; i + 1 < n; ++i) best[i][i + 1] = kEmpty;
  for (int len = 2; len < n; ++len) {
    for (int i = 0; i + len < n; ++i) {
      const int j = i + len;
      best[i][j] = kInvalid;
      apex[i][j] = -1;
      for (int k = i + 1; k < j; ++k) {
        double v = std::min(best[i][k], best[k][j]);
        if (v <= best[i][j]) continue;  // cannot win; skip the predicates
        if (excluded(i, k, j)) {
          out.pruned = true;  // declined as a shape: "not better", not "would invert"
          continue;
        }
        const double qb = candidate({p[i], p[k], p[j], b});
        v = std::min(v, qb);
        if (v <= best[i][j]) continue;
        const double qa = candidate({p[k], p[i], p[j], a});
        v = std::min(v, qa);
        if (v > best[i][j]) {
          best[i][j] = v;
          apex[i][j] = k;
          quality_b[i][j] = qb;
          quality_a[i][j] = qa;
        }
      }
    }
  }
  if (best[0][n - 1] == kInvalid) return false;
  std::array<std::array<int, 2>, kM> stack{};
  int top = 0;
  stack[top++] = {0, n - 1};
  while (top > 0) {
    const auto [i, j] = stack[--top];
    if (j - i < 2) continue;
    const int k = apex[i][j];
    out.quality[out.count] = quality_b[i][j];
    out.tets[out.count++] = {p[i], p[k], p[j], b};
    out.quality[out.count] = quality_a[i][j];
    out.tets[out.count++] = {p[k], p[i], p[j], a};
    stack[top++] = {i, k};
    stack[top++] = {k, j};
  }
  return true;
}

namespace flips_detail {
inline bool positive(const TetMesh& m, const Tet& k) {
  return exact::orient3d(m.point(k[0]), m.point(k[1]), m.point(k[2]), m.point(k[3])) > 0;
}
}  // namespace flips_detail

/// 2-3 judged by `criterion`: removes face f of tet t (and its neighbour u),
/// replacing the two tets by three around the new edge joining their apexes.
template <Criterion C>
Outcome flip23(TetMesh& mesh, Index t, int f, C& criterion) {
  if (t >= mesh.num_slots() || !mesh.alive(t)) return Outcome::kNotApplicable;
  const Index n = mesh.neighbour(t, f);
  if (n == kNoIndex) return Outcome::kNotApplicable;
  if (mesh.frozen(t, f)) return Outcome::kConstrained;
  const Index u = face_tet(n);
  if (mesh.region(t) != mesh.region(u)) return Outcome::kConstrained;
  // Face (a, b, c) is outward from t: its apex d lies below it and u's apex e above.
  const Tet& kt = mesh.tet(t);
  const Index a = kt[topo::kFaceVertex[f][0]];
  const Index b = kt[topo::kFaceVertex[f][1]];
  const Index c = kt[topo::kFaceVertex[f][2]];
  const Index d = kt[f];
  const Index e = mesh.tet(u)[face_local(n)];
  const std::array<Tet, 3> fresh{Tet{a, b, d, e}, Tet{b, c, d, e}, Tet{c, a, d, e}};
  for (const Tet& k : fresh)
    if (!flips_detail::positive(mesh, k)) return Outcome::kWouldInvert;
  const std::array<Index, 2> old{t, u};
  const double bar = criterion.bar(old);
  std::array<double, 3> score{};
  for (std::size_t j = 0; j < 3; ++j) {
    score[j] = criterion.score(fresh[j]);
    if (!(score[j] > bar)) return Outcome::kNotBetter;
  }
  if (!criterion.accepts(fresh)) return Outcome::kNotBetter;
  const std::array<Index, 3> parent{0, 0, 0};
  mesh.replace_cavity(old, fresh, parent);
  criterion.done(mesh.last_created(), score);
  return Outcome::kDone;
}

/// Edge removal of a ring removable_edge_ring found: its tets become the
/// triangulation of the ring polygon whose smallest score is best
/// (best_ring_triangulation), over the triangulations for which
/// `excluded(ring, i, k, j)` holds for no triangle.
template <Criterion C, class Excluded = AnyTriangulation>
Outcome replace_ring(TetMesh& mesh, const EdgeRing& r, C& criterion, Excluded&& excluded = {}) {
  const auto old = std::span<const Index>(r.tets.data(), static_cast<std::size_t>(r.size));
  const double bar = criterion.bar(old);
  RingTriangulation best;
  const bool found = best_ring_triangulation(
      r, bar,
      [&](const Tet& k) {
        return flips_detail::positive(mesh, k) ? static_cast<double>(criterion.score(k))
                                               : -std::numeric_limits<double>::infinity();
      },
      [&](int i, int k, int j) { return excluded(r, i, k, j); }, best);
  // No candidate survived: some tet was merely not better, or every one inverted.
  if (!found) return best.pruned ? Outcome::kNotBetter : Outcome::kWouldInvert;
  const auto c = static_cast<std::size_t>(best.count);
  const auto fresh = std::span<const Tet>(best.tets.data(), c);
  if (!criterion.accepts(fresh)) return Outcome::kNotBetter;
  std::array<Index, RingTriangulation::kMaxTets> parent{};
  mesh.replace_cavity(old, fresh, std::span<const Index>(parent.data(), c));
  criterion.done(mesh.last_created(), std::span<const double>(best.quality.data(), c));
  return Outcome::kDone;
}

/// Edge removal judged by `criterion`: the tets around edge e of tet t (a
/// closed ring of 3..kMaxRemovalRing, exactly `required` when it is not 0)
/// are replaced as replace_ring does.
template <Criterion C, class Excluded = AnyTriangulation>
Outcome remove_edge(TetMesh& mesh, Index t, int e, C& criterion, Excluded&& excluded = {}, int required = 0) {
  EdgeRing r;
  if (const Outcome why = removable_edge_ring(mesh, t, e, required, r); why != Outcome::kDone) return why;
  return replace_ring(mesh, r, criterion, std::forward<Excluded>(excluded));
}

/// The operations with the default criterion (MaxDihedral).
///
/// 2-3: removes face f of tet t (and its neighbour u), replacing the two tets
/// by three around the new edge joining their apexes.
FlipOutcome flip23(TetMesh& mesh, Index t, int f);

/// 3-2: removes edge e of tet t when exactly three tets surround it.
FlipOutcome flip32(TetMesh& mesh, Index t, int e);

/// 4-4: removes edge e of tet t when exactly four tets surround it, choosing the
/// better of the two diagonals of the ring.
FlipOutcome flip44(TetMesh& mesh, Index t, int e);

/// Flips read and fill the mesh's per-tet quality cache (TetMesh::cached_quality).
///
/// Edge removal for any interior edge with 3..kMaxRemovalRing tets around it:
/// n tets become 2(n-2), over the triangulation of the ring that maximises the
/// smallest max_dihedral_cosine (dynamic programming over the ring polygon).
FlipOutcome remove_edge(TetMesh& mesh, Index t, int e);

/// Edge removal that shortens: like remove_edge, but accepted when every new
/// tet's quality is above min(floor, the old tets' worst) (so a flip may lower
/// the local worst as long as it stays above `floor`), and only over
/// triangulations of the ring whose new edges are all strictly shorter than the
/// removed one (so repeated use ends: the multiset of edge lengths falls).
/// The refiner removes over-long edges with it. kNotApplicable for a NaN floor.
FlipOutcome remove_long_edge(TetMesh& mesh, Index t, int e, double floor);

}  // namespace pdrmesh
