// SPDX-License-Identifier: AGPL-3.0-or-later
// Final optimization: reconnection, sliver removal and smoothing (optimize.hpp).
#include "pdrmesh/optimize.hpp"

#include <fmt/format.h>
#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <iterator>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <span>
#include <tuple>
#include <vector>

#include "pdrmesh/flips.hpp"
#include "pdrmesh/insert.hpp"
#include "pdrmesh/predicates.hpp"
#include "pdrmesh/quality.hpp"
#include "pdrmesh/topology.hpp"
#include "pdrmesh/stopwatch.hpp"

namespace pdrmesh {
namespace {

/// Full-mesh scans run in parallel from this many tet slots (the merged mesh);
/// below (a leaf task's mesh, already on one of the run's worker threads) they
/// stay on the calling thread, so that leaf tasks do not wake more threads.
constexpr Index kParallelTets = Index{1} << 17;

enum class Badness { kGood, kBad, kSliver };

/// The cap repair's view of a bad tet (Optimizer::cap_kind).
enum class CapKind { kNone, kCap, kFreeApex };

std::array<Vec3, 4> corners(const TetMesh& m, const Tet& k) {
  return {m.point(k[0]), m.point(k[1]), m.point(k[2]), m.point(k[3])};
}

/// Smallest scaled sine of the six dihedral angles of (p0, p1, p2, p3): sin =
/// 6V * l_e / (|n1| |n2|), with n1, n2 the unnormalised outward normals of the
/// two faces on edge e, times `acute` for an angle up to 90 degrees and
/// `obtuse` above (the angle is obtuse when n1.n2 > 0). With acute =
/// 1/sin(target_min_dihedral) and obtuse = 1/sin(180 - target_max_dihedral) it
/// is >= 1 exactly for a tet within the targets (up to rounding), and it is
/// small both for angles near 0 and near 180 degrees; negative when the tet is
/// inverted (the sign of V), 0 when a face is degenerate.
double min_sine(const std::array<Vec3, 4>& p, double acute, double obtuse) {
  const double v6 = dot(cross(p[1] - p[0], p[2] - p[0]), p[3] - p[0]);
  std::array<Vec3, 4> normal;
  std::array<double, 4> n{};
  for (int f = 0; f < 4; ++f) {
    const Vec3& a = p[topo::kFaceVertex[f][0]];
    normal[f] = cross(p[topo::kFaceVertex[f][1]] - a, p[topo::kFaceVertex[f][2]] - a);
    n[f] = norm(normal[f]);
  }
  double lowest = std::numeric_limits<double>::infinity();
  for (int e = 0; e < 6; ++e) {
    const int f0 = topo::edge_face(e, 0), f1 = topo::edge_face(e, 1);
    const double den = n[f0] * n[f1];
    if (!(den > 0.0)) return 0.0;
    const double l = norm(p[topo::kEdgeVertex[e][1]] - p[topo::kEdgeVertex[e][0]]);
    const double scale = dot(normal[f0], normal[f1]) > 0.0 ? obtuse : acute;
    lowest = std::min(lowest, scale * v6 * l / den);
  }
  return lowest;
}

/// 1 / sin(angle in degrees), capped for angles near 0 or 180 (a target of 0
/// or 180 degrees then weighs like one of about 0.06 degrees).
double inverse_sine(double degrees) {
  const double s = std::sin(degrees * (3.14159265358979323846 / 180.0));
  return s > 1e-3 ? 1.0 / s : 1e3;
}

/// Smoothing passes per sweep (each over the vertices the previous one left bad).
constexpr int kSmoothPasses = 4;
/// Share of the tets (as a count of vertices) that the smoothing passes after
/// the first may try per sweep.
constexpr double kSmoothRetries = 0.02;
constexpr std::size_t kSmoothRetriesMin = 2000;  ///< ... but at least this many
/// Most polishing rounds after the sweeps (see optimize()).
constexpr int kPolishRounds = 4;
/// Smoothing's compass search (compass_search): most rounds of 14 trial
/// steps around a point no smoothing target helped.
constexpr int kCompassRounds = 48;
/// Smoothing makes no edge off the surface shorter than this times h at its
/// midpoint (keep_edge_sizes): the lower end of the refiner issue's size band.
constexpr double kShortEdge = 0.6;
/// The upper end of that band: the size polish (polish_sizes) brings edges
/// off the surface back within [kShortEdge, kLongEdge] h.
constexpr double kLongEdge = 1.5;
/// Rounds of the size polish (one that changes nothing ends it): 6 gave
/// hinge 90.4% of its interior edges within the band at the default size
/// against 90.2% with 4 and 90.4% with 8 (`pdrmesh_bench_refine`);
/// before the splits, with the surface tets' room, 4 gave 83.0% against 81.3%
/// with 2.
constexpr int kSizeRounds = 6;
/// Where the size polish's splits try the new point along the edge, in this
/// order. hinge at the default size, interior edges within the band: the
/// midpoint alone 88.9%, 1/2, 2/5, 3/5, 3/10, 7/10 89.9% (both with 4 rounds),
/// these nine 90.4% (90.2% with 4 rounds; `pdrmesh_bench_refine`).
constexpr std::array<double, 9> kSplitAt{0.5, 0.45, 0.55, 0.4, 0.6, 0.35, 0.65, 0.3, 0.7};

/// Line-search steps towards each smoothing target: 1, 1/2, ..., 1/64.
constexpr int kLineSteps = 7;
/// Most rounds of the interior repair (see optimize.hpp). With point removal,
/// rounds 5 and 6 took the tets outside the targets at diag/100 from 883 to
/// 552 on hinge and from 87 to 42 on couplingdown, at 6% more optimization
/// time on hinge; more rounds found nothing more
/// (`pdrmesh_bench_refine`). The rounds stop early anyway where nothing falls.
constexpr int kRepairRounds = 6;
/// Interior repair: a tet with a surface point may fall to this measure (about
/// 10 degrees, or 160 on the obtuse side, at the default targets) when a
/// repair of a tet with no fixed point needs it; above it, it may not get
/// worse. Lower where the mesh holds worse tets already (Optimizer::
/// start_repair): down to kRepairFloorMargin times the measure of the mesh's
/// smallest dihedral angle.
constexpr double kRepairFloor = 0.67;
constexpr double kRepairFloorMargin = 2.0;
/// Point removal: stars of more tets than this are not tried.
constexpr std::size_t kRemovalMaxStar = 256;
/// Cap repair: heights (times h) above the kept faces at which the new point is tried.
constexpr std::array<double, 7> kCapHeights{0.1, 0.2, 0.3, 0.45, 0.6, 0.75, 0.9};
/// Cap repair: most tets in a cavity.
constexpr std::size_t kCapMaxCavity = 24;
/// Cap repair: the new point keeps at least this distance (times h) from every
/// point of its star's link that is not on the surface (a closer one makes a
/// short interior edge: primitives13 at diag/100 had 13% of its interior edges
/// under 0.6 h). Above about 0.34, sphere966's flat tets find no point.
constexpr double kCapMinSpacing = 1.0 / 3.0;
/// Cap repair of a tet with one kept face: degrees by which its star's largest
/// dihedral angle may pass the mesh's largest before the cap repair.
constexpr double kCapMaxAngleSlack = 0.5;
/// Cap repair, relaxed pass: the range (degrees) every new tet's dihedral
/// angles must lie in, whatever the cavity had. The bounds of `pdrmesh
/// quality`'s "under 10" and "over 165": next to needle triangles (hinge,
/// couplingdown) no star reaches them; a trial that accepted any star whose
/// smallest angle rose added points there (hinge +14% tets) and raised
/// couplingdown's largest angle from 173.6 to 178.8 degrees.
constexpr std::array<double, 2> kRelaxedCapAngles{10.0, 165.0};
/// Cap repair of a tet with one kept face: the smallest angle (degrees) of
/// that surface triangle. Next to a needle triangle no star is good, and the
/// repairs there only add points: hinge (needles of 0.33 degrees) got 22%
/// more tets and 37.8% of them under 10 degrees instead of 33.2% without
/// this bound; sphere966's flat tets lie on triangles of 15 degrees or more.
constexpr double kCapMinTriangleAngle = 15.0;
/// Rounds of the margin polish (polish_margins; one that moves nothing ends
/// it). With the ring's moves, hinge at diag/100 kept 231 interior tets
/// outside [15, 150] after 4 rounds, 206 after 8, 199 after 16 (1.5 CPU s more
/// than 4); couplingdown 8 after each (`pdrmesh_bench_refine`).
constexpr int kMarginRounds = 8;
/// The compass search ends when its step falls below its first step over
/// this (compass_search)...
constexpr double kSearchEnd = 64.0;
/// ... and over this in the margin polish's last pass (polish_margins): the
/// tets it leaves are often within a fraction of a degree of the targets.
/// couplingdown at diag/100 kept 2 interior tets outside [15, 150] before that
/// pass and none after, hinge 113 and 81, 65, 68 with 256, 1024, 4096
/// (`pdrmesh_bench_refine`; no measurable time). The whole margin polish
/// at 1024 instead moved hinge's count both ways (93 to 139 at 128 to 1024).
constexpr double kFineSearchEnd = 1024.0;
constexpr double kInfinity = std::numeric_limits<double>::infinity();
/// Absorption (optimize.hpp, 10.): at most this many cycles, and it stops
/// after this many in a row that leave no fewer bad tets with no fixed point
/// than the fewest so far (the count goes up and down from cycle to cycle).
constexpr int kAbsorbCycles = 10;
constexpr int kAbsorbPatience = 3;
/// Absorption: the depth of its margin polish's ring (polish_margins). hinge
/// at diag/90, /95, /100, /105, /110, interior tets outside [15, 150]: 0, 0,
/// 13, 2, 49 with one layer, 3, 0, 9, 1, 25 with two, 0, 2, 0, 0, 14 with
/// three, for up to 2.4 times the optimization time (diag/110: 31 -> 75 s;
/// `pdrmesh_bench_refine`, PDRMESH_BENCH_DIVISOR).
constexpr int kAbsorbRingLayers = 3;

/// The smallest and largest dihedral angle of the live tets, kept exact while
/// the mesh changes, at a cost proportional to the changes: a min/max tree
/// over blocks of kRangeBlock slots. A block that an operation touched (a tet
/// created in it, or one of its tets moved) is measured again before the next
/// query. A slot freed without reuse is not reported, so a block's stored
/// extremes may be more extreme than its live tets (never less): a query
/// measures again the block that holds the root's extreme until that block's
/// measure confirms it. min/max are exact, so the result does not depend on
/// the order of the updates.
class RangeTree {
 public:
  static constexpr Index kRangeBlock = 8;

  /// Measures every block (in parallel on a large mesh).
  void build(const TetMesh& m) {
    const Index blocks = (m.num_slots() + kRangeBlock - 1) / kRangeBlock;
    cap_ = 1;
    while (cap_ < blocks) cap_ *= 2;
    node_.assign(2 * static_cast<std::size_t>(cap_), kNeutral);
    is_dirty_.assign(cap_, 0);
    dirty_.clear();
    const auto scan = [&](const tbb::blocked_range<Index>& r) {
      for (Index b = r.begin(); b < r.end(); ++b) node_[cap_ + b] = measure_block(m, b);
    };
    const tbb::blocked_range<Index> all(0, blocks, 512);
    if (m.num_slots() < kParallelTets) {
      scan(all);
    } else {
      tbb::parallel_for(all, scan);
    }
    for (Index i = cap_ - 1; i >= 1; --i) pull(i);
  }

  /// Slot t holds a new tet, or one whose points moved.
  void touch(Index t) {
    const Index b = t / kRangeBlock;
    if (b >= cap_) grow(b + 1);
    if (is_dirty_[b] == 0) {
      is_dirty_[b] = 1;
      dirty_.push_back(b);
    }
  }

  AngleRange range(const TetMesh& m) {
    for (Index b : dirty_) {
      is_dirty_[b] = 0;
      set(b, measure_block(m, b));
    }
    dirty_.clear();
    for (;;) {  // the smallest: confirm the block that holds it
      Index i = 1;
      while (i < cap_) i = node_[2 * i].min == node_[i].min ? 2 * i : 2 * i + 1;
      const AngleRange r = measure_block(m, i - cap_);
      if (r.min == node_[i].min) break;
      set(i - cap_, r);
    }
    for (;;) {  // the largest likewise
      Index i = 1;
      while (i < cap_) i = node_[2 * i].max == node_[i].max ? 2 * i : 2 * i + 1;
      const AngleRange r = measure_block(m, i - cap_);
      if (r.max == node_[i].max) break;
      set(i - cap_, r);
    }
    return node_[1];
  }

 private:
  static constexpr AngleRange kNeutral{180.0, 0.0};

  static AngleRange measure_block(const TetMesh& m, Index b) {
    AngleRange r = kNeutral;
    const Index end = std::min(m.num_slots(), (b + 1) * kRangeBlock);
    for (Index t = b * kRangeBlock; t < end; ++t) {
      if (!m.alive(t)) continue;
      const auto p = corners(m, m.tet(t));
      const AngleRange a = dihedral_range(p[0], p[1], p[2], p[3]);
      r.min = std::min(r.min, a.min);
      r.max = std::max(r.max, a.max);
    }
    return r;
  }
  void pull(Index i) {
    node_[i] = {std::min(node_[2 * i].min, node_[2 * i + 1].min), std::max(node_[2 * i].max, node_[2 * i + 1].max)};
  }
  void set(Index b, AngleRange r) {
    Index i = cap_ + b;
    node_[i] = r;
    for (i /= 2; i >= 1; i /= 2) pull(i);
  }
  /// Room for `blocks` blocks: the leaves move to a tree twice as wide (or more).
  void grow(Index blocks) {
    Index cap = std::max<Index>(cap_, 1);
    while (cap < blocks) cap *= 2;
    std::vector<AngleRange> node(2 * static_cast<std::size_t>(cap), kNeutral);
    std::copy(node_.begin() + cap_, node_.begin() + 2 * cap_, node.begin() + cap);
    node_ = std::move(node);
    is_dirty_.resize(cap, 0);
    cap_ = cap;
    for (Index i = cap_ - 1; i >= 1; --i) pull(i);
  }

