// SPDX-License-Identifier: AGPL-3.0-or-later
// The optimizer's working state (private to core/optimize): OptimizerState, what one
// optimization knows of its mesh, and class Optimizer, whose passes live one family to a
// file (state.cpp, reconnect.cpp, slivers.cpp, smooth.cpp, repair.cpp, caps.cpp,
// polish.cpp, size_polish.cpp; moves.hpp runs their point moves, side by side where
// allowed), and the geometric helpers they share. optimize.cpp runs the passes in order
// (see optimize.hpp).
#pragma once

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/parallel_sort.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <iterator>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <tuple>
#include <unordered_map>
#include <utility>
#include <vector>

#include "pdrmesh/fixed_chunks.hpp"
#include "pdrmesh/flips.hpp"
#include "pdrmesh/insert.hpp"
#include "pdrmesh/predicates.hpp"
#include "pdrmesh/quality.hpp"
#include "pdrmesh/optimize.hpp"
#include "pdrmesh/topology.hpp"
#include "tuning.hpp"

namespace pdrmesh::optimize_detail {

enum class Badness { kGood, kBad, kSliver };

/// A tet's class by its points (optimize.hpp, Points): interior (no fixed
/// point), on the surface (a surface point), or on a frozen face only (fixed
/// points, none on the surface: a leaf's interface or a region interface,
/// inside the final mesh, so held like the interior ones).
enum class TetClass : unsigned char { kInterior, kSurface, kFrozen };

/// A value per TetClass (the repair's floors).
struct ClassFloors {
  std::array<double, 3> v{};
  double& operator[](TetClass c) { return v[static_cast<std::size_t>(c)]; }
  double operator[](TetClass c) const { return v[static_cast<std::size_t>(c)]; }
};

/// The smoothing's rule (smooth): which points move and how a move is judged.
/// Sweeps move every free point of a bad tet and compare whole stars; the
/// polishing and repair rounds move the points of the interior bad tets only,
/// and pin the tets with a fixed point (they must not fall below min(their
/// measure, pin_floor) where they hold a surface point, their measure else).
struct SmoothRule {
  bool interior_only = false;
  bool pin_fixed = false;
  double pin_floor = 1.0;
};

/// The cap repair's rule (repair_caps, cap_angles_rise): strict, or the
/// relaxed pass; and the mesh's largest dihedral angle before the pass
/// (degrees), which a one-kept-face cap's star may pass by kCapMaxAngleSlack only.
struct CapRule {
  bool relaxed = false;
  double max_angle = 180.0;
};

/// The bounds of the size polish (polish_sizes): the mesh's extremes as it
/// began, and the limits its tets with a surface point keep (surface_bounds)
/// where they have the room; without it they are held as the others are.
struct SizeBounds {
  AngleRange mesh{};
  AngleRange limits{};
  bool room = true;
};

/// The local attempts whose failures the optimizer remembers (Optimizer::failed_before):
/// per tet, the flips of the reconnection, a sliver's insertion and the repair and
/// absorption operations; per point, the moves of the smoothing, the angle, margin
/// (a bad tet's point, or a ring point) and size polish.
enum class Attempt : unsigned char { kFlips, kSliver, kRepair, kAbsorb, kSmooth, kAngle, kMargin, kRing, kSize };
inline constexpr std::size_t kAttempts = static_cast<std::size_t>(Attempt::kSize) + 1;

/// The parameters an attempt depends on beyond its tets (a floor, the mesh's
/// extremes, a search length): a failure counts only under the same ones.
using AttemptKey = std::array<double, 4>;

/// The cap repair's view of a bad tet (Optimizer::cap_kind).
enum class CapKind { kNone, kCap, kFreeApex };

inline std::array<Vec3, 4> corners(const TetMesh& m, const Tet& k) {
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
inline double min_sine(const std::array<Vec3, 4>& p, double acute, double obtuse) {
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
inline double inverse_sine(double degrees) {
  const double s = std::sin(degrees * (3.14159265358979323846 / 180.0));
  return s > 1e-3 ? 1.0 / s : 1e3;
}
constexpr double kInfinity = std::numeric_limits<double>::infinity();

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

  /// Measures every block (in parallel on a large mesh), handing each live
  /// tet's angles to visit(t, range) on the way (the first scan of bad tets
  /// reads them too, so the mesh is measured once).
  template <class Visit>
  void build(const TetMesh& m, Visit&& visit) {
    const Index blocks = (m.num_slots() + kRangeBlock - 1) / kRangeBlock;
    cap_ = 1;
    while (cap_ < blocks) cap_ *= 2;
    node_.assign(2 * static_cast<std::size_t>(cap_), kNeutral);
    is_dirty_.assign(cap_, 0);
    dirty_.clear();
    const auto scan = [&](const tbb::blocked_range<Index>& r) {
      for (Index b = r.begin(); b < r.end(); ++b) node_[cap_ + b] = measure_block(m, b, visit);
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
    return measure_block(m, b, [](Index, const AngleRange&) {});
  }
  template <class Visit>
  static AngleRange measure_block(const TetMesh& m, Index b, Visit&& visit) {
    AngleRange r = kNeutral;
    const Index end = std::min(m.num_slots(), (b + 1) * kRangeBlock);
    for (Index t = b * kRangeBlock; t < end; ++t) {
      if (!m.alive(t)) continue;
      const auto p = corners(m, m.tet(t));
      const AngleRange a = dihedral_range(p[0], p[1], p[2], p[3]);
      visit(t, a);
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
inline Vec3 regular_apex(const Vec3& a, const Vec3& b, const Vec3& c, double fraction = 1.0) {
  const Vec3 n = cross(b - a, c - a);
  const double ln = norm(n);
  const Vec3 g = (1.0 / 3.0) * (a + b + c);
  if (!(ln > 0.0)) return g;
  const double edge = (norm(b - a) + norm(c - b) + norm(a - c)) / 3.0;
  return g + (fraction * std::sqrt(2.0 / 3.0) * edge / ln) * n;
}

/// The smallest angle of triangle (a, b, c), in degrees.
inline double smallest_angle(const Vec3& a, const Vec3& b, const Vec3& c) {
  const auto at = [](const Vec3& p, const Vec3& q, const Vec3& r) {
    const Vec3 u = q - p, v = r - p;
    return std::atan2(norm(cross(u, v)), dot(u, v)) * (180.0 / 3.14159265358979323846);
  };
  return std::min({at(a, b, c), at(b, c, a), at(c, a, b)});
}

/// f(item, out) for each item, appending to out: with `parallel`, side by side
/// over fixed chunks whose outputs follow one another in chunk order, else in
/// turn. The same list either way, for any thread count (the optimizer's
/// scans with parallel_moves).
template <class T, class F>
std::vector<Index> each_chunk(const std::vector<T>& items, F&& f, bool parallel = true) {
  std::vector<Index> out;
  if (!parallel) {
    for (const T& x : items) f(x, out);
    return out;
  }
  constexpr std::size_t kGrain = 256;
  std::vector<std::vector<Index>> parts(detail::chunk_count(items.size(), kGrain));
  detail::for_each_chunk(items.size(), kGrain, [&](std::size_t c, std::size_t lo, std::size_t hi) {
    for (std::size_t i = lo; i < hi; ++i) f(items[i], parts[c]);
  });
  return detail::concatenate(parts);
}

/// Sorts v and drops repeats (tbb::parallel_sort with `parallel`: the same result).
inline void sort_unique(std::vector<Index>& v, bool parallel = false) {
  if (parallel) {
    tbb::parallel_sort(v.begin(), v.end());
  } else {
    std::sort(v.begin(), v.end());
  }
  v.erase(std::unique(v.begin(), v.end()), v.end());
}

/// What one optimization knows of its mesh, shared by the optimizer that
/// holds it and its hands (Optimizer's second constructor), which run point
/// moves side by side (Optimizer::move_points, moves.hpp).
struct OptimizerState {
  explicit OptimizerState(Index points) : first_new_point(points) {}
  std::vector<char> fixed;    ///< per point, set by find_fixed(): on a frozen, hull or region face
  std::vector<char> surface;  ///< per point, set by find_fixed(): on a surface triangle
  bool fixed_known = false;   ///< find_fixed() has run once
  /// Per point: moved by the optimization (move_point); the points from
  /// first_new_point on were inserted by it. The size polish looks at their
  /// edges only (h costs a few microseconds a point on a graded field, and
  /// most of a large mesh is as the refiner left it).
  std::vector<char> moved;
  Index first_new_point;
  std::vector<Index> moved_list;  ///< the points of moved, in the order first moved
  /// Per slot: 1 + the Badness of the tet while known, 0 when unknown. Cleared
  /// for every tet an operation creates (a reused slot included) and for the
  /// star of a moved point, so a known entry of an alive tet is always current
  /// (the full-mesh scans of each sweep then evaluate only what changed).
  std::vector<unsigned char> known;
  /// bad_tets(): the bad live tets in slot order when it last ran, and the
  /// slots touched since.
  std::vector<Index> bad, touched;
  bool bad_known = false;
  RangeTree range;  ///< angles()
  bool range_built = false;
  /// any_tet(): per point, a live tet that held it when last set.
  std::vector<Index> any_tet;
  bool any_known = false;
  std::vector<Tri> surface_keys;  ///< repair_caps: the surface triangles, sorted keys
  bool surface_keys_known = false;
  /// The work queue's memory. clock counts the tets touched (touch); stamp
  /// holds per point the clock when a tet holding it was last created or
  /// moved. A failed attempt notes the clock (Failures::at, per slot or
  /// point); it is not made again while no point of its tet (or the point
  /// itself, whose star holds every tet it reads) has a later stamp and the
  /// parameters are the same: it would fail again, so rounds cost what
  /// changed since the last one, not what is bad.
  /// (A map, as few slots or points ever fail; it is only looked up, never walked.)
  struct Failures {
    std::unordered_map<Index, std::uint64_t> at;  ///< slot or point -> the clock at its failure
    std::uint64_t from = 0;  ///< failures before this clock were under other parameters
    AttemptKey key{};
  };
  std::array<Failures, kAttempts> failed{};
  std::vector<std::uint64_t> stamp;
  std::uint64_t clock = 1;
  /// try_flips' edge removals that failed, per edge (the two point indices,
  /// lower first): why, and the clock then (Optimizer::try_flips).
  struct FailedRemoval {
    Outcome outcome;
    std::uint64_t clock;
  };
  std::unordered_map<std::uint64_t, FailedRemoval> failed_removals;
};

/// What a hand's move_point leaves to the optimizer that holds the state: the
/// point it moved and the tets of its star, in star order (Optimizer::note_moved).
struct MoveNote {
  Index point = kNoIndex;
  std::vector<Index> tets;
};

/// One optimization run over a mesh: the passes that optimize() calls in turn and the
/// scratch of one local operation. The state the passes share (the bad-tet list, what is
/// known of each tet and point) is an OptimizerState, held by this optimizer and shared
/// with its hands (the second constructor), which move points side by side (moves.hpp).
class Optimizer {
 public:
  Optimizer(TetMesh& mesh, const SizingField* sizing, const OptimizeOptions& o, OptimizeStats& st)
      : m_(mesh),
        sizing_(sizing),
        o_(o),
        st_(st),
        acute_(inverse_sine(o.target_min_dihedral)),
        obtuse_(inverse_sine(180.0 - o.target_max_dihedral)),
        own_(std::make_unique<OptimizerState>(mesh.num_points())),
        s_(*own_) {}

  /// A hand of `holder`: its own scratch and stats, the holder's mesh and
  /// state. A hand runs a pass's point moves (move_points) on points whose
  /// stars no other hand reads at the same time, and its move_point writes the
  /// point and forgets its star's badness, leaving the rest to the holder
  /// (note_moved).
  Optimizer(Optimizer& holder, OptimizeStats& st, MoveNote& note)
      : m_(holder.m_),
        sizing_(holder.sizing_),
        o_(holder.o_),
        st_(st),
        acute_(holder.acute_),
        obtuse_(holder.obtuse_),
        s_(holder.s_),
        note_(&note) {}

  /// The quality that smoothing and insertion raise: min_sine scaled to the
  /// targets (>= 1 for a good tet).
  double measure(const std::array<Vec3, 4>& p) const { return min_sine(p, acute_, obtuse_); }

  class RepairCriterion;
  class AbsorbCriterion;
  /// Which operations repair_tet tries after its flips.
  struct RepairMoves {
    bool insert = false;    ///< a point into the tet's cavity (insert_into)
    bool collapse = false;  ///< an edge collapse, last (collapse_edge)
  };

  // state.cpp
  bool failed_before(Attempt a, Index i) const;
  void remember_failure(Attempt a, Index i);
  void attempt_key(Attempt a, const AttemptKey& key);
  Badness badness(Index t) const;
  Badness compute_badness(Index t) const;
  Badness badness_of(const AngleRange& r) const;
  std::vector<unsigned char> bad_flags();
  const std::vector<Index>& bad_tets();
  AngleRange angles();
  Index any_tet(Index v);
  void star_tets(Index v, std::vector<Index>& out);
  Index first_tet(Index v);
  void find_fixed();
  std::vector<Index> interior(const std::vector<Index>& tets) const;
  void start_sweep();

  // reconnect.cpp
  std::size_t reconnect(std::vector<Index> seeds);

  // slivers.cpp
  std::size_t insert_into_slivers();

  // smooth.cpp
  std::size_t smooth(const SmoothRule& rule = {});

  // repair.cpp
  double repair_floor();
  template <class Criterion>
  std::size_t repair_flips(std::vector<Index> seeds, Criterion& criterion, RepairMoves moves);
  std::size_t absorb(std::vector<Index> seeds);

  // caps.cpp
  std::size_t repair_caps(bool relaxed);

  // polish.cpp
  std::size_t polish_angles();
  std::size_t polish_margins(double end = kSearchEnd, bool extremes = false, int layers = 1);

  // size_polish.cpp
  std::size_t polish_sizes(bool room);

 private:
  /// An edge off the surface that polish_sizes found long.
  struct LongEdge {
    Index a, b;  ///< a < b
    Index t;     ///< a tet holding it when found, and its local edge
    int e;
    bool operator<(const LongEdge& o) const { return std::tie(a, b, t, e) < std::tie(o.a, o.b, o.t, o.e); }
    bool operator==(const LongEdge&) const = default;
  };
  /// Smoothing (keep_edge_sizes): an edge from the moving point to a link point
  /// off the surface, and the least squared length it may get.
  struct EdgeBound {
    Index u;
    double least2;
  };
  /// Size polish: an edge from the moving point to a link point off the
  /// surface, and h at its midpoint when the search began.
  struct SizeEdge {
    Index u;
    double h;
  };
  /// Margin polish: per link_ face, the tet over it has a surface point, or
  /// none and is within the targets and must stay so, or none and is judged
  /// (outside the targets; or any, for a ring point).
  enum class MarginKind : unsigned char { kSurface, kGood, kBad };

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

  bool off_surface(Index v) const { return v >= s_.surface.size() || s_.surface[v] == 0; }

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

  /// Whether the bad tet t is a cap (optimize.hpp, 5.): two or three kept
  /// faces (kept_face), two of them surface triangles (sorted keys in
  /// `surface`); or one kept face, a surface triangle, with all four points
  /// fixed (a flat tet lying on the surface with its fourth point on the
  /// surface too: no flip or smoothing move of the steps before reaches it),
  /// when that triangle is not a needle (kCapMinTriangleAngle).
  bool is_cap(Index t, const std::vector<Tri>& surface) const { return cap_kind(t, surface) == CapKind::kCap; }

  // state.cpp
  bool push_created();
  void forget_created();
  void touch(Index t);
  bool free_tet(Index t) const;
  bool on_surface(const Tri& f) const;
  void gather_link_points();
  void gather_link(Index v, Index start);
  void move_point(Index v, const Vec3& x);
  void note_moved(const MoveNote& note);
  void mark_moved(Index v);
  static bool within(const AngleRange& r, const AngleRange& bounds);
  bool surface_triangle(std::size_t i) const;
  bool kept_face(Index t, int f) const;
  bool kept_face_normal(Index t, int f, Vec3& n) const;
  AngleRange angle_range(const Vec3* x, std::span<const Index> tets) const;
  bool all_on_surface(Index t) const;
  bool free_point(Index t) const;

  class SizeCriterion;

  /// Counts the outcome of an operation of kind `op` in st_.tried; returns it.
  Outcome tally(LocalOperation op, Outcome o) {
    ++st_.tried[static_cast<std::size_t>(op)][static_cast<std::size_t>(o)];
    return o;
  }

  // reconnect.cpp
  Outcome try_flips(Index t);

  // slivers.cpp
  void fill_cavity(std::span<const Index> cavity, const Vec3& x);
  Outcome insert_into(Index t, RepairCriterion* guard = nullptr);

  // smooth.cpp
  double star_quality(const Vec3& x) const;
  double best_position(const Vec3& old, double q0, Vec3& best, const SmoothRule* profile = nullptr);
  bool star_measures(const Vec3& x, std::vector<double>& out,
                     double floor = -std::numeric_limits<double>::infinity()) const;
  void to_profile(const std::vector<double>& measures, std::vector<double>& out) const;
  bool keeps_edge_sizes(const Vec3& x) const;
  bool smoothing_accepts(const Vec3& x);
  std::optional<double> link_measure(std::size_t i, const Vec3& x) const;
  void bound_edge_sizes(const Vec3& old);
  Outcome smooth_vertex(Index v, Index start, const SmoothRule& rule);
  void bad_star_points(std::vector<Index>& next) const;

  // moves.hpp
  template <class Move, class After>
  std::size_t move_points(std::span<const Index> todo, Attempt kind, bool tallied, Move&& move, After&& after,
                          std::vector<Index>& out);
  /// move_points for a pass that wants nothing of the moved stars.
  template <class Move>
  std::size_t move_points(std::span<const Index> todo, Attempt kind, Move&& move) {
    std::vector<Index> none;
    return move_points(todo, kind, false, std::forward<Move>(move), [](Optimizer&, std::vector<Index>&) {}, none);
  }

  // repair.cpp
  double measured(const Tet& k) const;
  TetClass tet_class(const Tet& k) const;
  ClassFloors repair_floors(std::span<const Index> tets, double surface_floor, double* worst = nullptr) const;
  template <class Criterion>
  Outcome repair_tet(Index t, Criterion& criterion, RepairMoves moves);
  template <class Criterion>
  Outcome remove_point(Index t, Criterion& criterion);
  template <class Criterion>
  Outcome collapse_edge(Index t, Criterion& criterion);
  void replace_with_point(std::span<const Index> old, const Vec3& x);
  std::optional<Tet> cone_tet(Index s, int lv, Index w) const;
  template <class Criterion>
  double cone_quality(Index w, double beat, Criterion& criterion) const;

  // caps.cpp
  bool off_surface_floors_hold(const Vec3& x, const ClassFloors& floors) const;
  bool grow_cavity(std::vector<Index>& cavity, const Vec3& x);
  CapKind cap_kind(Index t, const std::vector<Tri>& surface) const;
  std::vector<Index> cap_seed(Index t) const;
  bool cap_angles_rise(const Vec3& x, std::span<const Index> cavity, int kept, const CapRule& rule) const;
  bool cap_spaced(const Vec3& x) const;
  Outcome insert_cap(Index t, const CapRule& rule);
  bool insert_over_fans(Index t, int kf, const CapRule& rule);
  bool insert_star(const std::vector<Index>& seed, const std::vector<Vec3>& starts, int kept, const CapRule& rule);

  // polish.cpp
  bool polish_point(Index v, Index start);
  AngleRange target_bounds(const AngleRange& r) const;
  double margin(const AngleRange& r) const;
  static AngleRange surface_bounds(const AngleRange& old, const AngleRange& limits, const AngleRange& mesh);
  bool margin_point(Index v, Index start, double end, bool ring, bool extremes, const AngleRange& mesh);

  // size_polish.cpp
  std::pair<std::size_t, double> size_excess(const Vec3& x) const;
  bool ring_of(const LongEdge& le) const;
  AngleRange size_bounds(const Tet& t, const SizeBounds& bounds) const;
  std::size_t size_flips(const SizeBounds& bounds);
  std::size_t size_splits(const SizeBounds& bounds);
  bool size_point(Index v, Index start, const SizeBounds& bounds);

  /// h(x) from the sizing field, each query started where the last one ended
  /// (the same value as sizing_->at(x)).
  double size_at(const Vec3& x) const { return sizing_->at(x, size_hint_); }

  TetMesh& m_;
  const SizingField* sizing_;
  mutable SizingHint size_hint_;  ///< size_at's memory of its last query
  const OptimizeOptions& o_;
  OptimizeStats& st_;
  const double acute_, obtuse_;  ///< measure()'s scales
  std::unique_ptr<OptimizerState> own_;  ///< the state, in the optimizer that holds it (null in a hand)
  OptimizerState& s_;
  /// In a hand (parallel moves): where move_point notes what it leaves to
  /// the holder (MoveNote); null in the holder.
  MoveNote* note_ = nullptr;
  std::vector<Index> queue_;
  std::vector<std::pair<Index, int>> star_;
  std::vector<Tri> link_;  ///< faces of the star being optimised, turned towards its apex
  std::vector<Index> link_points_;
  std::vector<double> measures_old_, measures_new_;  ///< smoothing scratch
  std::vector<Tet> fresh_;      ///< scratch: the new tets of a removal, collapse or split
  std::vector<Index> removal_star_;     ///< remove_point: the star of the point
  std::vector<Index> removal_targets_;  ///< remove_point: its link points
  std::vector<Index> parent_;
  std::vector<double> profile_old_, profile_new_, profile_best_;
  std::vector<char> pinned_;    ///< smoothing: per link_ face, the tet over it is pinned
  bool all_pinned_ = false;     ///< smoothing: every tet of the star is pinned
  std::vector<double> lower_;   ///< smoothing: per link_ face, the least measure accepted
  std::size_t last_failed_ = 0;  ///< smoothing_accepts: the link_ face whose tet failed the last trial
  std::vector<EdgeBound> edge_bounds_;
  std::vector<SizeEdge> size_edges_;
  /// Angle and margin polish: per link_ face, the angles (degrees) accepted
  /// (the margin polish reads them for the tets with a surface point only).
  std::vector<AngleRange> polish_bounds_;
  std::vector<MarginKind> margin_kind_;
  std::vector<LongEdge> long_edges_;  ///< polish_sizes' long edges off the surface
  std::size_t flips_this_sweep_ = 0;
  std::size_t flip_budget_ = 0;
  std::vector<Index> walk_;          ///< first_tet's scratch
  std::vector<char> marks_;          ///< polish_margins: per point, wanted or in the ring
  std::vector<Index> claims_;        ///< move_points: per point, the window place that claims it
};

/// The interior repair's criterion (repair rounds): a new tet scores its
/// measure(); the new tets must beat the worst replaced tet's measure, and
/// each must hold the floor of its class (repair_floors): no interior tet is
/// traded for a worse one, and no tet with a surface point falls under the
/// repair floor where the replaced ones with a surface point did not.
class Optimizer::RepairCriterion final {
 public:
  /// `surface_floor`: the repair floor (repair_floor) for tets with a surface point.
  RepairCriterion(const Optimizer& o, double surface_floor) : o_(o), surface_floor_(surface_floor) {}
  double bar(std::span<const Index> old) {
    double worst = 0.0;
    floors_ = o_.repair_floors(old, surface_floor_, &worst);
    return worst;
  }
  double score(const Tet& k) const { return o_.measure(corners(o_.m_, k)); }
  double score(const std::array<Vec3, 4>& p, bool /*surface*/) const { return o_.measure(p); }
  bool accepts(std::span<const Tet> fresh) const {
    for (const Tet& k : fresh)
      if (o_.measure(corners(o_.m_, k)) < floors_[o_.tet_class(k)]) return false;
    return true;
  }
  void done(std::span<const Index>, std::span<const double>) const {}
  /// What its decisions depend on beyond the tets (Optimizer::attempt_key).
  AttemptKey key() const { return {surface_floor_, 0.0, 0.0, 0.0}; }
  /// The floors bar() found, per class.
  const ClassFloors& floors() const { return floors_; }
  double surface_floor() const { return surface_floor_; }

 private:
  const Optimizer& o_;
  double surface_floor_;
  ClassFloors floors_{};
};

/// The absorption's criterion: a new tet with no surface point scores its
/// measure(); one with a surface point scores +inf when it lies within the
/// mesh's extremes as the absorption began, else -inf. So an operation is
/// judged by the tets off the surface (they must beat the worst replaced
/// one with no surface point), and no extreme of the mesh gets worse.
class Optimizer::AbsorbCriterion final {
 public:
  AbsorbCriterion(const Optimizer& o, const AngleRange& extremes) : o_(o), extremes_(extremes) {}
  double bar(std::span<const Index> old) const {
    double q = kInfinity;
    for (Index t : old)
      if (o_.tet_class(o_.m_.tet(t)) != TetClass::kSurface) q = std::min(q, o_.measure(corners(o_.m_, o_.m_.tet(t))));
    return q;
  }
  double score(const Tet& k) const {
    return score(corners(o_.m_, k), o_.tet_class(k) == TetClass::kSurface);
  }
  double score(const std::array<Vec3, 4>& p, bool surface) const {
    if (!surface) return o_.measure(p);
    return within(dihedral_range(p[0], p[1], p[2], p[3]), extremes_) ? kInfinity : -kInfinity;
  }
  bool accepts(std::span<const Tet>) const { return true; }
  void done(std::span<const Index>, std::span<const double>) const {}
  /// What its decisions depend on beyond the tets (Optimizer::attempt_key).
  AttemptKey key() const { return {extremes_.min, extremes_.max, 0.0, 0.0}; }

 private:
  const Optimizer& o_;
  AngleRange extremes_;
};

}  // namespace pdrmesh::optimize_detail