  Index cap_ = 0;                 ///< leaves: a power of two, at least the blocks
  std::vector<AngleRange> node_;  ///< node_[1] the root, node_[cap_ + b] block b
  std::vector<Index> dirty_;      ///< blocks to measure before the next query
  std::vector<char> is_dirty_;
};

/// The point over triangle (a, b, c), on the side of cross(b - a, c - a), at
/// `fraction` of the height of the regular tet whose edge is the triangle's
/// mean edge; the centroid when the triangle has no area.
Vec3 regular_apex(const Vec3& a, const Vec3& b, const Vec3& c, double fraction = 1.0) {
  const Vec3 n = cross(b - a, c - a);
  const double ln = norm(n);
  const Vec3 g = (1.0 / 3.0) * (a + b + c);
  if (!(ln > 0.0)) return g;
  const double edge = (norm(b - a) + norm(c - b) + norm(a - c)) / 3.0;
  return g + (fraction * std::sqrt(2.0 / 3.0) * edge / ln) * n;
}

/// The smallest angle of triangle (a, b, c), in degrees.
double smallest_angle(const Vec3& a, const Vec3& b, const Vec3& c) {
  const auto at = [](const Vec3& p, const Vec3& q, const Vec3& r) {
    const Vec3 u = q - p, v = r - p;
    return std::atan2(norm(cross(u, v)), dot(u, v)) * (180.0 / 3.14159265358979323846);
  };
  return std::min({at(a, b, c), at(b, c, a), at(c, a, b)});
}

class Optimizer {
 public:
  Optimizer(TetMesh& mesh, const SizingField* sizing, const OptimizeOptions& o, OptimizeStats& st)
      : m_(mesh),
        sizing_(sizing),
        o_(o),
        st_(st),
        acute_(inverse_sine(o.target_min_dihedral)),
        obtuse_(inverse_sine(180.0 - o.target_max_dihedral)) {}

  /// The quality that smoothing and insertion raise: min_sine scaled to the
  /// targets (>= 1 for a good tet).
  double measure(const std::array<Vec3, 4>& p) const { return min_sine(p, acute_, obtuse_); }

  /// The badness of the alive tet t, through known_ (see there).
  Badness badness(Index t) const {
    if (t >= known_.size()) known_.resize(m_.num_slots(), 0);  // never inside bad_flags' parallel scan
    unsigned char& k = known_[t];
    if (k == 0) k = static_cast<unsigned char>(1 + static_cast<int>(compute_badness(t)));
    return static_cast<Badness>(k - 1);
  }

  Badness compute_badness(Index t) const {
    const auto p = corners(m_, m_.tet(t));
    const AngleRange r = dihedral_range(p[0], p[1], p[2], p[3]);
    const bool small = r.min < o_.target_min_dihedral, large = r.max > o_.target_max_dihedral;
    if (small && large) return Badness::kSliver;
    return small || large ? Badness::kBad : Badness::kGood;
  }

  /// Per slot: 1 for a live bad tet (computed in parallel).
  std::vector<unsigned char> bad_flags() const {
    if (known_.size() < m_.num_slots()) known_.resize(m_.num_slots(), 0);
    std::vector<unsigned char> is_bad(m_.num_slots(), 0);
    const auto scan = [&](const tbb::blocked_range<Index>& r) {
      for (Index t = r.begin(); t < r.end(); ++t) is_bad[t] = m_.alive(t) && badness(t) != Badness::kGood ? 1 : 0;
    };
    const tbb::blocked_range<Index> all(0, m_.num_slots(), 4096);
    if (m_.num_slots() < kParallelTets) {
      scan(all);  // a leaf task's mesh: its worker thread is already one of the run's threads
    } else {
      tbb::parallel_for(all, scan);
    }
    return is_bad;
  }

  /// Bad live tets in slot order. The first call scans every slot (in
  /// parallel; the list does not depend on the thread count); later calls
  /// take the last list and the slots touched since (touch), as no other tet
  /// changed: the same list for the cost of the changes.
  const std::vector<Index>& bad_tets() {
    if (!bad_known_) {
      const std::vector<unsigned char> is_bad = bad_flags();
      bad_.clear();
      for (Index t = 0; t < m_.num_slots(); ++t)
        if (is_bad[t] != 0) bad_.push_back(t);
      bad_known_ = true;
      touched_.clear();
      return bad_;
    }
    if (touched_.empty()) return bad_;
    std::sort(touched_.begin(), touched_.end());
    touched_.erase(std::unique(touched_.begin(), touched_.end()), touched_.end());
    std::vector<Index> merged;
    merged.reserve(bad_.size() + touched_.size());
    std::set_union(bad_.begin(), bad_.end(), touched_.begin(), touched_.end(), std::back_inserter(merged));
    touched_.clear();
    bad_.clear();
    for (Index t : merged)
      if (m_.alive(t) && badness(t) != Badness::kGood) bad_.push_back(t);
    return bad_;
  }

  /// The mesh's extreme dihedral angles now (range_, built on first use).
  AngleRange angles() {
    if (!range_built_) {
      range_.build(m_);
      range_built_ = true;
    }
    return range_.range(m_);
  }

  /// Any live tet holding point v, or kNoIndex for a point in none: any_tet_,
  /// one scan of the mesh on first use, then kept by forget_created.
  Index any_tet(Index v) {
    if (!any_known_) {
      any_known_ = true;
      any_tet_.assign(m_.num_points(), kNoIndex);
      for (Index t = 0; t < m_.num_slots(); ++t)
        if (m_.alive(t))
          for (Index u : m_.tet(t)) any_tet_[u] = t;
    }
    if (v >= any_tet_.size()) return kNoIndex;
    const Index t = any_tet_[v];
    if (t == kNoIndex || !m_.alive(t)) return kNoIndex;  // a removed point
    for (Index u : m_.tet(t))
      if (u == v) return t;
    return kNoIndex;
  }

  /// The live tets holding point v, by a walk across the faces through v (for
  /// a free point, which lies on no kept face, all of them), appended to out.
  void star_tets(Index v, std::vector<Index>& out) {
    const Index start = any_tet(v);
    if (start == kNoIndex) return;
    const std::size_t first = out.size();
    out.push_back(start);
    for (std::size_t i = first; i < out.size(); ++i) {
      const Index t = out[i];
      const int lv = topo::local_vertex(m_.tet(t), v);
      for (int f = 0; f < 4; ++f) {
        if (f == lv) continue;
        const Index n = m_.neighbour(t, f);
        if (n == kNoIndex) continue;
        const Index u = face_tet(n);
        if (std::find(out.begin() + static_cast<std::ptrdiff_t>(first), out.end(), u) == out.end()) out.push_back(u);
      }
    }
  }

  /// The first live tet of free point v in slot order (where its star walks
  /// start: smooth, polish_angles, polish_margins, polish_sizes).
  Index first_tet(Index v) {
    walk_.clear();
    star_tets(v, walk_);
    return walk_.empty() ? kNoIndex : *std::min_element(walk_.begin(), walk_.end());
  }

  /// Runs the reconnection queue from `seeds` (processed in the given order).
  std::size_t reconnect(std::vector<Index> seeds) {
    queue_ = std::move(seeds);
    std::size_t done = 0;
    if (!o_.reconnect) return 0;
    for (std::size_t head = 0; head < queue_.size(); ++head) {
      if (flips_this_sweep_ >= flip_budget_) break;
      const Index t = queue_[head];
      if (!m_.alive(t)) continue;
      const Badness b = badness(t);
      if (b == Badness::kGood) continue;
      if (try_flips(t)) {
        ++done;
        ++flips_this_sweep_;
        if (b == Badness::kSliver) ++st_.slivers_removed;
      }
    }
    st_.flips += done;
    return done;
  }

  /// Point insertion into the slivers left in the mesh (see optimize.hpp).
  std::size_t insert_into_slivers() {
    if (sizing_ == nullptr || !o_.insert_points) return 0;
    std::vector<Index> slivers;
    for (Index t : bad_tets())
      if (badness(t) == Badness::kSliver) slivers.push_back(t);
    std::size_t inserted = 0;
    for (Index t : slivers) {
      if (!m_.alive(t) || badness(t) != Badness::kSliver) continue;  // a flip took the slot
      if (!insert_into(t)) continue;
      ++inserted;
      ++st_.slivers_removed;
      const auto created = m_.last_created();
      reconnect(std::vector<Index>(created.begin(), created.end()));
    }
    st_.points_inserted += inserted;
    return inserted;
  }

  /// Marks in fixed_ the points on a frozen, hull or region face, and in
  /// surface_ those on a boundary triangle that is not a leaf's interface
  /// (TetMesh::boundary() with a non-zero id, or any when there are no ids).
  void find_fixed() {
    // No operation of the optimizer changes which points are fixed (flips and
    // insertions refuse frozen, hull and region faces; a new point is free),
    // so the marks are found once and only grow with the points after that.
    if (fixed_known_) {
      fixed_.resize(m_.num_points(), 0);
      surface_.resize(m_.num_points(), 0);
      return;
    }
    fixed_known_ = true;
    surface_.assign(m_.num_points(), 0);
    for (std::size_t i = 0; i < m_.boundary().size(); ++i)
      if (surface_triangle(i))
        for (Index v : m_.boundary()[i]) surface_[v] = 1;
    fixed_.assign(m_.num_points(), 0);
    for (Index t = 0; t < m_.num_slots(); ++t) {
      if (!m_.alive(t)) continue;
      const Tet& k = m_.tet(t);
      for (int f = 0; f < 4; ++f)
        if (kept_face(t, f))
          for (int j = 0; j < 3; ++j) fixed_[k[topo::kFaceVertex[f][j]]] = 1;
    }
  }

  /// One smoothing pass over the free vertices of bad tets, ascending.
  std::size_t smooth() {
    find_fixed();
    const std::vector<char>& fixed = fixed_;
    std::vector<Index> bad = bad_tets();
    if (interior_only_) bad = interior(bad);
    std::vector<Index> todo, next;
    for (Index t : bad)
      for (Index v : m_.tet(t))
        if (!fixed[v]) todo.push_back(v);
    std::sort(todo.begin(), todo.end());
    todo.erase(std::unique(todo.begin(), todo.end()), todo.end());
    // Passes over the free vertices of bad tets, ascending; the next pass takes
    // the free vertices of the bad tets left in the stars of the points just
    // moved (the topology does not change here).
    // Passes after the first together try at most max(kSmoothRetriesMin,
    // kSmoothRetries * tets) vertices (where most tets are beyond repair, as next to needle
    // triangles, they would otherwise take the time of many sweeps).
    std::size_t moved = 0;
    std::size_t retries =
        std::max(kSmoothRetriesMin, static_cast<std::size_t>(kSmoothRetries * m_.num_tets()));
    for (int pass = 0; pass < kSmoothPasses && !todo.empty(); ++pass) {
      std::size_t moved_now = 0;
      next.clear();
      for (Index v : todo) {
        if (pass > 0) {
          if (retries == 0) break;
          --retries;
        }
        if (!smooth_vertex(v, first_tet(v))) continue;
        ++moved_now;
        for (const auto& s : star_)
          if (badness(s.first) != Badness::kGood)
            for (Index u : m_.tet(s.first))
              if (!fixed[u]) next.push_back(u);
      }
      moved += moved_now;
      if (moved_now == 0) break;
      std::sort(next.begin(), next.end());
      next.erase(std::unique(next.begin(), next.end()), next.end());
      std::swap(todo, next);
    }
    st_.points_moved += moved;
    return moved;
  }

  /// The tets of `tets` with no fixed point (as the last smooth() found them;
  /// points added since are free).
  std::vector<Index> interior(const std::vector<Index>& tets) const {
    std::vector<Index> out;
    for (Index t : tets) {
      bool free = true;
      for (Index v : m_.tet(t)) free = free && (v >= fixed_.size() || fixed_[v] == 0);
      if (free) out.push_back(t);
    }
    return out;
  }

  /// Restricts smooth() to the vertices of bad tets with no fixed point.
  /// With `pin` (the polishing rounds' polish_pins_fixed), smoothing also pins
  /// the tets with a fixed point (see optimize.hpp).
  void set_interior_only(bool on, bool pin = false, double pin_floor = 1.0) {
    interior_only_ = on;
    pin_fixed_ = on && pin;
    pin_floor_ = pin_floor;
  }

  /// Sets the interior repair's floor for tets with a surface point:
  /// kRepairFloor, or kRepairFloorMargin times the measure that the mesh's
  /// smallest dihedral angle (now) has on the acute side when that is lower.
  /// Next to needle triangles, where the tets on the surface are that bad
  /// anyway, the tets off it then get room to reach the targets, while no
  /// repair makes a tet near the mesh's worst. The margin leaves the cap
  /// repair and angle polish after it room too: at the worst measure itself,
  /// couplingdown's smallest angle at diag/100 fell from 0.8 to 0.4 degrees
  /// (`pdrmesh_bench_refine`).
  void start_repair() {
    const double smallest = angles().min * (3.14159265358979323846 / 180.0);
    repair_floor_ = std::min(kRepairFloor, kRepairFloorMargin * std::sin(smallest) * acute_);
  }
  double repair_floor() const { return repair_floor_; }

  /// Interior repair flips (see optimize.hpp): for each bad tet with no fixed
  /// point in `seeds` (slot order), one edge removal or 2-3 flip judged by
  /// measure() (min-max over the tets replaced) on its edges, its faces, then
  /// its face neighbours' other edges; created bad tets with no fixed point
  /// join the queue. Returns the flips done.
  std::size_t repair_flips(std::vector<Index> seeds) {
    std::size_t done = 0;
    for (std::size_t head = 0; head < seeds.size(); ++head) {
      if (flips_this_sweep_ >= flip_budget_) break;
      const Index t = seeds[head];
      if (!m_.alive(t) || badness(t) == Badness::kGood || !free_tet(t)) continue;
      if (!repair_tet(t)) continue;
      ++done;
      ++flips_this_sweep_;
      for (Index c : m_.last_created())
        if (badness(c) != Badness::kGood && free_tet(c)) seeds.push_back(c);
      if (m_.alive(t)) seeds.push_back(t);
    }
    st_.flips += done;
    st_.repair_flips += done;
    return done;
  }

  /// Absorption (optimize.hpp, 10.): repair_flips over `seeds` with the
  /// operations judged by judged()'s absorption rule, against the mesh's
  /// extremes now, no point inserted into a cavity (insert_into) and an edge
  /// collapse (collapse_edge) tried last. Returns the operations.
  std::size_t absorb(std::vector<Index> seeds) {
    find_fixed();
    mesh_angles_ = angles();
    judge_ = Judge::kAbsorb;
    const std::size_t done = repair_flips(std::move(seeds));
    judge_ = Judge::kRepair;
    st_.absorbed += done;
    return done;
  }

  /// Cap repair (optimize.hpp, 5.): one point inserted into a cavity around
  /// each cap (is_cap), worst first (insert_cap). With `relaxed` (the second
  /// pass) also around each free-apex cap (cap_kind) and each bad tet of four
  /// surface points (whatever its surface triangles), and a star is judged by
  /// kRelaxedCapAngles (cap_angles_rise). Returns the points inserted.
  std::size_t repair_caps(bool relaxed) {
    relaxed_caps_ = relaxed;
    if (sizing_ == nullptr || !o_.insert_points) return 0;
    // The surface triangles (TetMesh::boundary() with a non-zero id, or all
    // when there are no ids; not a leaf's interface), as sorted keys.
    if (!surface_keys_known_) {
      surface_keys_known_ = true;
      for (std::size_t i = 0; i < m_.boundary().size(); ++i)
        if (surface_triangle(i)) surface_keys_.push_back(topo::sorted_key(m_.boundary()[i]));
      std::sort(surface_keys_.begin(), surface_keys_.end());
    }
    const std::vector<Tri>& surface = surface_keys_;
    find_fixed();
    // Worst first (the smaller of the smallest dihedral angle and 180 - the
    // largest; ties in slot order): a cavity may swallow a worse cap next to
    // its own that a repair of that cap would fix better.
    // A slot may hold a newer tet by the time it is tried: asked again then.
    const auto eligible = [&](Index t) {
      if (!m_.alive(t) || badness(t) == Badness::kGood) return false;
      const CapKind kind = cap_kind(t, surface);
      return kind == CapKind::kCap ||
             (relaxed && (kind == CapKind::kFreeApex || all_on_surface(t)));
    };
    std::vector<std::pair<double, Index>> caps;
    for (Index t : bad_tets()) {
      if (!eligible(t)) continue;
      const auto p = corners(m_, m_.tet(t));
      const AngleRange r = dihedral_range(p[0], p[1], p[2], p[3]);
      caps.push_back({std::min(r.min, 180.0 - r.max), t});
    }
    if (caps.empty()) return 0;
    std::sort(caps.begin(), caps.end());
    cap_max_angle_ = angles().max;
    std::size_t done = 0;
    for (const auto& [worst, t] : caps)
      if (eligible(t) && insert_cap(t)) ++done;
    st_.points_inserted += done;
    st_.caps_repaired += done;
    return done;
  }

  /// Angle polish (optimize.hpp, 6.): the free points of the tets whose
  /// smallest dihedral angle is under target_min_dihedral, ascending, each
  /// once (polish_point). Returns the points moved.
  std::size_t polish_angles() {
    find_fixed();
    std::vector<Index> wanted;
    for (Index t : bad_tets()) {
      const auto p = corners(m_, m_.tet(t));
      if (!(dihedral_range(p[0], p[1], p[2], p[3]).min < o_.target_min_dihedral)) continue;
      for (Index v : m_.tet(t)) wanted.push_back(v);
    }
    std::sort(wanted.begin(), wanted.end());
    wanted.erase(std::unique(wanted.begin(), wanted.end()), wanted.end());
    std::size_t moved = 0;
    for (Index v : wanted)
      if ((v >= fixed_.size() || !fixed_[v]) && polish_point(v, first_tet(v))) ++moved;
    st_.points_moved += moved;
    return moved;
  }

  /// Margin polish (optimize.hpp, 7.): up to kMarginRounds rounds; in each,
  /// first the ring (the free points next to a free point of a bad tet with
  /// no surface point, not on such a tet themselves), ascending, each moved by
  /// margin_point as the ring, then the free points of those bad tets,
  /// ascending, each moved by margin_point; each compass search ends at 1/`end` of its first
  /// step; with `extremes`, the tets with a surface point may use the mesh's
  /// extremes (margin_point). The ring is `layers` deep: with more than one,
  /// the free points next to the ring (not on a bad tet) join it, and so on.
  /// Returns the moves.
  std::size_t polish_margins(double end = kSearchEnd, bool extremes = false, int layers = 1) {
    find_fixed();
    std::size_t moved = 0;
    // Per point: 1 wanted (a point of such a bad tet), 2 in the ring; reset
    // after each round, so a round costs what its points and stars do.
    marks_.resize(m_.num_points(), 0);
    for (int round = 0; round < kMarginRounds; ++round) {
      std::vector<Index> wanted;
      for (Index t : bad_tets()) {
        if (repair_class(m_.tet(t)) == 1) continue;
        for (Index v : m_.tet(t)) wanted.push_back(v);
      }
      if (wanted.empty()) break;  // most meshes: no star walks
      std::sort(wanted.begin(), wanted.end());
      wanted.erase(std::unique(wanted.begin(), wanted.end()), wanted.end());
      for (Index v : wanted) marks_[v] = 1;
      mesh_angles_ = angles();
      // The ring: the free points of the links of the free wanted points that
      // are not wanted themselves; each deeper layer, those of the links of the
      // last layer's points not taken yet. Sets: the walks' order does not matter.
      std::vector<Index> ring, layer, next;
      const auto visit = [&](Index v, std::vector<Index>& out) {
        gather_link(v, any_tet(v));
        for (const Tri& f : link_)
          for (Index u : f)
            if (marks_[u] == 0 && !fixed_[u]) {
              marks_[u] = 2;
              out.push_back(u);
            }
      };
      for (Index v : wanted)
        if (!fixed_[v]) visit(v, ring);
      layer = ring;
      for (int depth = 1; depth < layers && !layer.empty(); ++depth) {
        next.clear();
        for (Index v : layer) visit(v, next);
        ring.insert(ring.end(), next.begin(), next.end());
        std::swap(layer, next);
      }
      std::sort(ring.begin(), ring.end());
      std::size_t now = 0;
      for (Index v : ring)
        if (margin_point(v, first_tet(v), end, /*ring=*/true, extremes)) ++now;
      for (Index v : wanted)
        if (!fixed_[v] && margin_point(v, first_tet(v), end, /*ring=*/false, extremes)) ++now;
      for (Index v : wanted) marks_[v] = 0;
      for (Index v : ring) marks_[v] = 0;
      moved += now;
      if (now == 0) break;
    }
    st_.points_moved += moved;
    st_.margin_moves += moved;
    return moved;
  }

  /// Size polish (optimize.hpp, 9.): up to kSizeRounds rounds, while one
  /// changes something; in each, of the edges between two points off the
  /// surface, one of them moved or inserted by the optimization (touched),
  /// that are out of [kShortEdge, kLongEdge] times the mean h of their ends
  /// (h at the points, measured once each), the long ones are removed
  /// (size_flips) or split (size_splits) where that holds, then the free
  /// points of all of them and the new points, ascending, are moved by
  /// size_point. Returns the moves.
  std::size_t polish_sizes() {
    const auto touched = [this](Index v) { return v >= first_new_point_ || (v < moved_.size() && moved_[v] != 0); };
    std::vector<double> h(m_.num_points(), -1.0);
    const auto h_at = [&](Index v) {
      if (h[v] < 0.0) h[v] = sizing_->at(m_.point(v));
      return h[v];
    };
    std::size_t moved = 0;
    mesh_angles_ = angles();
    size_limits_ = {std::max(kRelaxedCapAngles[0], mesh_angles_.min),
                    std::min(kRelaxedCapAngles[1], mesh_angles_.max)};
    for (int round = 0; round < kSizeRounds; ++round) {
      find_fixed();  // also sized for the points the last round's splits added
      h.resize(m_.num_points(), -1.0);
      const Index np = m_.num_points();
      // The tets with an edge to check: those of the touched points off the
      // surface (free points, whose stars the walks find whole), in slot order.
      std::vector<Index> tets;
      for (Index v : moved_list_)
        if (surface_[v] == 0) star_tets(v, tets);
      for (Index v = first_new_point_; v < np; ++v)
        if (surface_[v] == 0) star_tets(v, tets);
      std::sort(tets.begin(), tets.end());
      tets.erase(std::unique(tets.begin(), tets.end()), tets.end());
      std::vector<Index> wanted;
      long_edges_.clear();
      for (Index t : tets) {
        const Tet& k = m_.tet(t);
        for (int e = 0; e < 6; ++e) {
          const Index a = k[topo::kEdgeVertex[e][0]], b = k[topo::kEdgeVertex[e][1]];
          if (surface_[a] != 0 || surface_[b] != 0 || !(touched(a) || touched(b))) continue;
          const Vec3 d = m_.point(a) - m_.point(b);
          const double mean = 0.5 * (h_at(a) + h_at(b)), l2 = dot(d, d);
          if (l2 > kLongEdge * kLongEdge * mean * mean) long_edges_.push_back({std::min(a, b), std::max(a, b), t, e});
          if (l2 < kShortEdge * kShortEdge * mean * mean || l2 > kLongEdge * kLongEdge * mean * mean) {
            wanted.push_back(a);
            wanted.push_back(b);
          }
        }
      }
      std::sort(long_edges_.begin(), long_edges_.end());  // each edge once, from its first tet
      long_edges_.erase(std::unique(long_edges_.begin(), long_edges_.end(),
                                    [](const LongEdge& x, const LongEdge& y) { return x.a == y.a && x.b == y.b; }),
                        long_edges_.end());
      const std::size_t flipped = o_.reconnect ? size_flips() : 0;
      st_.flips += flipped;
      st_.size_flips += flipped;
      const std::size_t split = o_.insert_points ? size_splits() : 0;
      st_.points_inserted += split;
      st_.size_splits += split;
      find_fixed();
      for (Index v = np; v < m_.num_points(); ++v) wanted.push_back(v);  // new: their edges may be out of the band
      std::sort(wanted.begin(), wanted.end());
      wanted.erase(std::unique(wanted.begin(), wanted.end()), wanted.end());
      std::size_t now = 0;
      for (Index v : wanted)
        if (fixed_[v] == 0 && size_point(v, first_tet(v))) ++now;
      moved += now;
      if (now + flipped + split == 0) break;
    }
    st_.points_moved += moved;
    st_.size_moves += moved;
    return moved;
  }

  void start_sweep() {
    flips_this_sweep_ = 0;
    flip_budget_ = static_cast<std::size_t>(o_.max_flips_per_tet * m_.num_tets()) + 1;
  }

 private:
  bool push_created() {
    forget_created();
    for (Index c : m_.last_created()) queue_.push_back(c);
    return true;
  }

  /// Drops the known badness of the tets the last operation created, and
  /// notes them (touch); their points now lie in them (any_tet_).
  void forget_created() {
    for (Index c : m_.last_created()) {
      touch(c);
      if (!any_known_) continue;
      for (Index v : m_.tet(c)) {
        if (v >= any_tet_.size()) any_tet_.resize(v + 1, kNoIndex);
        any_tet_[v] = c;
      }
    }
  }

  /// Slot t holds a new tet, or one whose points moved: its badness is
  /// unknown, and bad_tets() and angles() look at it again.
  void touch(Index t) {
    if (t < known_.size()) known_[t] = 0;
    if (bad_known_) touched_.push_back(t);
    if (range_built_) range_.touch(t);
  }

  /// No vertex of tet t is fixed (fixed_ as find_fixed left it; later points are free).
  bool free_tet(Index t) const {
    for (Index v : m_.tet(t))
      if (v < fixed_.size() && fixed_[v] != 0) return false;
    return true;
  }

  /// Whether a point of face f is on the surface (surface_).
  bool on_surface(const Tri& f) const {
    for (Index v : f)
      if (v < surface_.size() && surface_[v] != 0) return true;
    return false;
  }

  /// measure() of tet k, or -inf when k is not positive (exact).
  double measured(const Tet& k) const {
    const auto p = corners(m_, k);
    if (exact::orient3d(p[0], p[1], p[2], p[3]) <= 0) return -std::numeric_limits<double>::infinity();
    return measure(p);
  }

  /// Whether the tets of fresh_ hold the floors of the tets they replace
  /// (repair_floors): a repair flip must not trade an interior tet for a worse
  /// one, nor make a tet with a fixed point worse than the repair floor where
  /// the old ones with a fixed point were not.
  bool fresh_holds(const std::array<double, 3>& floors) const {
    if (judge_ == Judge::kAbsorb) return true;  // judged() held the absorption's bounds
    for (const Tet& k : fresh_)
      if (measure(corners(m_, k)) < floors[repair_class(k)]) return false;
    return true;
  }

  /// The repair's class of tet k: 0 no fixed point, 1 a point on the surface
  /// (surface_), 2 fixed points elsewhere only (a leaf's interface, which is
  /// inside the final mesh: such tets are held like those with no fixed point).
  int repair_class(const Tet& k) const {
    int c = 0;
    for (Index v : k) {
      if (v < surface_.size() && surface_[v] != 0) return 1;
      if (v < fixed_.size() && fixed_[v] != 0) c = 2;
    }
    return c;
  }

  /// The floors of a repair operation replacing `tets`, per repair_class: the
  /// worst measure of the class, capped at 1 (at repair_floor() for class 1).
  /// With `worst`, also the worst measure over all of them, uncapped (each
  /// tet is measured once).
  std::array<double, 3> repair_floors(std::span<const Index> tets, double* worst = nullptr) const {
    std::array<double, 3> q{1.0, repair_floor_, 1.0};
    double lowest = std::numeric_limits<double>::infinity();
    for (Index t : tets) {
      const double m = measure(corners(m_, m_.tet(t)));
      double& f = q[static_cast<std::size_t>(repair_class(m_.tet(t)))];
      f = std::min(f, m);
      lowest = std::min(lowest, m);
    }
    if (worst != nullptr) *worst = lowest;
    return q;
  }

  /// The objective of the repair's operations: measured(); in the absorption
  /// (judge_), measured() for a tet with no surface point only, while one
  /// with a surface point scores +inf when it is positive (exact) and within
  /// the mesh's extremes (mesh_angles_), else -inf: the operation is judged
  /// by the tets off the surface, and no extreme of the mesh gets worse.
  double judged(const Tet& k) const {
    const double q = measured(k);
    return q == -kInfinity ? q : judged(corners(m_, k), repair_class(k) == 1, q);
  }

  /// judged() of a positive tet with corners p, a surface point or not, and
  /// measure q.
  double judged(const std::array<Vec3, 4>& p, bool surface, double q) const {
    if (judge_ == Judge::kRepair || !surface) return q;
    return within(dihedral_range(p[0], p[1], p[2], p[3]), mesh_angles_) ? kInfinity : -kInfinity;
  }

  /// What the new tets of an operation replacing `tets` must beat: the worst
  /// measure among them (`worst`, from repair_floors) or, in the absorption,
  /// the worst among those with no surface point (+inf when there are none).
  double beat(std::span<const Index> tets, double worst) const {
    if (judge_ == Judge::kRepair) return worst;
    double q = kInfinity;
    for (Index t : tets)
      if (repair_class(m_.tet(t)) != 1) q = std::min(q, measure(corners(m_, m_.tet(t))));
    return q;
  }

  /// One repair flip around the bad tet t (repair_flips).
  bool repair_tet(Index t) {
    const auto p = corners(m_, m_.tet(t));
    const auto angles = dihedral_angles(p[0], p[1], p[2], p[3]);
    std::array<int, 6> edges{0, 1, 2, 3, 4, 5};
    std::stable_sort(edges.begin(), edges.end(), [&](int a, int b) {
      return std::abs(angles[a] - 90.0) > std::abs(angles[b] - 90.0);  // most extreme first
    });
    for (int e : edges)
      if (remove_edge_measured(t, e)) return true;
    for (int f = 0; f < 4; ++f)
      if (flip23_measured(t, f)) return true;
    for (int f = 0; f < 4; ++f) {
      const Index n = m_.neighbour(t, f);
      if (n == kNoIndex) continue;
      const Index u = face_tet(n);
      const int apex = face_local(n);
      for (int j = 0; j < 4; ++j)
        if (j != apex && remove_edge_measured(u, topo::kEdgeIndex[apex][j])) return true;
    }
    // No flip: a point in the cavity of t and its face neighbours (as for
    // slivers; judged by the measure, so not in the absorption).
    if (judge_ == Judge::kRepair && sizing_ != nullptr && o_.insert_points && insert_into(t, /*guard_free=*/true)) {
      ++st_.points_inserted;
      return true;
    }
    // Nor a point: one of t's points removed.
    if (o_.remove_points && remove_point(t)) {
      ++st_.points_removed;
      return true;
    }
    // In the absorption, last: two of t's points replaced by one.
    if (judge_ == Judge::kAbsorb && o_.remove_points && collapse_edge(t)) {
      ++st_.edges_collapsed;
      return true;
    }
    return false;
  }

  /// Edge removal as flips.hpp's remove_edge (the same ring and search,
  /// best_ring_triangulation), but maximising the smallest measure() of the new
  /// tets, and done only when it beats the old tets' smallest and holds their
  /// repair floors.
  bool remove_edge_measured(Index t, int e) {
    EdgeRing r;
    if (removable_edge_ring(m_, t, e, 0, r) != FlipOutcome::kDone) return false;
    const auto old = std::span<const Index>(r.tets.data(), static_cast<std::size_t>(r.size));
    double old_q = 0.0;
    const std::array<double, 3> floors = repair_floors(old, &old_q);
    RingTriangulation best;
    if (!best_ring_triangulation(
            r, beat(old, old_q), [this](const Tet& k) { return judged(k); }, [](int, int, int) { return false; }, best))
      return false;
    fresh_.assign(best.tets.begin(), best.tets.begin() + best.count);
    if (!fresh_holds(floors)) return false;
    parent_.assign(fresh_.size(), 0);
    m_.replace_cavity(old, fresh_, parent_);
    forget_created();
    return true;
  }

  /// Point removal (remove_points, optimize.hpp 4.): a free point v of the bad
  /// tet t is contracted onto a point w of its link: v's star becomes the cone
  /// from w over the link faces that do not hold w (the tets around the edge
  /// (v, w) go). Of v's link points, the w whose cone has the best worst tet,
  /// ascending index on ties; done when every tet of the cone is positive
  /// (exact), beats the worst tet of the star and holds its repair floors.
  /// Positive tets over the whole link tile the star (it is star-shaped from
  /// w), so the mesh stays a conforming tetrahedralization of the same region;
  /// v is left in no tet (optimize() drops such points at the end).
  bool remove_point(Index t) {
    const Tet k = m_.tet(t);
    for (Index v : k) {
      if ((v < fixed_.size() && fixed_[v] != 0) || !gather_star(v, t, kRemovalMaxStar)) continue;
      removal_star_.clear();
      for (const auto& [s, lv] : star_) removal_star_.push_back(s);
      double old_q = 0.0;
      const std::array<double, 3> floors = repair_floors(removal_star_, &old_q);
      removal_targets_.clear();
      for (const auto& [s, lv] : star_)
        for (Index u : m_.tet(s))
          if (u != v) removal_targets_.push_back(u);
      std::sort(removal_targets_.begin(), removal_targets_.end());
      removal_targets_.erase(std::unique(removal_targets_.begin(), removal_targets_.end()),
                             removal_targets_.end());
      Index best = kNoIndex;
      double best_q = beat(removal_star_, old_q);
      for (Index w : removal_targets_) {
        const double q = cone_quality(w, best_q);
        if (q > best_q) {
          best_q = q;
          best = w;
        }
      }
      if (best == kNoIndex) continue;
      fresh_.clear();
      for (const auto& [s, lv] : star_)
        if (const std::optional<Tet> n = cone_tet(s, lv, best)) fresh_.push_back(*n);
      if (!fresh_holds(floors)) continue;
      parent_.assign(fresh_.size(), 0);
      m_.replace_cavity(removal_star_, fresh_, parent_);
      forget_created();
      return true;
    }
    return false;
  }

  /// Edge collapse: the free points v and w of an edge of the bad tet t are
  /// replaced by one new point x: the tets of both stars become the star of x
  /// over their outer faces (the tets holding both go), x placed by a compass
  /// search from the edge's midpoint for the best worst judged() tet; done
  /// when every new tet is positive (exact) and that worst beats the stars'
  /// (beat). v and w are left in no tet (optimize() drops them).
  bool collapse_edge(Index t) {
    const Tet k = m_.tet(t);
    for (int e = 0; e < 6; ++e) {
      const Index v = k[topo::kEdgeVertex[e][0]], w = k[topo::kEdgeVertex[e][1]];
      if ((v < fixed_.size() && fixed_[v] != 0) || (w < fixed_.size() && fixed_[w] != 0)) continue;
      if (!gather_star(v, t, kRemovalMaxStar)) continue;
      removal_star_.clear();
      fresh_.clear();
      for (const auto& [s, lv] : star_) {
        removal_star_.push_back(s);
        const Tet& ks = m_.tet(s);
        if (std::find(ks.begin(), ks.end(), w) != ks.end()) continue;
        Tet n = ks;
        n[static_cast<std::size_t>(lv)] = kNoIndex;
        fresh_.push_back(n);
      }
      if (!gather_star(w, t, kRemovalMaxStar)) continue;
      for (const auto& [s, lw] : star_) {
        const Tet& ks = m_.tet(s);
        if (std::find(ks.begin(), ks.end(), v) != ks.end()) continue;
        removal_star_.push_back(s);
        Tet n = ks;
        n[static_cast<std::size_t>(lw)] = kNoIndex;
        fresh_.push_back(n);
      }
      double old_q = 0.0;
      repair_floors(removal_star_, &old_q);
      const double floor = beat(removal_star_, old_q);
      const auto score = [&](const Vec3& x) {
        double q = kInfinity;
        for (const Tet& n : fresh_) {
          std::array<Vec3, 4> p{};
          for (int j = 0; j < 4; ++j) p[j] = n[j] == kNoIndex ? x : m_.point(n[j]);
          if (exact::orient3d(p[0], p[1], p[2], p[3]) <= 0) return -kInfinity;
          bool surface = false;
          for (Index u : n) surface = surface || (u != kNoIndex && !off_surface(u));
          q = std::min(q, judged(p, surface, measure(p)));
          if (q == -kInfinity) return q;
        }
        return q;
      };
      link_points_.clear();
      for (const Tet& n : fresh_)
        for (Index u : n)
          if (u != kNoIndex) link_points_.push_back(u);
      std::sort(link_points_.begin(), link_points_.end());
      link_points_.erase(std::unique(link_points_.begin(), link_points_.end()), link_points_.end());
      const Vec3 mid = 0.5 * (m_.point(v) + m_.point(w));
      double best = score(mid);
      const Vec3 x = compass_search(mid, [&](const Vec3& y) {
        const double q = score(y);
        if (!(q > best)) return false;
        best = q;
        return true;
      });
      if (!(best > floor)) continue;
      replace_with_point(removal_star_, x);
      return true;
    }
    return false;
  }

  /// Replaces the tets `old` by fresh_, in which kNoIndex stands for a new
  /// point at x (collapse_edge, size_splits).
  void replace_with_point(std::span<const Index> old, const Vec3& x) {
    const Index np = m_.add_point(x);
    for (Tet& n : fresh_)
      for (Index& u : n)
        if (u == kNoIndex) u = np;
    parent_.assign(fresh_.size(), 0);
    m_.replace_cavity(old, fresh_, parent_);
    forget_created();
  }

  /// The tet of the cone from w that replaces star tet s (whose point lv is
  /// the removed one): s with w in that place; none when s holds w (it goes).
  std::optional<Tet> cone_tet(Index s, int lv, Index w) const {
    Tet n = m_.tet(s);
    if (std::find(n.begin(), n.end(), w) != n.end()) return std::nullopt;
    n[static_cast<std::size_t>(lv)] = w;
    return n;
  }

  /// The worst measure of the cone from w over the link faces of star_'s
  /// point that do not hold w, -inf when one is not positive; it stops early,
  /// with a value <= `beat`, once the worst is no better than `beat`.
  double cone_quality(Index w, double beat) const {
    double q = std::numeric_limits<double>::infinity();
    for (const auto& [s, lv] : star_) {
      const std::optional<Tet> n = cone_tet(s, lv, w);
      if (!n) continue;
      q = std::min(q, judged(*n));
      if (!(q > beat)) break;
    }
    return q;
  }

  /// 2-3 flip of face f of t as flips.hpp's flip23, judged by measure().
  bool flip23_measured(Index t, int f) {
    const Index n = m_.neighbour(t, f);
    if (n == kNoIndex || m_.frozen(t, f)) return false;
    const Index u = face_tet(n);
    if (m_.region(t) != m_.region(u)) return false;
    const Tet& kt = m_.tet(t);
    const Index a = kt[topo::kFaceVertex[f][0]], b = kt[topo::kFaceVertex[f][1]];
    const Index c = kt[topo::kFaceVertex[f][2]], d = kt[f];
    const Index e = m_.tet(u)[face_local(n)];
    const std::array<Index, 2> old{t, u};
    double old_q = 0.0;
    const std::array<double, 3> floors = repair_floors(old, &old_q);
    fresh_.assign({Tet{a, b, d, e}, Tet{b, c, d, e}, Tet{c, a, d, e}});
    const double floor = beat(old, old_q);
    for (const Tet& k : fresh_)
      if (!(judged(k) > floor)) return false;
    if (!fresh_holds(floors)) return false;
    parent_.assign(3, 0);
    m_.replace_cavity(old, fresh_, parent_);
    forget_created();
    return true;
  }

  /// One flip that improves the neighbourhood of the bad tet t, or none.
  bool try_flips(Index t) {
    const auto p = corners(m_, m_.tet(t));
    const auto angles = dihedral_angles(p[0], p[1], p[2], p[3]);
    std::array<int, 6> edges{0, 1, 2, 3, 4, 5};
    std::stable_sort(edges.begin(), edges.end(),
                     [&](int a, int b) { return angles[a] > angles[b]; });
    for (int e : edges)
      if (remove_edge(m_, t, e) == FlipOutcome::kDone) return push_created();
    for (int f = 0; f < 4; ++f)
      if (flip23(m_, t, f) == FlipOutcome::kDone) return push_created();
    // The neighbourhood: edges of the face neighbours that t does not hold.
    for (int f = 0; f < 4; ++f) {
      const Index n = m_.neighbour(t, f);
      if (n == kNoIndex) continue;
      const Index u = face_tet(n);
      const int apex = face_local(n);
      for (int j = 0; j < 4; ++j) {
        if (j == apex) continue;
        if (remove_edge(m_, u, topo::kEdgeIndex[apex][j]) == FlipOutcome::kDone) {
          push_created();
          queue_.push_back(t);
          return true;
        }
      }
    }
    return false;
  }

  /// The star of v: (tet, local index of v), by a walk from `start` across the
  /// faces through v; with kCrossKept false (insert_over_fans) only across
  /// those that are not kept (kept_face). False when it would pass `most` tets.
  /// (A template argument, so that the smoothing's walk, its hot path, pays
  /// nothing for the check.)
  template <bool kCrossKept = true>
  bool gather_star(Index v, Index start, std::size_t most = std::numeric_limits<std::size_t>::max()) {
    star_.clear();
    star_.push_back({start, topo::local_vertex(m_.tet(start), v)});
    for (std::size_t i = 0; i < star_.size(); ++i) {
      const auto [t, lv] = star_[i];
      for (int f = 0; f < 4; ++f) {
        if (f == lv) continue;  // the faces through v are those opposite its other vertices
        const Index n = m_.neighbour(t, f);
        if (n == kNoIndex || (!kCrossKept && kept_face(t, f))) continue;
        const Index u = face_tet(n);
        bool seen = false;
        for (const auto& s : star_) seen = seen || s.first == u;
        if (seen) continue;
        if (star_.size() >= most) return false;
        star_.push_back({u, topo::local_vertex(m_.tet(u), v)});
      }
    }
    return true;
  }

  /// The new tets over link_ with the free point x and no surface point (repair
  /// classes 0 and 2) meet their class's floor (repair_floors of the tets they
  /// replace): a cap repair may not trade the cap for a bad tet away from the
  /// surface (primitives13 at diag/100 got interior tets of 9.6 / 166.6 degrees).
  bool off_surface_floors_hold(const Vec3& x, const std::array<double, 3>& floors) const {
    for (const Tri& f : link_) {
      const int c = repair_class({f[0], f[1], f[2], kNoIndex});  // x: not yet a point, free
      if (c == 1) continue;
      if (measure({m_.point(f[0]), m_.point(f[1]), m_.point(f[2]), x}) < floors[static_cast<std::size_t>(c)]) return false;
    }
    return true;
  }

  /// Worst measure of the tets (link face, x); -inf when one is not positive.
  double star_quality(const Vec3& x) const {
    double worst = std::numeric_limits<double>::infinity();
    for (const Tri& f : link_) {
      const std::array<Vec3, 4> p{m_.point(f[0]), m_.point(f[1]), m_.point(f[2]), x};
      if (exact::orient3d(p[0], p[1], p[2], p[3]) <= 0)
        return -std::numeric_limits<double>::infinity();
      worst = std::min(worst, measure(p));
    }
    return worst;
  }

  /// The points of link_, each once and ascending, into link_points_.
  void gather_link_points() {
    link_points_.clear();
    for (const Tri& f : link_) link_points_.insert(link_points_.end(), f.begin(), f.end());
    std::sort(link_points_.begin(), link_points_.end());
    link_points_.erase(std::unique(link_points_.begin(), link_points_.end()), link_points_.end());
  }

  /// Best position for the apex of the tets over link_ (star_quality), starting
  /// from `old` and moving towards the candidate targets with a line search
  /// (kLineSteps steps 1, 1/2, 1/4, ...; the first step that beats q0 is taken
  /// per target).
  /// Returns the best quality found, > q0 only when `best` improves.
  /// With `profile`, a position counts as better when its star_profile is
  /// lexicographically greater (the first differing quality higher) than the
  /// one in profile_old_ (and than the best so far); the return value is then
  /// the best profile's worst quality.
  double best_position(const Vec3& old, double q0, Vec3& best, bool profile = false) {
    // Target 1: the mean of the link's vertices (each once).
    gather_link_points();
    Vec3 laplace{0, 0, 0};
    for (Index u : link_points_) laplace = laplace + m_.point(u);
    laplace = (1.0 / static_cast<double>(link_points_.size())) * laplace;
    // Target 2: the mean of the apexes that would make each tet regular.
    Vec3 ideal{0, 0, 0};
    for (const Tri& f : link_) ideal = ideal + regular_apex(m_.point(f[0]), m_.point(f[1]), m_.point(f[2]));
    ideal = (1.0 / static_cast<double>(link_.size())) * ideal;

    // Target 3: the apex that would make the star's worst tet regular.
    Vec3 worst_ideal = old;
    double worst_q = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < link_.size(); ++i) {
      // The repair's smoothing aims at the worst judged tet (a pinned one
      // only leads when all are).
      if (profile && pin_floor_ < 1.0 && pinned_[i] && !all_pinned_) continue;
      const Tri& f = link_[i];
      const Vec3 &a = m_.point(f[0]), &b = m_.point(f[1]), &c = m_.point(f[2]);
      const double q = measure({a, b, c, old});
      if (!(q < worst_q)) continue;
      worst_q = q;
      worst_ideal = regular_apex(a, b, c);
    }

    double best_q = q0;
    best = old;
    if (profile) profile_best_ = profile_old_;
    for (const Vec3& target : {laplace, ideal, worst_ideal}) {
      double step = 1.0;
      for (int i = 0; i < kLineSteps; ++i, step *= 0.5) {
        const Vec3 x = old + step * (target - old);
        if (profile) {
          if (!smoothing_accepts(x)) continue;
          if (profile_best_ < profile_new_) {
            std::swap(profile_best_, profile_new_);
            best_q = profile_best_.front();
            best = x;
          }
          break;
        }
        const double q = star_quality(x);
        if (q > q0) {
          if (q > best_q) {
            best_q = q;
            best = x;
          }
          break;
        }
      }
    }
    return best_q;
  }

  /// The measure of every tet (link face, x) in link_ order into `out`; false
  /// (out unusable) when one is not positive (exact), or measures below `floor`.
  bool star_measures(const Vec3& x, std::vector<double>& out,
                     double floor = -std::numeric_limits<double>::infinity()) const {
    out.clear();
    for (const Tri& f : link_) {
      const std::array<Vec3, 4> p{m_.point(f[0]), m_.point(f[1]), m_.point(f[2]), x};
      const double q = measure(p);
      if (q < floor || exact::orient3d(p[0], p[1], p[2], p[3]) <= 0) return false;
      out.push_back(q);
    }
    return true;
  }

  /// The smoothing profile of a star from its measures: each clipped at 1 (a
  /// tet within the targets counts as good, however good), ascending; the
  /// pinned tets (pinned_, in link_ order) are left out unless every tet is.
  void to_profile(const std::vector<double>& measures, std::vector<double>& out) const {
    out.clear();
    for (std::size_t i = 0; i < measures.size(); ++i)
      if (!pinned_[i] || all_pinned_) out.push_back(std::min(measures[i], 1.0));
    std::sort(out.begin(), out.end());
  }

  /// Whether apex position x keeps every edge bound of edge_bounds_.
  bool keeps_edge_sizes(const Vec3& x) const {
    for (const EdgeBound& e : edge_bounds_) {
      const Vec3 d = x - m_.point(e.u);
      if (dot(d, d) < e.least2) return false;
    }
    return true;
  }

  /// Whether apex position x beats the old one for smoothing: every tet
  /// positive, every tet at or above its bound in lower_ (the judged tets: the
  /// old worst judged measure; a pinned tet: its own old measure, so it never
  /// gets worse), and the profile lexicographically above profile_old_ (the
  /// worst judged tet better, or as good and the next worse one better, ...).
  /// Leaves x's profile in profile_new_.
  bool smoothing_accepts(const Vec3& x) {
    if (!keeps_edge_sizes(x)) return false;
    // The tet that failed the last trial first: most trials fail (83% of
    // couplingdown's at diag/100), mostly on the tet that failed the one
    // before, and the decision does not depend on the order.
    const std::size_t first = last_failed_ < link_.size() ? last_failed_ : 0;
    const std::optional<double> q_first = link_measure(first, x);
    if (!q_first) return false;
    measures_new_.clear();
    for (std::size_t i = 0; i < link_.size(); ++i) {
      const std::optional<double> q = i == first ? q_first : link_measure(i, x);
      if (!q) {
        last_failed_ = i;
        return false;
      }
      measures_new_.push_back(*q);
    }
    to_profile(measures_new_, profile_new_);
    return profile_old_ < profile_new_;
  }

  /// measure() of the tet over link_ face i with apex x; none when it is
  /// below lower_[i] or not positive (exact::orient3d).
  std::optional<double> link_measure(std::size_t i, const Vec3& x) const {
    const Tri& f = link_[i];
    const std::array<Vec3, 4> p{m_.point(f[0]), m_.point(f[1]), m_.point(f[2]), x};
    const double q = measure(p);
    if (q < lower_[i] || exact::orient3d(p[0], p[1], p[2], p[3]) <= 0) return std::nullopt;
    return q;
  }

  /// Compass search for the apex of the star over link_ (smooth_vertex when
  /// no target helped, optimize.hpp 3.; polish_angles): from `old`, a step
  /// along each of the 6 axes and 8 diagonals; the last that `improves`
  /// (which keeps the best so far: each step it accepts beats it) is taken,
  /// else the step halves. The step starts at a quarter of the mean distance
  /// to the link points and the search ends below 1/`end` of it or after
  /// kCompassRounds rounds. Expects link_points_ (gather_link_points).
  template <typename Improves>
  Vec3 compass_search(const Vec3& old, Improves&& improves, double end = kSearchEnd) {
    double scale = 0;
    for (Index u : link_points_) scale += norm(m_.point(u) - old);
    scale /= static_cast<double>(std::max<std::size_t>(1, link_points_.size()));
    static const std::array<Vec3, 14> dirs = [] {
      std::array<Vec3, 14> d{};
      std::size_t i = 0;
      for (int a = 0; a < 3; ++a)
        for (double sgn : {1.0, -1.0}) {
          Vec3 e{0, 0, 0};
          e[static_cast<std::size_t>(a)] = sgn;
          d[i++] = e;
        }
      const double c = 1.0 / std::sqrt(3.0);
      for (double sx : {1.0, -1.0})
        for (double sy : {1.0, -1.0})
          for (double sz : {1.0, -1.0}) d[i++] = Vec3{sx * c, sy * c, sz * c};
      return d;
    }();
    Vec3 x = old;
    double step = 0.25 * scale;
    for (int round = 0; round < kCompassRounds && step > scale / end; ++round) {
      Vec3 next = x;
      for (const Vec3& d : dirs) {
        const Vec3 y = x + step * d;
        if (improves(y)) next = y;
      }
      if (next == x) {
        step *= 0.5;
      } else {
        x = next;
      }
    }
    return x;
  }

  /// The star of v (gather_star from `start`) and its link faces, turned
  /// towards v, into link_ (in star_ order).
  void gather_link(Index v, Index start) {
    gather_star(v, start);
    last_failed_ = 0;
    edge_bounds_.clear();
    link_.clear();
    for (const auto& [t, lv] : star_) {
      const Tri f = topo::face_of(m_.tet(t), lv);  // outward: away from v
      link_.push_back({f[0], f[2], f[1]});
    }
  }

  /// Moves v to x and forgets what was known of its star's tets.
  void move_point(Index v, const Vec3& x) {
    m_.set_point(v, x);
    if (v >= moved_.size()) moved_.resize(v + 1, 0);
    if (moved_[v] == 0) moved_list_.push_back(v);
    moved_[v] = 1;
    for (const auto& s : star_) {
      m_.invalidate_quality(s.first);
      touch(s.first);
    }
  }

  /// With keep_edge_sizes and a sizing field: the least lengths of the edges
  /// from a point at `old` to the link points off the surface (edge_bounds_):
  /// kShortEdge times h at the edge's midpoint, or its old length when that
  /// is less.
  void bound_edge_sizes(const Vec3& old) {
    if (sizing_ == nullptr || !o_.keep_edge_sizes) return;
    gather_link_points();
    for (Index u : link_points_) {
      if (u < surface_.size() && surface_[u] != 0) continue;
      const Vec3& p = m_.point(u);
      const double least = std::min(norm(old - p), kShortEdge * sizing_->at(0.5 * (old + p)));
      edge_bounds_.push_back({u, least * least});
    }
  }

  bool smooth_vertex(Index v, Index start) {
    gather_link(v, start);
    const Vec3 old = m_.point(v);
    Vec3 best;
    if (!star_measures(old, measures_old_)) return false;
    // In the polishing rounds, a tet with a fixed point is pinned: it only
    // must not get worse, and the move is judged by the other tets' profile.
    pinned_.assign(link_.size(), 0);
    all_pinned_ = true;
    for (std::size_t i = 0; i < link_.size(); ++i) {
      bool pinned = false;
      for (Index u : link_[i]) pinned = pinned || (pin_fixed_ && u < fixed_.size() && fixed_[u] != 0);
      pinned_[i] = pinned ? 1 : 0;
      all_pinned_ = all_pinned_ && pinned;
    }
    to_profile(measures_old_, profile_old_);
    if (profile_old_.front() >= 1.0) return false;  // the star is good already
    bound_edge_sizes(old);
    lower_.resize(link_.size());
    for (std::size_t i = 0; i < link_.size(); ++i)
      lower_[i] = pinned_[i] && !all_pinned_ ? std::min(measures_old_[i], on_surface(link_[i]) ? pin_floor_ : 1.0)
                                             : profile_old_.front();
    // Targets and line search as best_position, but compared by the star's
    // profile (smoothing_accepts): a move may improve a bad tet while the
    // star's worst tet, which v cannot help (e.g. a tet on the boundary), stays
    // as it is; tets within the targets count as equal.
    const double q0 = profile_old_.front();
    (void)best_position(old, q0, best, /*profile=*/true);
    if (best == old) {
      // Steps that smoothing_accepts and whose profile beats profile_best_
      // (the old profile: no target helped).
      best = compass_search(old, [this](const Vec3& y) {
        if (!smoothing_accepts(y) || !(profile_best_ < profile_new_)) return false;
        std::swap(profile_best_, profile_new_);
        return true;
      });
    }
    if (best == old) return false;
    move_point(v, best);
    return true;
  }

  /// Angle polish of v (polish_angles): a compass search for the position
  /// that raises the smallest dihedral angle of v's star, every tet of it
  /// positive (exact) and within its bounds: one with a surface point (its
  /// link face on_surface) keeps its largest angle within the larger of
  /// kRelaxedCapAngles[1] and the star's old largest; one with none stays
  /// within the targets or no worse than it was on either side (the interior
  /// bound of the refiner issue). True when v moved.
  bool polish_point(Index v, Index start) {
    gather_link(v, start);
    const Vec3 old = m_.point(v);
    const AngleRange before = angle_range(&old, {});
    if (!(before.min < o_.target_min_dihedral)) return false;
    const double largest = std::max(kRelaxedCapAngles[1], before.max);
    polish_bounds_.clear();
    for (const Tri& f : link_) {
      if (on_surface(f)) {
        polish_bounds_.push_back({0.0, largest});
        continue;
      }
      const AngleRange r = dihedral_range(m_.point(f[0]), m_.point(f[1]), m_.point(f[2]), old);
      polish_bounds_.push_back(target_bounds(r));
    }
    return move_by_score(v, before.min, [this](std::size_t i, const AngleRange& r) {
      return within(r, polish_bounds_[i]) ? r.min : -kInfinity;
    });
  }

  /// The angles a tet whose angles are r may reach: the targets, widened on
  /// either side to r where r lies outside them (within stays within, outside
  /// gets no worse).
  AngleRange target_bounds(const AngleRange& r) const {
    return {std::min(o_.target_min_dihedral, r.min), std::max(o_.target_max_dihedral, r.max)};
  }

  /// How far the dihedral angles of r lie inside the targets, in degrees:
  /// negative for a tet outside them (by its worse side).
  double margin(const AngleRange& r) const {
    return std::min(r.min - o_.target_min_dihedral, o_.target_max_dihedral - r.max);
  }

  /// The angles a tet with a surface point may reach from `old` in the margin
  /// and size polish: a side within `limits` stays within them, a side already
  /// past them may go as far as the mesh's extreme on that side when the round
  /// began (mesh_angles_), so neither extreme of the mesh gets worse, nor the
  /// share of tets past the limits. The margin polish's limits are
  /// kRelaxedCapAngles (no tet crosses 10 or 165 degrees). Next to needle
  /// triangles the tets on the surface are that bad anyway: letting them move
  /// within that range took hinge at diag/100 from 376 interior tets outside
  /// [15, 150] to 333 and couplingdown from 25 to 23
  /// (`pdrmesh_bench_refine`), where [min(10, old), max(165, old)] held them to
  /// their own extremes.
  AngleRange surface_bounds(const AngleRange& old, const AngleRange& limits) const {
    return {old.min < limits.min ? std::min(mesh_angles_.min, old.min) : limits.min,
            old.max > limits.max ? std::max(mesh_angles_.max, old.max) : limits.max};
  }

  /// Margin polish of v (polish_margins): a compass search for the position
  /// that raises the smallest margin() of v's star's bad tets with no surface
  /// point, every tet positive (exact); such a tet within the targets stays
  /// within them, and a tet with a surface point keeps its angles within
  /// surface_bounds(its old angles, kRelaxedCapAngles), or with `extremes`
  /// (the absorption's pass) within the mesh's extremes. With `ring`, v is next to a bad tet's
  /// point but on none (polish_margins' ring): every tet of its star with no
  /// surface point is judged (all within the targets, and they stay within),
  /// so that the bad tets' points find room next, and with keep_edge_sizes no
  /// edge to a point off the surface is made short (bound_edge_sizes). The
  /// ring took hinge at diag/100 from 333 interior tets outside [15, 150] to
  /// 231 and couplingdown from 23 to 8 (4 rounds; without the edge guard 220
  /// and 6, but hinge's interior edges within [0.6, 1.5] h fell from 90.3% to
  /// 89.8%; `pdrmesh_bench_refine`). True when v moved.
  bool margin_point(Index v, Index start, double end, bool ring, bool extremes) {
    gather_link(v, start);
    const Vec3 old = m_.point(v);
    double worst = kInfinity;
    polish_bounds_.clear();
    margin_kind_.clear();
    for (const Tri& f : link_) {
      const AngleRange r = dihedral_range(m_.point(f[0]), m_.point(f[1]), m_.point(f[2]), old);
      if (on_surface(f)) {
        margin_kind_.push_back(MarginKind::kSurface);
        polish_bounds_.push_back(
            surface_bounds(r, extremes ? mesh_angles_ : AngleRange{kRelaxedCapAngles[0], kRelaxedCapAngles[1]}));
        continue;
      }
      const double q = margin(r);
      const bool judged = ring || q < 0;
      margin_kind_.push_back(judged ? MarginKind::kBad : MarginKind::kGood);
      polish_bounds_.push_back(r);
      if (judged) worst = std::min(worst, q);
    }
    if (ring ? worst == kInfinity : !(worst < 0)) return false;  // nothing to judge, or nothing bad
    if (ring) bound_edge_sizes(old);
    return move_by_score(v, worst, [this](std::size_t i, const AngleRange& r) {
      switch (margin_kind_[i]) {
        case MarginKind::kSurface:
          return within(r, polish_bounds_[i]) ? kInfinity : -kInfinity;
        case MarginKind::kGood:
          return margin(r) >= 0 ? kInfinity : -kInfinity;
        case MarginKind::kBad:
          break;
      }
      return margin(r);
    }, end);
  }

  /// How far the edges from a point at x to the link points off the surface
  /// (size_edges_) lie out of [kShortEdge, kLongEdge] h, h at their midpoints
  /// when the search began: how many are out, then the sum of the distances
  /// (in units of h) to the band.
  std::pair<std::size_t, double> size_excess(const Vec3& x) const {
    std::pair<std::size_t, double> out{0, 0.0};
    for (const SizeEdge& e : size_edges_) {
      const double r = norm(x - m_.point(e.u)) / e.h;
      const double excess = std::max(r - kLongEdge, 0.0) + std::max(kShortEdge - r, 0.0);
      if (excess > 0.0) ++out.first;
      out.second += excess;
    }
    return out;
  }

  /// An edge off the surface that polish_sizes found long.
  struct LongEdge {
    Index a, b;  ///< a < b
    Index t;     ///< a tet holding it when found, and its local edge
    int e;
    bool operator<(const LongEdge& o) const { return std::tie(a, b, t, e) < std::tie(o.a, o.b, o.t, o.e); }
    bool operator==(const LongEdge&) const = default;
  };

  /// Whether the long edge le is still where polish_sizes found it (its tet
  /// alive and holding it: the slot may hold another tet now) and has a
  /// removable ring (flips.hpp), then in r.
  bool ring_of(const LongEdge& le, EdgeRing& r) const {
    if (!m_.alive(le.t)) return false;
    const Tet& k = m_.tet(le.t);
    const Index u = k[topo::kEdgeVertex[le.e][0]], w = k[topo::kEdgeVertex[le.e][1]];
    if (std::min(u, w) != le.a || std::max(u, w) != le.b) return false;
    return removable_edge_ring(m_, le.t, le.e, 0, r) == FlipOutcome::kDone;
  }

  bool off_surface(Index v) const { return v >= surface_.size() || surface_[v] == 0; }

  /// The angles a new tet of the size flips and splits must lie within: the
  /// targets, or size_limits_ for a tet with a surface point with the room.
  AngleRange size_bounds(const Tet& t) const {
    if (o_.surface_room && repair_class(t) == 1) return size_limits_;
    return {o_.target_min_dihedral, o_.target_max_dihedral};
  }

  /// Size flips (before each round's moves): each long edge of long_edges_
  /// (in the order of its ends, from the first tet in slot order that held it
  /// when the round began, if that tet still does) is removed where a triangulation of its
  /// ring exists whose new tets are positive (exact), those with no surface
  /// point within the targets and those with one within size_limits_, and
  /// whose new edges are all shorter than the removed one and, between two
  /// points off the surface, within [kShortEdge, kLongEdge] h at their
  /// midpoint: one edge fewer out of the band, none added. The triangulation
  /// with the best smallest measure wins. Returns the flips.
  std::size_t size_flips() {
    std::size_t flips = 0;
    for (const LongEdge& le : long_edges_) {
      EdgeRing r;
      if (!ring_of(le, r)) continue;
      const Vec3 d = m_.point(r.a) - m_.point(r.b);
      const double removed2 = dot(d, d);
      const int n = r.size;
      // A diagonal (ring[i], ring[j]) that is not a side of the ring polygon is a new edge.
      const auto refused = [&](int i, int j) {
        if (j - i < 2 || (i == 0 && j == n - 1)) return false;
        const Vec3 &x = m_.point(r.ring[i]), &y = m_.point(r.ring[j]);
        const double l2 = dot(x - y, x - y);
        if (l2 >= removed2) return true;
        if (!off_surface(r.ring[i]) || !off_surface(r.ring[j])) return false;
        const double h = sizing_->at(0.5 * (x + y));
        return l2 < kShortEdge * kShortEdge * h * h || l2 > kLongEdge * kLongEdge * h * h;
      };
      const auto quality = [&](const Tet& t) {
        const double q = measured(t);
        if (q == -kInfinity) return q;
        const auto p = corners(m_, t);
        return within(dihedral_range(p[0], p[1], p[2], p[3]), size_bounds(t)) ? q : -kInfinity;
      };
      RingTriangulation best;
      const auto excluded = [&](int i, int m, int j) { return refused(i, m) || refused(m, j) || refused(i, j); };
      if (!best_ring_triangulation(r, -kInfinity, quality, excluded, best)) continue;
      fresh_.assign(best.tets.begin(), best.tets.begin() + best.count);
      parent_.assign(fresh_.size(), 0);
      m_.replace_cavity(std::span<const Index>(r.tets.data(), static_cast<std::size_t>(n)), fresh_, parent_);
      forget_created();
      ++flips;
    }
    return flips;
  }

  /// Size splits (after the size flips): each long edge of long_edges_ still
  /// in the mesh gets a new point x on it, its ring's tets each split in two
  /// (a and b in turn replaced by x), where every new tet is positive (exact)
  /// and within the bounds of size_flips, and at most one new edge to a point
  /// off the surface lies out of [kShortEdge, kLongEdge] h (x moves next, with
  /// the polish's moves). x is tried at kSplitAt along the edge, the first
  /// that holds taken. Returns the points added.
  std::size_t size_splits() {
    std::size_t splits = 0;
    for (const LongEdge& le : long_edges_) {
      EdgeRing r;
      if (!ring_of(le, r)) continue;
      // Whether the new tets of a split at x hold (fresh_ gets them, with
      // kNoIndex for the new point).
      const auto holds = [&](const Vec3& x) {
        const auto out_of_band = [&](Index v) {
          if (!off_surface(v)) return 0;
          const Vec3& y = m_.point(v);
          const double l = norm(x - y), hm = sizing_->at(0.5 * (x + y));
          return l < kShortEdge * hm || l > kLongEdge * hm ? 1 : 0;
        };
        int out = out_of_band(r.a) + out_of_band(r.b);
        for (int i = 0; i < r.size; ++i) out += out_of_band(r.ring[i]);
        if (out > 1) return false;
        fresh_.clear();
        for (int i = 0; i < r.size; ++i) {
          const Tet& t = m_.tet(r.tets[i]);
          const AngleRange bounds = size_bounds(t);  // the two halves hold t's points
          for (const Index replaced : {r.a, r.b}) {
            Tet n = t;
            std::array<Vec3, 4> p = corners(m_, t);
            for (int j = 0; j < 4; ++j)
              if (n[j] == replaced) {
                p[j] = x;
                n[j] = kNoIndex;
              }
            if (exact::orient3d(p[0], p[1], p[2], p[3]) <= 0 || !within(dihedral_range(p[0], p[1], p[2], p[3]), bounds))
              return false;
            fresh_.push_back(n);
          }
        }
        return true;
      };
      const Vec3 &pa = m_.point(r.a), &pb = m_.point(r.b);
      bool found = false;
      Vec3 x{};
      for (std::size_t c = 0; c < kSplitAt.size() && !found; ++c) {
        x = pa + kSplitAt[c] * (pb - pa);
        found = holds(x);
      }
      if (!found) continue;
      replace_with_point(std::span<const Index>(r.tets.data(), static_cast<std::size_t>(r.size)), x);
      ++splits;
    }
    return splits;
  }

  /// Size polish of v (polish_sizes): a compass search for the position
  /// that lowers size_excess (fewer edges out of the band, then less far out),
  /// every tet of the star positive (exact); one with no surface point within
  /// the targets or, where it was outside, no worse on either side than it
  /// was; one with a surface point within surface_bounds(its old angles,
  /// size_limits_). True when v moved.
  bool size_point(Index v, Index start) {
    gather_link(v, start);
    gather_link_points();
    const Vec3 old = m_.point(v);
    size_edges_.clear();
    for (Index u : link_points_)
      if (u >= surface_.size() || surface_[u] == 0)
        size_edges_.push_back({u, sizing_->at(0.5 * (old + m_.point(u)))});
    std::pair<std::size_t, double> best = size_excess(old);
    if (best.first == 0) return false;
    polish_bounds_.clear();
    for (const Tri& f : link_) {
      const AngleRange r = dihedral_range(m_.point(f[0]), m_.point(f[1]), m_.point(f[2]), old);
      const bool room = o_.surface_room && on_surface(f);
      polish_bounds_.push_back(room ? surface_bounds(r, size_limits_) : target_bounds(r));
    }
    const Vec3 to = compass_search(old, [&](const Vec3& y) {
      const std::pair<std::size_t, double> excess = size_excess(y);
      if (!(excess < best)) return false;
      for (std::size_t i = 0; i < link_.size(); ++i) {
        const Vec3 &a = m_.point(link_[i][0]), &b = m_.point(link_[i][1]), &c = m_.point(link_[i][2]);
        if (exact::orient3d(a, b, c, y) <= 0 || !within(dihedral_range(a, b, c, y), polish_bounds_[i])) return false;
      }
      best = excess;
      return true;
    });
    if (to == old) return false;
    move_point(v, to);
    return true;
  }

  /// Whether the angles of r lie within `bounds`.
  static bool within(const AngleRange& r, const AngleRange& bounds) {
    return r.min >= bounds.min && r.max <= bounds.max;
  }

  /// The compass search of the angle and margin polish: v moves to the
  /// position y that compass_search finds where no edge bound (edge_bounds_,
  /// when bound_edge_sizes set them) is broken, every tet (link_ face i, y) is
  /// positive (exact) and the lowest score(i, its dihedral angles) beats the
  /// best so far, which starts at `floor`; a score of -kInfinity refuses y,
  /// kInfinity leaves the tet out; the search ends at 1/`end` of its first
  /// step. Expects link_ (gather_link). True when v moved.
  template <class Score>
  bool move_by_score(Index v, double floor, Score&& score, double end = kSearchEnd) {
    const Vec3 old = m_.point(v);
    gather_link_points();
    double best = floor;
    const Vec3 to = compass_search(old, [&](const Vec3& y) {
      if (!keeps_edge_sizes(y)) return false;
      double lowest = kInfinity;
      for (std::size_t i = 0; i < link_.size(); ++i) {
        const Vec3 &a = m_.point(link_[i][0]), &b = m_.point(link_[i][1]), &c = m_.point(link_[i][2]);
        if (exact::orient3d(a, b, c, y) <= 0) return false;
        lowest = std::min(lowest, score(i, dihedral_range(a, b, c, y)));
        if (!(lowest > best)) return false;
      }
      best = lowest;
      return true;
    }, end);
    if (to == old) return false;
    move_point(v, to);
    return true;
  }

  /// Whether boundary triangle i is on the surface, not a leaf's interface: a
  /// non-zero id, or any triangle when there are no ids.
  bool surface_triangle(std::size_t i) const {
    return m_.boundary_ids().size() != m_.boundary().size() || m_.boundary_ids()[i] != 0;
  }

  /// Face f of t stays as it is (its points are fixed; a cap repair keeps it):
  /// a hull face, a frozen face or a face between two regions.
  bool kept_face(Index t, int f) const {
    const Index n = m_.neighbour(t, f);
    return n == kNoIndex || m_.frozen(t, f) || m_.region(face_tet(n)) != m_.region(t);
  }

  /// The unit normal of t's kept face f, pointing into t, into `n`; false when
  /// the face has no area.
  bool kept_face_normal(Index t, int f, Vec3& n) const {
    const Tri k = topo::face_of(m_.tet(t), f);
    const Vec3& a = m_.point(k[0]);
    const Vec3 c = cross(m_.point(k[2]) - a, m_.point(k[1]) - a);
    const double ln = norm(c);
    if (!(ln > 0.0)) return false;
    n = (1.0 / ln) * c;
    return true;
  }

  /// Smallest and largest dihedral angle of the tets (link_ face, x), or of the
  /// tets `tets` when x is null.
  AngleRange angle_range(const Vec3* x, std::span<const Index> tets) const {
    AngleRange r{180.0, 0.0};
    const auto add = [&r](const std::array<Vec3, 4>& p) {
      const AngleRange a = dihedral_range(p[0], p[1], p[2], p[3]);
      r.min = std::min(r.min, a.min);
      r.max = std::max(r.max, a.max);
    };
    if (x == nullptr) {
      for (Index u : tets) add(corners(m_, m_.tet(u)));
    } else {
      for (const Tri& f : link_) add({m_.point(f[0]), m_.point(f[1]), m_.point(f[2]), *x});
    }
    return r;
  }

  /// The tets of `cavity` grown until every outer face is seen from x (the
  /// new tet over it positive by exact::orient3d): a tet across a face that is
  /// not seen joins, unless the face is kept (then false). The outer faces,
  /// turned into the cavity, go to link_. False too when the cavity would
  /// pass kCapMaxCavity tets, leave a region, hold a frozen face inside, or
  /// lose a vertex (one with no outer face, see insert_into).
  bool grow_cavity(std::vector<Index>& cavity, const Vec3& x) {
    const auto inside = [&cavity](Index u) { return std::find(cavity.begin(), cavity.end(), u) != cavity.end(); };
    for (bool grown = true; grown;) {
      grown = false;
      link_.clear();
      for (std::size_t i = 0; i < cavity.size() && !grown; ++i) {
        const Index u = cavity[i];
        for (int g = 0; g < 4 && !grown; ++g) {
          const Index n = m_.neighbour(u, g);
          if (n != kNoIndex && inside(face_tet(n))) {
            if (m_.frozen(u, g)) return false;
            continue;
          }
          const Tri k = topo::face_of(m_.tet(u), g);
          if (exact::orient3d(m_.point(k[0]), m_.point(k[2]), m_.point(k[1]), x) > 0) {
            link_.push_back({k[0], k[2], k[1]});
            continue;
          }
          if (kept_face(u, g) || cavity.size() >= kCapMaxCavity) return false;
          cavity.push_back(face_tet(n));
          grown = true;
        }
      }
    }
    for (Index u : cavity)
      for (Index v : m_.tet(u))
        if (std::none_of(link_.begin(), link_.end(),
                         [v](const Tri& f) { return f[0] == v || f[1] == v || f[2] == v; }))
          return false;
    return true;
  }

  /// Whether the bad tet t is a cap (optimize.hpp, 5.): two or three kept
  /// faces (kept_face), two of them surface triangles (sorted keys in
  /// `surface`); or one kept face, a surface triangle, with all four points
  /// fixed (a flat tet lying on the surface with its fourth point on the
  /// surface too: no flip or smoothing move of the steps before reaches it),
  /// when that triangle is not a needle (kCapMinTriangleAngle).
  bool is_cap(Index t, const std::vector<Tri>& surface) const { return cap_kind(t, surface) == CapKind::kCap; }

  /// What the cap repair makes of the bad tet t: kCap as is_cap says; kFreeApex
  /// for one kept face, a surface triangle that is not a needle, under a free
  /// fourth point (the relaxed pass takes it: insert_over_fans); else kNone.
  CapKind cap_kind(Index t, const std::vector<Tri>& surface) const {
    int kept = 0, on_surface = 0, kept_face_index = 0;
    for (int f = 0; f < 4; ++f) {
      if (!kept_face(t, f)) continue;
      ++kept;
      kept_face_index = f;
      on_surface += std::binary_search(surface.begin(), surface.end(),
                                       topo::sorted_key(topo::face_of(m_.tet(t), f)))
                        ? 1
                        : 0;
    }
    if (kept == 1) {
      const Tri k = topo::face_of(m_.tet(t), kept_face_index);
      if (on_surface != 1 || smallest_angle(m_.point(k[0]), m_.point(k[1]), m_.point(k[2])) < kCapMinTriangleAngle)
        return CapKind::kNone;
      return free_point(t) ? CapKind::kFreeApex : CapKind::kCap;
    }
    return kept < 4 && on_surface >= 2 ? CapKind::kCap : CapKind::kNone;
  }

  /// Whether every point of tet t lies on a surface triangle.
  bool all_on_surface(Index t) const {
    for (Index v : m_.tet(t))
      if (v >= surface_.size() || surface_[v] == 0) return false;
    return true;
  }

  /// Whether a point of tet t is free (not in fixed_ as find_fixed left it;
  /// later points are free).
  bool free_point(Index t) const {
    for (Index v : m_.tet(t))
      if (v >= fixed_.size() || fixed_[v] == 0) return true;
    return false;
  }

  /// The tets the cavity of cap t starts from: with two kept faces the ring
  /// of the edge that t's two other faces share (t and its neighbours alone
  /// are not star-shaped from any point inside: that edge is reflex); with
  /// one, three or none (the relaxed pass), t and its neighbours across the
  /// faces that are not kept. Empty when the ring is open or too large, or a
  /// tet is in another region.
  std::vector<Index> cap_seed(Index t) const {
    std::array<int, 4> open{};  // the faces of t that are not kept
    int n_open = 0;
    for (int f = 0; f < 4; ++f)
      if (!kept_face(t, f)) open[static_cast<std::size_t>(n_open++)] = f;
    std::vector<Index> seed{t};
    if (n_open == 2) {
      // The faces opposite local vertices open[0], open[1] share the edge of
      // the other two vertices.
      std::array<int, 2> ends{};
      int m = 0;
      for (int v = 0; v < 4; ++v)
        if (v != open[0] && v != open[1]) ends[static_cast<std::size_t>(m++)] = v;
      EdgeRing r;
      if (!m_.edge_ring(t, topo::kEdgeIndex[ends[0]][ends[1]], r, static_cast<int>(kCapMaxCavity)) || !r.closed)
        return {};
      seed.assign(r.tets.begin(), r.tets.begin() + r.size);
    } else {
      for (int i = 0; i < n_open; ++i) seed.push_back(face_tet(m_.neighbour(t, open[static_cast<std::size_t>(i)])));
    }
    for (Index u : seed)
      if (m_.region(u) != m_.region(t)) return {};
    return seed;
  }

  /// Whether the star of x over link_ beats the cavity's tets by their
  /// dihedral angles: the smallest rises, and in the relaxed pass every new
  /// tet lies within kRelaxedCapAngles; otherwise, with two or three kept
  /// faces the largest does not rise. With one (a flat tet on the surface,
  /// whose best star may need a larger angle than the cavity had: sphere966
  /// stayed at 4.1 degrees without), the smaller of the smallest and 180 -
  /// the largest rises, and the largest stays within kCapMaxAngleSlack of the
  /// mesh's largest before the cap repair (couplingdown went from 173.6 to
  /// 176.5).
  bool cap_angles_rise(const Vec3& x, std::span<const Index> cavity, int kept) const {
    const AngleRange old_range = angle_range(nullptr, cavity);
    const AngleRange new_range = angle_range(&x, {});
    if (!(new_range.min > old_range.min)) return false;
    if (relaxed_caps_) return new_range.min >= kRelaxedCapAngles[0] && new_range.max <= kRelaxedCapAngles[1];
    if (kept == 1)
      return std::min(new_range.min, 180.0 - new_range.max) > std::min(old_range.min, 180.0 - old_range.max) &&
             new_range.max <= cap_max_angle_ + kCapMaxAngleSlack;
    return new_range.max <= old_range.max;
  }

  /// Whether x lies at least kCapMinSpacing times h(x) from every point of
  /// link_ that is not on the surface (surface_; new points are not).
  bool cap_spaced(const Vec3& x) const {
    const double reach = kCapMinSpacing * sizing_->at(x);
    for (const Tri& f : link_)
      for (Index v : f)
        if ((v >= surface_.size() || surface_[v] == 0) && norm(m_.point(v) - x) < reach) return false;
    return true;
  }

  /// Replaces the cap t (is_cap, or in the relaxed pass a free-apex cap or a
  /// tet of four surface points) and the tets around it by the star of one
  /// new point x over the cavity's boundary, the kept faces included (each
  /// becomes a face of a new tet). A free-apex cap first tries a point over
  /// a fan its apex covers (insert_over_fans). Otherwise the cavity starts
  /// from cap_seed, and x above the mean centroid of the kept faces, along
  /// their mean inward normal, at kCapHeights times h there (with no kept
  /// face: at t's centroid and beside each of its faces); insert_star does
  /// the rest.
  bool insert_cap(Index t) {
    const Tet kt = m_.tet(t);
    Vec3 mid{0, 0, 0}, inward{0, 0, 0};
    int kept = 0, kf = 0;  // kf: a kept face (the only one when kept == 1)
    for (int f = 0; f < 4; ++f) {
      if (!kept_face(t, f)) continue;
      Vec3 n;
      if (!kept_face_normal(t, f, n)) return false;
      const Tri k = topo::face_of(kt, f);
      mid = mid + (1.0 / 3.0) * (m_.point(k[0]) + m_.point(k[2]) + m_.point(k[1]));
      inward = inward + n;
      kf = f;
      ++kept;
    }
    if (kept == 4) return false;
    if (kept == 1 && free_point(t) && insert_over_fans(t, kf)) return true;
    const std::vector<Index> seed = cap_seed(t);
    if (seed.empty()) return false;
    std::vector<Vec3> starts;
    if (kept == 0) {
      // Four surface points and no kept face: from the centroid, and off each
      // face into the neighbour across it (the tet is flat: its best point
      // lies beside it), at a quarter and half the height of a regular tet
      // over that face.
      const auto p = corners(m_, kt);
      starts.push_back(0.25 * (p[0] + p[1] + p[2] + p[3]));
      for (int f = 0; f < 4; ++f) {
        const Tri k = topo::face_of(kt, f);  // outward: the apex lies out of t
        for (double fraction : {0.25, 0.5})
          starts.push_back(regular_apex(m_.point(k[0]), m_.point(k[1]), m_.point(k[2]), fraction));
      }
    } else {
      mid = (1.0 / static_cast<double>(kept)) * mid;
      const double ln = norm(inward);
      if (!(ln > 0.0)) return false;
      inward = (1.0 / ln) * inward;
      const double h = sizing_->at(mid);
      for (double height : kCapHeights) starts.push_back(mid + (height * h) * inward);
    }
    return insert_star(seed, starts, kept);
  }

  /// For a free-apex cap t (cap_kind) with kept face kf: for each point s of
  /// that face whose tets all hold t's free point a over a kept face (a alone
  /// covers the surface fan of s: over a curved fan its tets are as bad as the
  /// fan is curved, and no move of a helps them all: armadillo's worst), in
  /// order, a new point over that fan (insert_star from the tets of s,
  /// starting above s along the fan's mean inward normal at kCapHeights times
  /// h(s)), until one is inserted. Frees a to move for the tets left
  /// (polish_angles).
  bool insert_over_fans(Index t, int kf) {
    const Tet kt = m_.tet(t);
    const Index apex = kt[static_cast<std::size_t>(kf)];
    std::vector<Index> star;
    std::vector<Vec3> starts;
    for (Index s : topo::face_of(kt, kf)) {
      // The tets around s, from t across the faces through s that are not kept.
      if (!gather_star</*kCrossKept=*/false>(s, t, kCapMaxCavity)) continue;
      star.clear();
      for (const auto& e : star_) star.push_back(e.first);
      Vec3 inward{0, 0, 0};
      bool covered = true;
      for (Index u : star) {
        const Tet& k = m_.tet(u);
        const int la = topo::local_vertex(k, apex);
        if (la < 0 || !kept_face(u, la)) {
          covered = false;
          break;
        }
        Vec3 n;
        if (kept_face_normal(u, la, n)) inward = inward + n;
      }
      const double ln = norm(inward);
      if (!covered || !(ln > 0.0)) continue;
      const Vec3& x = m_.point(s);
      const double h = sizing_->at(x);
      starts.clear();
      for (double height : kCapHeights) starts.push_back(x + (height * h / ln) * inward);
      if (insert_star(star, starts, 1)) return true;
    }
    return false;
  }

  /// The search of insert_cap: from each start point x, the cavity grows from
  /// `seed` (grow_cavity) and x moves as in best_position; the best x by the
  /// worst measure of its star is taken when that beats the cavity's worst
  /// measure, the new tets off the surface hold their floors, the angles rise
  /// (cap_angles_rise with `kept` kept faces) and x is spaced (cap_spaced).
  bool insert_star(const std::vector<Index>& seed, const std::vector<Vec3>& starts, int kept) {
    // The best candidate: its point, cavity and worst new measure.
    double best_q = -std::numeric_limits<double>::infinity();
    Vec3 best_x{0, 0, 0};
    std::vector<Index> best_cavity, cavity;
    for (Vec3 x : starts) {
      cavity = seed;
      if (!grow_cavity(cavity, x)) continue;
      double q = star_quality(x);
      Vec3 moved;
      const double q_moved = best_position(x, q, moved);
      if (q_moved > q) {
        x = moved;
        q = q_moved;
      }
      if (!(q > best_q)) continue;
      double q_old = std::numeric_limits<double>::infinity();
      for (Index u : cavity) q_old = std::min(q_old, measure(corners(m_, m_.tet(u))));
      if (!(q > q_old)) continue;
      if (!off_surface_floors_hold(x, repair_floors(cavity))) continue;
      if (!cap_angles_rise(x, cavity, kept) || !cap_spaced(x)) continue;
      best_q = q;
      best_x = x;
      best_cavity = cavity;
    }
    if (best_cavity.empty()) return false;
    cavity = best_cavity;
    if (!grow_cavity(cavity, best_x) || cavity.size() != best_cavity.size()) return false;  // link_ for best_x
    fill_cavity(cavity, best_x);
    return true;
  }

  /// Replaces the tets of `cavity` by the star of a new point x over link_
  /// (the new tets take the region of cavity[0] and the outer faces' marks).
  void fill_cavity(std::span<const Index> cavity, const Vec3& x) {
    const Index p = m_.add_point(x);
    std::vector<Tet> fresh;
    for (const Tri& f : link_) fresh.push_back({f[0], f[1], f[2], p});
    const std::vector<Index> parent(fresh.size(), 0);
    m_.replace_cavity(cavity, fresh, parent);
    forget_created();
  }

  /// Replaces the sliver t and its four face neighbours by the star of a new
  /// point over the cavity's boundary, when the new tets are all positive, beat
  /// the cavity's worst measure, and the point keeps its distance.
  bool insert_into(Index t, bool guard_free = false) {
    if ((m_.flags(t) & TetMesh::kFrozenMask) != 0) return false;
    std::array<Index, 5> cavity{t, 0, 0, 0, 0};
    for (int f = 0; f < 4; ++f) {
      const Index n = m_.neighbour(t, f);
      if (n == kNoIndex || m_.region(face_tet(n)) != m_.region(t)) return false;
      cavity[static_cast<std::size_t>(f + 1)] = face_tet(n);
    }
    double q_old = std::numeric_limits<double>::infinity();
    for (Index u : cavity) q_old = std::min(q_old, measure(corners(m_, m_.tet(u))));
    // The cavity's boundary: the neighbours' faces away from t, less the faces
    // two neighbours share (seen once each way), which must not be frozen.
    link_.clear();
    std::vector<std::pair<Tri, bool>> faces;  // (sorted key, frozen), with link_ in step
    for (int f = 0; f < 4; ++f) {
      const Index n = m_.neighbour(t, f);
      const Index u = face_tet(n);
      for (int g = 0; g < 4; ++g) {
        if (g == face_local(n)) continue;
        const Tri k = topo::face_of(m_.tet(u), g);
        link_.push_back({k[0], k[2], k[1]});  // the new point lies inside: reversed
        faces.push_back({topo::sorted_key(k), m_.frozen(u, g)});
      }
    }
    std::vector<Tri> outer;
    for (std::size_t i = 0; i < link_.size(); ++i) {
      int same = 0;
      for (std::size_t j = 0; j < faces.size(); ++j) same += faces[j].first == faces[i].first ? 1 : 0;
      if (same == 1) {
        outer.push_back(link_[i]);
      } else if (faces[i].second) {
        return false;  // a frozen face inside the cavity
      }
    }
    // Every vertex of the cavity must stay a vertex of the refill: one whose
    // whole star lies inside the cavity (e.g. the point of a 1-4 split whose
    // tets include the sliver) would vanish from the mesh.
    for (Index u : cavity)
      for (Index v : m_.tet(u))
        if (std::none_of(outer.begin(), outer.end(),
                         [v](const Tri& f) { return f[0] == v || f[1] == v || f[2] == v; }))
          return false;
    link_ = outer;
    const Tet& k = m_.tet(t);
    const Vec3 centroid =
        0.25 * (m_.point(k[0]) + m_.point(k[1]) + m_.point(k[2]) + m_.point(k[3]));
    Vec3 x;
    const double q_centroid = star_quality(centroid);
    double q = best_position(centroid, q_centroid, x);
    if (!(q > q_centroid)) x = centroid;
    q = std::max(q, q_centroid);
    if (!(q > q_old)) return false;
    const double h = sizing_->at(x);
    for (Index u : link_points_)
      if (norm(m_.point(u) - x) < o_.insert_min_distance * h) return false;
    if (guard_free) {  // the repair: the new tets hold the old ones' floors (fresh_holds)
      const auto floors = repair_floors(cavity);
      for (const Tri& f : link_) {
        const int c = repair_class({f[0], f[1], f[2], kNoIndex});  // the new point is free
        if (measure({m_.point(f[0]), m_.point(f[1]), m_.point(f[2]), x}) < floors[static_cast<std::size_t>(c)])
          return false;
      }
    }
    fill_cavity(cavity, x);
    return true;
  }

  TetMesh& m_;
  const SizingField* sizing_;
  const OptimizeOptions& o_;
  OptimizeStats& st_;
  const double acute_, obtuse_;  ///< measure()'s scales
  std::vector<Index> queue_;
  std::vector<std::pair<Index, int>> star_;
  std::vector<Tri> link_;  ///< faces of the star being optimised, turned towards its apex
  std::vector<Index> link_points_;
  double cap_max_angle_ = 180.0;  ///< cap repair: the mesh's largest dihedral angle before it (degrees)
  bool relaxed_caps_ = false;     ///< cap repair: in the relaxed pass (repair_caps)
  std::vector<double> measures_old_, measures_new_;  ///< smoothing scratch
  std::vector<char> fixed_;     ///< per point, set by find_fixed(): on a frozen, hull or region face
  std::vector<char> surface_;   ///< per point, set by find_fixed(): on a surface triangle
  bool fixed_known_ = false;    ///< find_fixed() has run once
  bool interior_only_ = false;  ///< see set_interior_only
  bool pin_fixed_ = false;      ///< smoothing: tets with a fixed point are pinned
  double pin_floor_ = 1.0;      ///< smoothing: a pinned tet may fall to min(its measure, this)
  double repair_floor_ = kRepairFloor;  ///< see start_repair
  std::vector<Tet> fresh_;      ///< repair flips' scratch
  std::vector<Index> removal_star_;     ///< remove_point: the star of the point
  std::vector<Index> removal_targets_;  ///< remove_point: its link points
  std::vector<Index> parent_;
  std::vector<double> profile_old_, profile_new_, profile_best_;
  std::vector<char> pinned_;    ///< smoothing: per link_ face, the tet over it is pinned
  bool all_pinned_ = false;     ///< smoothing: every tet of the star is pinned
  std::vector<double> lower_;   ///< smoothing: per link_ face, the least measure accepted
  std::size_t last_failed_ = 0;  ///< smoothing_accepts: the link_ face whose tet failed the last trial
  /// Smoothing (keep_edge_sizes): an edge from the moving point to a link point
  /// off the surface, and the least squared length it may get.
  struct EdgeBound {
    Index u;
    double least2;
  };
  std::vector<EdgeBound> edge_bounds_;
  /// Size polish: an edge from the moving point to a link point off the
  /// surface, and h at its midpoint when the search began.
  struct SizeEdge {
    Index u;
    double h;
  };
  std::vector<SizeEdge> size_edges_;
  /// Per point: moved by the optimization (move_point); the points from
  /// first_new_point_ on were inserted by it. The size polish looks at their
  /// edges only (h costs a few microseconds a point on a graded field, and
  /// most of a large mesh is as the refiner left it).
  std::vector<char> moved_;
  Index first_new_point_ = m_.num_points();
  /// Angle and margin polish: per link_ face, the angles (degrees) accepted
  /// (the margin polish reads them for the tets with a surface point only).
  std::vector<AngleRange> polish_bounds_;
  /// Margin polish: per link_ face, the tet over it has a surface point, or
  /// none and is within the targets and must stay so, or none and is judged
  /// (outside the targets; or any, for a ring point).
  enum class MarginKind : unsigned char { kSurface, kGood, kBad };
  std::vector<MarginKind> margin_kind_;
  /// The mesh's extreme dihedral angles when a margin polish round, or the
  /// size polish, began.
  AngleRange mesh_angles_{};
  /// How the repair's operations judge their new tets (judged, beat).
  enum class Judge { kRepair, kAbsorb };
  Judge judge_ = Judge::kRepair;
  AngleRange size_limits_{};  ///< polish_sizes' surface_bounds limits
  std::vector<LongEdge> long_edges_;  ///< polish_sizes' long edges off the surface
  std::size_t flips_this_sweep_ = 0;
  std::size_t flip_budget_ = 0;
  /// Per slot: 1 + the Badness of the tet while known, 0 when unknown. Cleared
  /// for every tet an operation creates (a reused slot included) and for the
  /// star of a moved point, so a known entry of an alive tet is always current
  /// (the full-mesh scans of each sweep then evaluate only what changed).
  mutable std::vector<unsigned char> known_;
  /// bad_tets(): the bad live tets in slot order when it last ran, and the
  /// slots touched since.
  std::vector<Index> bad_, touched_;
  bool bad_known_ = false;
  RangeTree range_;  ///< angles()
  bool range_built_ = false;
  /// any_tet(): per point, a live tet that held it when last set.
  std::vector<Index> any_tet_;
  bool any_known_ = false;
  std::vector<Index> walk_;          ///< first_tet's scratch
  std::vector<char> marks_;          ///< polish_margins: per point, wanted or in the ring
  std::vector<Index> moved_list_;    ///< the points of moved_, in the order first moved
  std::vector<Tri> surface_keys_;    ///< repair_caps: the surface triangles, sorted keys
  bool surface_keys_known_ = false;
};

}  // namespace

Status validate(const OptimizeOptions& o) {
  const auto bad = [](const char* name, double v) {
    return invalid_input(fmt::format("optimize option {} = {} is out of range", name, v));
  };
  if (!std::isfinite(o.target_min_dihedral) || o.target_min_dihedral < 0)
    return bad("target_min_dihedral", o.target_min_dihedral);
  if (!std::isfinite(o.target_max_dihedral) || o.target_max_dihedral > 180 ||
      o.target_max_dihedral <= o.target_min_dihedral)
    return bad("target_max_dihedral", o.target_max_dihedral);
  if (o.sweeps < 0) return bad("sweeps", o.sweeps);
  if (o.repair_cycles < 0) return bad("repair_cycles", o.repair_cycles);
  if (!std::isfinite(o.insert_min_distance) || o.insert_min_distance < 0)
    return bad("insert_min_distance", o.insert_min_distance);
  if (!std::isfinite(o.max_flips_per_tet) || !(o.max_flips_per_tet > 0))
    return bad("max_flips_per_tet", o.max_flips_per_tet);
  return Status{};
}

Result<OptimizeStats> optimize(TetMesh& mesh, const SizingField* sizing,
                               const OptimizeOptions& options) {
  PDR_TRY(validate(options));
  const auto clock_start = std::chrono::steady_clock::now();
  OptimizeStats st;
  Optimizer opt(mesh, sizing, options, st);

  const AngleRange before = opt.angles();
  st.min_dihedral_before = before.min;
  st.max_dihedral_before = before.max;
  std::vector<Index> bad = opt.bad_tets();
  st.bad_before = bad.size();
  bool settled = false;  // a sweep changed nothing
  for (int sweep = 0; sweep < options.sweeps && !bad.empty(); ++sweep) {
    ++st.sweeps_run;
    opt.start_sweep();
    std::size_t changes = opt.reconnect(std::move(bad));
    changes += opt.insert_into_slivers();
    if (options.smooth) changes += opt.smooth();
    bad = opt.bad_tets();
    if (changes == 0) {
      settled = true;
      break;
    }
  }
  // Runs `round` up to `rounds` times while the number of bad tets with no
  // fixed point falls (the polishing and the repair rounds).
  const auto while_interior_falls = [&](int rounds, int& count, const auto& round) {
    std::size_t inner = opt.interior(bad).size();
    for (int r = 0; r < rounds && inner > 0; ++r) {
      ++count;
      opt.start_sweep();
      round();
      bad = opt.bad_tets();
      const std::size_t now = opt.interior(bad).size();
      if (now >= inner) break;
      inner = now;
    }
  };
  // Polishing rounds: reconnection and smoothing of the bad tets with no fixed
  // point alone, while their number falls (their work is small; the full sweeps
  // spend theirs on tets next to the boundary, many beyond repair).
  if (options.smooth && st.sweeps_run > 0 && !settled) {
    while_interior_falls(kPolishRounds, st.polish_rounds, [&] {
      opt.reconnect(opt.interior(bad));
      opt.set_interior_only(true, options.polish_pins_fixed);
      opt.smooth();
      opt.set_interior_only(false);
    });
  }
  // Interior repair: flips judged by the full measure, then smoothing of the
  // vertices of the bad tets with no fixed point, where a tet with a fixed
  // point may give way down to the repair floor, while their number falls.
  const bool repair = options.interior_repair && st.sweeps_run > 0;
  const auto repair_rounds = [&] {
    opt.find_fixed();
    opt.start_repair();
    while_interior_falls(kRepairRounds, st.repair_rounds, [&] {
      opt.repair_flips(opt.interior(bad));
      if (options.smooth) {
        opt.set_interior_only(true, true, opt.repair_floor());
        opt.smooth();
        opt.set_interior_only(false);
      }
    });
  };
  if (repair) repair_rounds();
  // Cap repair: a point into a cavity around each bad tet with two or three
  // kept faces, two of them on the surface (a flat tet on a nearly flat patch
  // of the surface). No smoothing follows (it may trade an angle near 180
  // degrees elsewhere for the worst tet of a star).
  // Then the relaxed pass (optimize.hpp, 5.): the caps the first left and the
  // flat tets of four surface points, with the new tets within [10, 165].
  if (options.repair_caps) {
    const std::size_t strict = opt.repair_caps(false);
    const std::size_t relaxed = opt.repair_caps(true);  // a statement of its own: after the first
    if (strict + relaxed > 0) bad = opt.bad_tets();
  }
  // Angle polish (optimize.hpp, 6.): the free points of the tets under the
  // smallest-angle target, raising their stars' smallest angle.
  if (options.smooth && options.polish_angles && opt.polish_angles() > 0) bad = opt.bad_tets();
  // Margin polish (optimize.hpp, 7.): the free points of the bad tets with
  // no surface point, raising their stars' worst margin to the targets.
  const bool margins = options.smooth && options.polish_margins;
  if (margins && opt.polish_margins() > 0) bad = opt.bad_tets();
  // Repair cycles (optimize.hpp, 8.): the repair rounds and the margin polish
  // again, while the bad tets with no fixed point get fewer.
  for (int cycle = 0; repair && margins && cycle < options.repair_cycles; ++cycle) {
    const std::size_t inner = opt.interior(bad).size();
    if (inner == 0) break;
    ++st.repair_cycles;
    repair_rounds();
    if (opt.polish_margins() > 0) bad = opt.bad_tets();
    if (opt.interior(bad).size() >= inner) break;
  }
  // The margin polish's last pass (optimize.hpp, 7.), with a finer search.
  if (margins && !opt.interior(bad).empty() && opt.polish_margins(kFineSearchEnd) > 0) bad = opt.bad_tets();
  // Absorption (optimize.hpp, 10.): the bad tets with no fixed point handed to
  // the tets on the surface where they can take them, then the repair rounds
  // and a margin polish within the mesh's extremes, while cycles find fewer.
  if (repair && margins && options.absorb && options.surface_room) {
    std::size_t best = opt.interior(bad).size();
    for (int cycle = 0, stale = 0; cycle < kAbsorbCycles && stale < kAbsorbPatience && best > 0; ++cycle) {
      ++st.absorb_cycles;
      opt.start_sweep();
      if (opt.absorb(opt.interior(bad)) > 0) bad = opt.bad_tets();
      repair_rounds();
      if (opt.polish_margins(kFineSearchEnd, /*extremes=*/true, kAbsorbRingLayers) > 0) bad = opt.bad_tets();
      const std::size_t now = opt.interior(bad).size();
      stale = now < best ? 0 : stale + 1;
      best = std::min(best, now);
    }
  }
  // The cap repair's relaxed pass again (optimize.hpp, 5.): the caps and flat
  // tets of four surface points that the steps since made, or left in changed
  // cavities.
  if (options.repair_caps && options.late_caps && opt.repair_caps(true) > 0) bad = opt.bad_tets();
  // Size polish (optimize.hpp, 9.): the free points of the edges off the
  // surface out of the size band, moved back towards it where no tet gets worse.
  if (options.smooth && options.polish_sizes && sizing != nullptr && opt.polish_sizes() > 0) bad = opt.bad_tets();
  st.bad_after = bad.size();
  if (st.points_removed + st.edges_collapsed > 0 && !options.keep_point_indices) mesh.remove_unused_points();
  const AngleRange after = opt.angles();
  st.min_dihedral_after = after.min;
  st.max_dihedral_after = after.max;
  st.seconds = seconds_since(clock_start);
  return st;
}

}  // namespace pdrmesh
