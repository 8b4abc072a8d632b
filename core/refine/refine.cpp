// SPDX-License-Identifier: AGPL-3.0-or-later
// The grid generation passes: advancing-front point creation, rejection,
// insertion and local reconnection (see refine.hpp).
#include "pdrmesh/refine.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <bit>
#include <span>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <tuple>
#include <utility>
#include <vector>

#include "failed_edges.hpp"
#include "pdrmesh/flips.hpp"
#include "pdrmesh/insert.hpp"
#include "pdrmesh/predicates.hpp"
#include "pdrmesh/bvh.hpp"
#include "pdrmesh/closest_point.hpp"
#include "pdrmesh/topology.hpp"
#include "pdrmesh/stopwatch.hpp"

namespace pdrmesh {
namespace {

using Clock = std::chrono::steady_clock;
using refine_detail::FailedEdges;

struct Candidate {
  Vec3 p;
  Index tet;  ///< the tet it advances into: where its location walk starts
  Tet vertices;  ///< that tet's vertices when the candidate was made
};

/// Whether a lower bound of the distance from p to triangle (a, b, c) is below
/// r: the larger of the distance to its plane and the distance to its bounding
/// sphere about the centroid. The sphere's part is only computed when the
/// plane's is below r (the larger of the two is below r only if both are).
bool face_bound_below(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& p, double r) {
  const Vec3 n = cross(b - a, c - a);
  const double ln = norm(n);
  const double plane = ln > 0.0 ? std::fabs(dot(n, p - a)) / ln : 0.0;
  if (!(plane < r)) return false;
  const Vec3 g = (1.0 / 3.0) * (a + b + c);
  const double radius = std::sqrt(std::max({dot(a - g, a - g), dot(b - g, b - g), dot(c - g, c - g)}));
  return norm(p - g) - radius < r;
}

class Refiner {
 public:
  /// `sizing` may be null for insert_all alone (run() needs it).
  Refiner(TetMesh& mesh, const SizingField* sizing, const RefineOptions& options)
      : m_(mesh), sizing_(sizing), o_(options) {
    const double angle = o_.min_max_angle;
    bad_cos_ = angle > 0.0 ? std::cos(angle * 3.14159265358979323846 / 180.0) : -2.0;
    if (o_.insert_within) {
      for (std::size_t i = 0; i < m_.boundary().size(); ++i)
        if (m_.boundary_ids()[i] == 0) cuts_.push_back(topo::sorted_key(m_.boundary()[i]));
      std::sort(cuts_.begin(), cuts_.end());
    }
  }

  /// h at the mesh's points, one per point, instead of evaluating them in run().
  void set_sizes(std::vector<double> sizes) { h_ = std::move(sizes); }
  /// h at every point after run().
  std::vector<double> take_sizes() { return std::move(h_); }

  RefineStats run(const RefineProgress& progress) {
    const auto t0 = Clock::now();
    RefineStats stats;
    if (h_.size() != m_.num_points()) {
      h_.resize(m_.num_points());
      for (Index v = 0; v < m_.num_points(); ++v) h_[v] = sizing_->at(m_.point(v), sizing_hint_);
    }
    while (last_tet_ + 1 < m_.num_slots() && !m_.alive(last_tet_)) ++last_tet_;
    bool midpoints = false;
    for (int pass = 1; pass <= o_.max_passes; ++pass) {
      const auto tp = Clock::now();
      RefinePassStats ps;
      ps.pass = pass;
      if (o_.spatial_order && m_.num_tets() >= o_.spatial_order_min_tets &&
          m_.num_tets() >= sorted_tets_ + sorted_tets_ / 4)
        sort_tets();  // after each growth by a quarter
      deactivate();
      collect(midpoints);
      ps.candidates = candidates_.size();
      // A tet none of whose candidates went in, and that no insertion or flip
      // has replaced meanwhile, is retired (inactive) until an operation
      // touches it again: its candidates would fail the same way next pass.
      std::size_t groups = 0;
      for (std::size_t i = 0; i < candidates_.size();) {
        // Past the deadline the pass stops too (checked every 1024 tets' candidates):
        // the mesh stays valid, and a caller that set one fails the run anyway.
        if (o_.deadline && (++groups & 1023) == 0 && Clock::now() >= *o_.deadline) {
          stats.stopped_at_deadline = true;
          break;
        }
        const Candidate& first = candidates_[i];
        bool any = false;
        std::size_t j = i;
        for (; j < candidates_.size() && candidates_[j].tet == first.tet &&
               candidates_[j].vertices == first.vertices;
             ++j) {
          prefetch_candidates(j);
          any = process(candidates_[j], ps) || any;
        }
        if (!any && m_.alive(first.tet) && m_.tet(first.tet) == first.vertices)
          m_.set_active(first.tet, false);
        i = j;
      }
      if (o_.reconnect && o_.min_max && o_.defer_min_max) ps.flips += reconnect_pass(ps.inserted);
      ps.tets = m_.num_tets();
      ps.seconds = seconds_since(tp);
      stats.points_added += ps.inserted;
      stats.passes.push_back(ps);
      if (progress) progress(ps);
      if (stats.stopped_at_deadline || (o_.deadline && Clock::now() >= *o_.deadline)) {
        stats.stopped_at_deadline = true;
        break;
      }
      if (ps.inserted == 0) {
        if (midpoints) break;
        midpoints = true;
      } else {
        midpoints = false;
      }
    }
    stats.seconds = seconds_since(t0);
    return stats;
  }

  /// insert_points (refine.hpp): the points in rounds, coarse to fine, each
  /// round in the Morton order of the coordinates (ties by index), so that
  /// each point lies near the one before. Each is located by a walk from the
  /// last new tet, then from the tets last made near it, then by a search
  /// around the last new tet (a walk may meet the hull of a non-convex mesh),
  /// and last by a scan of the mesh; it goes in by the constrained
  /// Bowyer-Watson cavity, or a split and Lawson's flips where the cavity
  /// cannot be used. h plays no part: the options leave delaunay_reach
  /// unlimited.
  InsertPointsStats insert_all(std::span<const Vec3> points) {
    InsertPointsStats stats;
    // Unbounded cavities (the first points into a boundary mesh take many
    // tets), so that the result is the constrained Delaunay one.
    max_cavity_ = std::numeric_limits<std::size_t>::max();
    h_.assign(m_.num_points(), 1.0);
    // Where the mesh is not Delaunay (TetGen's boundary recovery leaves such
    // faces), a cavity may miss tets whose spheres hold the point: Lawson's
    // flips over the whole mesh, before and after, make it Delaunay where
    // flips can.
    stats.flips = delaunay_flips_everywhere();
    while (last_tet_ + 1 < m_.num_slots() && !m_.alive(last_tet_)) ++last_tet_;
    Box box;
    for (const Vec3& p : points)
      if (is_finite(p)) box.add(p);
    constexpr double kCells = 2097151.0;  // 21 bits per axis
    std::vector<std::pair<std::uint64_t, Index>> order;
    order.reserve(points.size());
    for (std::size_t j = 0; j < points.size(); ++j) {
      if (!is_finite(points[j])) {
        ++stats.declined;
        continue;
      }
      std::uint64_t key = 0;
      for (int i = 0; i < 3; ++i) {
        const double side = box.hi[i] - box.lo[i];
        const double q = side > 0 ? std::clamp((points[j][i] - box.lo[i]) / side * kCells, 0.0, kCells) : 0.0;
        key |= detail::spread_bits(static_cast<std::uint64_t>(q)) << i;
      }
      order.emplace_back(key, static_cast<Index>(j));
    }
    // Rounds of a biased randomized insertion order (Amenta, Choi and Rote):
    // a point is in round r with probability about 7/8^(kInsertionRounds-r)
    // (from a hash of its index), the rounds go coarse to fine, each in
    // Morton order. No region then stays empty while its neighbour fills up,
    // so no point's cavity reaches across the mesh.
    std::vector<std::uint8_t> round(points.size(), 0);
    for (auto& [key, j] : order) round[j] = static_cast<std::uint8_t>(insertion_round(j));
    std::sort(order.begin(), order.end(), [&](const auto& a, const auto& b) {
      return std::tie(round[a.second], a.first, a.second) < std::tie(round[b.second], b.first, b.second);
    });
    // The last tet made for a point of each cell of a grid over the points
    // (about two points a cell): where the curve jumps, a walk from the
    // cells around the point starts near it.
    const int n = std::max(1, static_cast<int>(std::cbrt(0.5 * static_cast<double>(order.size()))));
    std::vector<Index> hint(static_cast<std::size_t>(n) * n * n, kNoIndex);
    const auto coord = [&](const Vec3& p, int i) {
      const double side = box.hi[i] - box.lo[i];
      return side > 0 ? std::clamp(static_cast<int>((p[i] - box.lo[i]) / side * n), 0, n - 1) : 0;
    };
    const auto cell = [&](int x, int y, int z) {
      return (static_cast<std::size_t>(z) * n + static_cast<std::size_t>(y)) * n + static_cast<std::size_t>(x);
    };
    const auto from_hints = [&](const Vec3& p) {
      const int x = coord(p, 0), y = coord(p, 1), z = coord(p, 2);
      for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            if (std::min({x + dx, y + dy, z + dz}) < 0 || std::max({x + dx, y + dy, z + dz}) >= n) continue;
            const Index t = hint[cell(x + dx, y + dy, z + dz)];
            if (t == kNoIndex || !m_.alive(t)) continue;
            const Location l = walk(m_, t, p, m_.num_slots(), /*cross_frozen=*/false);
            if (l.kind != LocationKind::kOutside) return l;
          }
      return Location{};
    };
    for (const auto& [key, j] : order) {
      const Vec3& p = points[j];
      Location l = walk(m_, last_tet_, p, m_.num_slots(), /*cross_frozen=*/false);
      if (l.kind == LocationKind::kOutside) l = from_hints(p);
      if (l.kind == LocationKind::kOutside) l = search(m_, last_tet_, p, 4096);
      if (l.kind == LocationKind::kOutside) {
        ++stats.scans;
        l = locate(m_, last_tet_, p);
      }
      if (!insertable(l)) {
        ++stats.declined;
        continue;
      }
      if (cavity_insert(l, p, 1.0)) {
        last_tet_ = hint[cell(coord(p, 0), coord(p, 1), coord(p, 2))] = m_.last_created()[0];
        ++stats.inserted;
        continue;
      }
      const InsertResult r = insert_at(m_, l, p);
      if (r.outcome != InsertOutcome::kDone) {
        ++stats.declined;
        continue;
      }
      h_.push_back(1.0);
      delaunay_flips(r.point);
      ++stats.split;
      // The last operation's tets are alive.
      last_tet_ = hint[cell(coord(p, 0), coord(p, 1), coord(p, 2))] = m_.last_created()[0];
      ++stats.inserted;
    }
    stats.flips += delaunay_flips_everywhere();
    return stats;
  }

 private:
  /// True when every edge of t is within split_ratio of the mean h of its ends.
  bool satisfied(Index t) const {
    const Tet& k = m_.tet(t);
    for (int e = 0; e < 6; ++e)
      if (!short_edge(k[topo::kEdgeVertex[e][0]], k[topo::kEdgeVertex[e][1]])) return false;
    return true;
  }

  /// True when an edge of t is longer than twice split_ratio times the mean h of its ends.
  bool in_void(Index t) const {
    const Tet& k = m_.tet(t);
    for (int e = 0; e < 6; ++e) {
      const Index a = k[topo::kEdgeVertex[e][0]], b = k[topo::kEdgeVertex[e][1]];
      const Vec3 d = m_.point(a) - m_.point(b);
      const double limit = 2.0 * o_.split_ratio * 0.5 * (h_[a] + h_[b]);
      if (dot(d, d) > limit * limit) return true;
    }
    return false;
  }

  /// Retires the tets whose candidates would all be dropped: those with no
  /// long edge, and (insert_within) those too far from the box to offer a
  /// point inside it. An operation that replaces one makes active tets again.
  void deactivate() {
    for (Index t = 0; t < m_.num_slots(); ++t) {
      if (t + kAhead < m_.num_slots() && m_.active(t + kAhead)) prefetch_points(t + kAhead);
      if (m_.alive(t) && m_.active(t) && (satisfied(t) || (o_.insert_within && !may_offer_inside(m_.tet(t)))))
        m_.set_active(t, false);
    }
  }

  /// Asks the cache for what the walks of the candidates after candidate j
  /// start from: the tet kAhead candidates on and its points, and the tet
  /// 2 kAhead on, whose points are asked for kAhead candidates later.
  void prefetch_candidates(std::size_t j) const {
    if (j + 2 * kAhead < candidates_.size()) m_.prefetch(candidates_[j + 2 * kAhead].tet);
    if (j + kAhead < candidates_.size()) prefetch_points(candidates_[j + kAhead].tet);
  }

  /// How far ahead the slot scans and queues ask for a tet's points.
  static constexpr Index kAhead = 8;

  /// Asks the cache for the points of slot t and their h, when t is an alive
  /// tet: a slot scan or queue reads them kAhead tets later, and they lie
  /// anywhere in memory (a hint only: no effect on results).
  void prefetch_points(Index t) const {
    if (t >= m_.num_slots() || !m_.alive(t)) return;
    for (const Index v : m_.tet(t)) {
      __builtin_prefetch(&m_.point(v));
      __builtin_prefetch(&h_[v]);
    }
  }

  /// Renumbers the tets in the Morton order of their barycentres (ties by slot):
  /// the pass then collects, walks and flips through neighbouring slots instead
  /// of slots scattered by the free list, far fewer cache misses.
  void sort_tets() {
    Vec3 lo = m_.point(0), hi = m_.point(0);
    for (const Vec3& p : m_.points())
      for (int i = 0; i < 3; ++i) {
        lo[i] = std::min(lo[i], p[i]);
        hi[i] = std::max(hi[i], p[i]);
      }
    constexpr double kCells = 2097151.0;  // 21 bits per axis
    Vec3 scale{};
    for (int i = 0; i < 3; ++i) scale[i] = hi[i] > lo[i] ? kCells / (hi[i] - lo[i]) : 0.0;
    keys_.clear();
    keys_.reserve(m_.num_tets());
    for (Index t = 0; t < m_.num_slots(); ++t) {
      if (!m_.alive(t)) continue;
      const Tet& k = m_.tet(t);
      std::uint64_t key = 0;
      for (int i = 0; i < 3; ++i) {
        const double c = 0.25 * (m_.point(k[0])[i] + m_.point(k[1])[i] + m_.point(k[2])[i] + m_.point(k[3])[i]);
        const auto q = static_cast<std::uint64_t>(std::clamp((c - lo[i]) * scale[i], 0.0, kCells));
        key |= detail::spread_bits(q) << i;
      }
      keys_.push_back({key, t});
    }
    std::sort(keys_.begin(), keys_.end());
    std::vector<Index> order(keys_.size());
    for (std::size_t i = 0; i < keys_.size(); ++i) order[i] = keys_[i].second;
    keys_ = {};  // before the reorder's own scratch: a lower peak
    const std::vector<Index> map = m_.reorder(order);
    last_tet_ = map[last_tet_] != kNoIndex ? map[last_tet_] : 0;
    sorted_tets_ = m_.num_tets();
  }

  /// True when the edge (a, b) is no longer than split_ratio times its mean h.
  bool short_edge(Index a, Index b) const {
    const Vec3 d = m_.point(a) - m_.point(b);
    const double limit = o_.split_ratio * 0.5 * (h_[a] + h_[b]);
    return dot(d, d) <= limit * limit;
  }

  /// True when face f of a tet with vertices k is a cut (RefineOptions::insert_within).
  bool is_cut(const Tet& k, int f) const {
    return !cuts_.empty() && std::binary_search(cuts_.begin(), cuts_.end(), topo::sorted_key(topo::face_of(k, f)));
  }

  /// False when no candidate of a tet with vertices k can lie inside
  /// insert_within: each lies within the tet's bounding box grown by
  /// advance_ratio times the largest h of its vertices (a front candidate is
  /// that far from its face's centroid, a midpoint inside the tet).
  bool may_offer_inside(const Tet& k) const {
    const Box& b = *o_.insert_within;
    double reach = 0;
    for (Index v : k) reach = std::max(reach, h_[v]);
    reach *= o_.advance_ratio;
    for (int i = 0; i < 3; ++i) {
      double lo = m_.point(k[0])[i], hi = lo;
      for (int j = 1; j < 4; ++j) {
        lo = std::min(lo, m_.point(k[j])[i]);
        hi = std::max(hi, m_.point(k[j])[i]);
      }
      if (hi + reach < b.lo[i] || lo - reach > b.hi[i]) return false;
    }
    return true;
  }

  /// Appends a candidate at p made by tet t (vertices k), unless p lies
  /// outside RefineOptions::insert_within.
  void add_candidate(std::vector<Candidate>& to, const Vec3& p, Index t, const Tet& k) const {
    if (o_.insert_within) {
      const Box& b = *o_.insert_within;
      for (int i = 0; i < 3; ++i)
        if (!(p[i] >= b.lo[i] && p[i] <= b.hi[i])) return;
    }
    to.push_back({p, t, k});
  }

  /// Front stage: from every face of an active tet that is a hull or frozen
  /// face or has no long edge, a point advanced into the tet. Midpoint stage:
  /// the midpoint of every long edge of an active tet (each edge once per tet).
  /// Slot order, then face or edge order.
  void collect(bool midpoints) {
    candidates_.clear();
    for (Index t = 0; t < m_.num_slots(); ++t) {
      if (t + kAhead < m_.num_slots() && m_.active(t + kAhead)) prefetch_points(t + kAhead);
      if (!m_.alive(t) || !m_.active(t)) continue;
      const Tet& k = m_.tet(t);  // active: deactivate() has checked may_offer_inside this pass
      if (midpoints) {
        for (int e = 0; e < 6; ++e) {
          const Index a = k[topo::kEdgeVertex[e][0]], b = k[topo::kEdgeVertex[e][1]];
          if (!short_edge(a, b)) add_candidate(candidates_, 0.5 * (m_.point(a) + m_.point(b)), t, k);
        }
        continue;
      }
      const std::size_t before = candidates_.size();
      for (int f = 0; f < 4; ++f) {
        const Index a = k[topo::kFaceVertex[f][0]], b = k[topo::kFaceVertex[f][1]],
                    c = k[topo::kFaceVertex[f][2]];
        const bool wall = m_.neighbour(t, f) == kNoIndex || m_.frozen(t, f);
        if (!wall && !(short_edge(a, b) && short_edge(b, c) && short_edge(c, a))) continue;
        const Vec3& pa = m_.point(a);
        const Vec3& pb = m_.point(b);
        const Vec3& pc = m_.point(c);
        const Vec3 normal = cross(pb - pa, pc - pa);  // outward from t
        const double ln = norm(normal);
        if (!(ln > 0.0)) continue;
        const double hf = (h_[a] + h_[b] + h_[c]) / 3.0;
        const Vec3 g = (1.0 / 3.0) * (pa + pb + pc);
        add_candidate(candidates_, g - (o_.advance_ratio * hf / ln) * normal, t, k);
      }
      if (o_.void_midpoints && candidates_.size() == before) {
        // No front face: a tet of the unfilled interior. Its longest edge's
        // midpoint is a candidate too, after every front candidate.
        int longest = 0;
        double best = -1.0;
        for (int e = 0; e < 6; ++e) {
          const Vec3 d = m_.point(k[topo::kEdgeVertex[e][0]]) - m_.point(k[topo::kEdgeVertex[e][1]]);
          if (dot(d, d) > best) {
            best = dot(d, d);
            longest = e;
          }
        }
        const Index a = k[topo::kEdgeVertex[longest][0]], b = k[topo::kEdgeVertex[longest][1]];
        if (!short_edge(a, b)) add_candidate(voids_, 0.5 * (m_.point(a) + m_.point(b)), t, k);
      }
    }
    candidates_.insert(candidates_.end(), voids_.begin(), voids_.end());
    voids_.clear();
  }

  /// The proximity test: false when a point lies within `r_point` of p, or a
  /// hull or frozen face within `r_face`, among the tets reachable from `start`
  /// across unfrozen faces that may lie within r_point of p.
  bool clear_around(Index start, const Vec3& p, double r_point, double r_face) {
    if (stamp_.size() < m_.num_slots()) stamp_.resize(m_.num_slots(), 0);
    if (++epoch_ == 0) {  // wrapped: reset the stamps
      std::fill(stamp_.begin(), stamp_.end(), 0u);
      epoch_ = 1;
    }
    const double rp2 = r_point * r_point;
    // The stack holds packed faces (tet, face it was entered through): that
    // face leads back to a marked tet and needs no test.
    stack_.clear();
    stack_.push_back(pack_face(start, 0));
    stamp_[start] = epoch_;
    Index visited = 0;
    while (!stack_.empty() && visited < o_.max_search_tets) {
      const Index t = face_tet(stack_.back());
      const int entry = visited == 0 ? -1 : face_local(stack_.back());  // the start was not entered
      stack_.pop_back();
      ++visited;
      const Tet& k = m_.tet(t);
      for (int f = 0; f < 4; ++f)  // the marks read below, while the distances are computed
        if (const Index n = m_.neighbour(t, f); n != kNoIndex && f != entry) __builtin_prefetch(&stamp_[face_tet(n)]);
      for (int i = 0; i < 4; ++i) {
        const Vec3 d = m_.point(k[i]) - p;
        if (dot(d, d) < rp2) return false;
      }
      for (int f = 0; f < 4; ++f) {
        if (f == entry) continue;
        const Index n = m_.neighbour(t, f);
        const bool wall = n == kNoIndex || m_.frozen(t, f);
        const Vec3& a = m_.point(k[topo::kFaceVertex[f][0]]);
        const Vec3& b = m_.point(k[topo::kFaceVertex[f][1]]);
        const Vec3& c = m_.point(k[topo::kFaceVertex[f][2]]);
        if (wall) {
          // The bound first (most walls are far), then the distance itself:
          // the bound of a needle triangle many h long is its plane's
          // distance, which rejected points far from the triangle.
          if (face_bound_below(a, b, c, p, r_face) && within_distance(k, f, p, r_face) && !is_cut(k, f))
            return false;
          continue;
        }
        // The neighbour's mark before the bound: about half the faces lead
        // back into the visited tets, and the mark is cheaper than the bound.
        if (stamp_[face_tet(n)] != epoch_ && face_bound_below(a, b, c, p, r_point)) {
          stamp_[face_tet(n)] = epoch_;
          stack_.push_back(n);
          m_.prefetch(face_tet(n));  // read when popped
        }
      }
    }
    return true;
  }

  /// Whether face f of tet k lies closer than r to p.
  bool within_distance(const Tet& k, int f, const Vec3& p, double r) const {
    const Vec3 y = closest_on_triangle(p, m_.point(k[topo::kFaceVertex[f][0]]), m_.point(k[topo::kFaceVertex[f][1]]),
                                       m_.point(k[topo::kFaceVertex[f][2]]));
    return dot(y - p, y - p) < r * r;
  }

  /// Where a candidate may be inserted: strictly inside a tet, or on an
  /// interior unfrozen face or edge (insert_at declines frozen ones itself).
  bool insertable(const Location& l) {
    switch (l.kind) {
      case LocationKind::kInTet:
        return true;
      case LocationKind::kOnFace:
        return m_.neighbour(l.tet, l.local) != kNoIndex && !m_.frozen(l.tet, l.local);
      case LocationKind::kOnEdge:
        return m_.edge_ring(l.tet, l.local, ring_) && ring_.closed;
      default:
        return false;
    }
  }

  /// Locates, checks and inserts one candidate; true when it went in.
  bool process(const Candidate& c, RefinePassStats& ps) {
    Index start = c.tet;
    if (!m_.alive(start)) start = last_tet_;
    const Location l = walk(m_, start, c.p, o_.max_walk_steps, /*cross_frozen=*/false);
    if (!insertable(l)) return false;
    const double h = sizing_->at(c.p, sizing_hint_);
    if (!clear_around(l.tet, c.p, o_.reject_distance * h, o_.boundary_reject_distance * h))
      return false;
    ++ps.accepted;
    if (o_.reconnect && o_.delaunay && cavity_insert(l, c.p, h)) {
      ++ps.inserted;
      queue_.assign(m_.last_created().begin(), m_.last_created().end());
      last_tet_ = m_.last_created()[0];
      if (o_.min_max && !o_.defer_min_max) ps.flips += reconnect();
      return true;
    }
    const InsertResult r = insert_at(m_, l, c.p);
    if (r.outcome != InsertOutcome::kDone) return false;
    ++ps.inserted;
    h_.push_back(h);
    last_tet_ = m_.last_created()[0];
    if (o_.reconnect) {
      if (o_.delaunay) ps.flips += delaunay_flips(r.point);
      if (o_.min_max && !o_.defer_min_max) ps.flips += reconnect();
    }
    return true;
  }

  /// Fresh marks for the cavity search: stamp_ holds in_ for a tet in the
  /// cavity, out_ for one tested and left out (clear_around's marks differ).
  void next_epoch() {
    if (stamp_.size() < m_.num_slots()) stamp_.resize(m_.num_slots(), 0);
    if (epoch_ > 0xFFFFFFF0u) {  // about to wrap: reset the stamps
      std::fill(stamp_.begin(), stamp_.end(), 0u);
      epoch_ = 0;
    }
    in_ = ++epoch_;
    out_ = ++epoch_;
  }

  /// True when face f of cavity tet t is on the cavity's boundary.
  bool cavity_face(Index t, int f) const {
    const Index n = m_.neighbour(t, f);
    return n == kNoIndex || stamp_[face_tet(n)] != in_;
  }

  /// Constrained Bowyer-Watson insertion of p at location l (one cavity
  /// replacement instead of a 1-4 split and tens of Lawson flips): the cavity
  /// grows from the tets that contain p across unfrozen faces within one region
  /// to every tet whose circumsphere holds p strictly (exact insphere); then
  /// tets whose boundary faces p does not see strictly (exact orient3d) are
  /// dropped, seeds excepted, until the cavity is star-shaped from p, and it is
  /// re-tiled as the star of p over its boundary. False (nothing changed) when
  /// a seed would have to go, a cavity vertex would vanish or the cavity grows
  /// past max_cavity_ tets: the caller then splits and flips instead.
  bool cavity_insert(const Location& l, const Vec3& p, double h) {
    next_epoch();
    const std::uint32_t in = in_, out = out_;
    cavity_.clear();
    const auto add = [&](Index t) {
      stamp_[t] = in;
      cavity_.push_back(t);
    };
    switch (l.kind) {
      case LocationKind::kInTet:
        add(l.tet);
        break;
      case LocationKind::kOnFace:
        if (m_.frozen(l.tet, l.local) || m_.neighbour(l.tet, l.local) == kNoIndex) return false;
        add(l.tet);
        add(face_tet(m_.neighbour(l.tet, l.local)));
        break;
      case LocationKind::kOnEdge: {
        if (!m_.edge_ring(l.tet, l.local, ring_) || !ring_.closed) return false;
        for (int i = 0; i < ring_.size; ++i) {
          const Index u = ring_.tets[i];
          if (m_.frozen(u, topo::local_vertex(m_.tet(u), ring_.ring[i]))) return false;
          add(u);
        }
        break;
      }
      default:
        return false;
    }
    const std::size_t seeds = cavity_.size();
    for (std::size_t i = 1; i < seeds; ++i)
      if (m_.region(cavity_[i]) != m_.region(cavity_[0])) return false;
    const int region = m_.region(cavity_[0]);
    const double reach = o_.delaunay_reach * h;
    const double reach2 = reach * reach;
    for (std::size_t i = 0; i < cavity_.size(); ++i) {
      const Index t = cavity_[i];
      for (int f = 0; f < 4; ++f) {
        const Index n = m_.neighbour(t, f);
        if (n == kNoIndex || m_.frozen(t, f)) continue;
        const Index u = face_tet(n);
        if (stamp_[u] == in || stamp_[u] == out) continue;
        const Tet& k = m_.tet(u);
        bool take = m_.region(u) == region;
        if (take && reach2 < std::numeric_limits<double>::infinity()) {
          const Vec3 d = m_.point(k[face_local(n)]) - p;
          take = dot(d, d) <= reach2;
        }
        take = take && exact::insphere(m_.point(k[0]), m_.point(k[1]), m_.point(k[2]), m_.point(k[3]), p) > 0;
        if (!take) {
          stamp_[u] = out;
          continue;
        }
        if (cavity_.size() == max_cavity_) return false;
        add(u);
      }
    }
    // Star-shapedness: drop the tets with a boundary face that p does not see.
    for (bool changed = true; changed;) {
      changed = false;
      for (std::size_t i = 0; i < cavity_.size(); ++i) {
        const Index t = cavity_[i];
        if (stamp_[t] != in) continue;
        const Tet& k = m_.tet(t);
        for (int f = 0; f < 4; ++f) {
          if (!cavity_face(t, f)) continue;
          if (exact::orient3d(m_.point(k[topo::kFaceVertex[f][0]]), m_.point(k[topo::kFaceVertex[f][1]]),
                              m_.point(k[topo::kFaceVertex[f][2]]), p) < 0)
            continue;
          if (i < seeds) return false;
          stamp_[t] = out;
          changed = true;
          break;
        }
      }
    }
    std::size_t kept = 0;
    for (const Index t : cavity_)
      if (stamp_[t] == in) cavity_[kept++] = t;
    cavity_.resize(kept);
    // The star over the boundary faces; every cavity vertex must stay in it.
    star_.clear();
    if (vstamp_.size() < m_.num_points()) vstamp_.resize(m_.num_points(), 0);
    if (++vepoch_ == 0) {  // wrapped: reset the marks
      std::fill(vstamp_.begin(), vstamp_.end(), 0u);
      vepoch_ = 1;
    }
    for (std::size_t i = 0; i < cavity_.size(); ++i) {
      const Index t = cavity_[i];
      const Tet& k = m_.tet(t);
      for (int f = 0; f < 4; ++f) {
        if (!cavity_face(t, f)) continue;
        const Index a = k[topo::kFaceVertex[f][0]], b = k[topo::kFaceVertex[f][1]], c = k[topo::kFaceVertex[f][2]];
        vstamp_[a] = vstamp_[b] = vstamp_[c] = vepoch_;
        star_.push_back({{a, b, c}, m_.neighbour(t, f), static_cast<Index>(i), m_.frozen(t, f)});
      }
    }
    for (const Index t : cavity_)
      for (const Index v : m_.tet(t))
        if (vstamp_[v] != vepoch_) return false;
    const Index q = m_.add_point(p);
    h_.push_back(h);
    m_.replace_star(cavity_, q, star_);
    return true;
  }

  /// True when tets `old` may be replaced by the positive tets `fresh` (the
  /// replaced faces are not frozen: checked by the caller) within one region.
  bool all_positive(std::span<const Tet> fresh) const {
    for (const Tet& k : fresh)
      if (exact::orient3d(m_.point(k[0]), m_.point(k[1]), m_.point(k[2]), m_.point(k[3])) <= 0)
        return false;
    return true;
  }

  /// 3-2 flip of edge le of tet t when exactly three tets surround it, none of
  /// the faces around it is frozen and all lie in one region.
  bool flip32_delaunay(Index t, int le) {
    if (!m_.edge_ring(t, le, ring_) || !ring_.closed || ring_.size != 3) return false;
    for (int i = 0; i < 3; ++i) {
      const Index u = ring_.tets[i];
      if (m_.frozen(u, topo::local_vertex(m_.tet(u), ring_.ring[i]))) return false;
      if (m_.region(u) != m_.region(ring_.tets[0])) return false;
    }
    const auto& r = ring_.ring;
    const std::array<Tet, 2> fresh{Tet{r[0], r[1], r[2], ring_.b}, Tet{r[1], r[0], r[2], ring_.a}};
    if (!all_positive(fresh)) return false;
    const std::array<Index, 2> parent{0, 0};
    m_.replace_cavity(std::span<const Index>(ring_.tets.data(), 3), fresh, parent);
    return true;
  }

  /// Lawson's flips after inserting point p: every face opposite p whose
  /// neighbour's apex lies inside the tet's circumsphere (exact insphere) is
  /// flipped away (lawson_flip). Frozen faces and region borders are never
  /// flipped (a constrained Delaunay repair).
  std::size_t delaunay_flips(Index p) {
    queue_.assign(m_.last_created().begin(), m_.last_created().end());
    std::size_t flips = 0;
    const double reach = o_.delaunay_reach * h_[p];
    const double reach2 = reach * reach;
    for (std::size_t head = 0; head < queue_.size() && flips < o_.max_flips_per_point; ++head) {
      const Index t = queue_[head];
      if (!m_.alive(t)) continue;
      const int f = topo::local_vertex(m_.tet(t), p);
      if (f < 0 || !lawson_flip(t, f, reach2)) continue;
      ++flips;
      const auto created = m_.last_created();
      queue_.insert(queue_.end(), created.begin(), created.end());
    }
    return flips;
  }

  /// Lawson's flips over the whole mesh until every face that may be flipped
  /// is locally Delaunay (each flip lowers the lifted triangulation, so it
  /// ends); the tets of every flip are tested again.
  std::size_t delaunay_flips_everywhere() {
    queue_.clear();
    for (Index t = 0; t < m_.num_slots(); ++t)
      if (m_.alive(t)) queue_.push_back(t);
    std::size_t flips = 0;
    const double unlimited = std::numeric_limits<double>::infinity();
    for (std::size_t head = 0; head < queue_.size(); ++head) {
      const Index t = queue_[head];
      for (int f = 0; f < 4 && m_.alive(t); ++f) {
        if (!lawson_flip(t, f, unlimited)) continue;
        ++flips;
        const auto created = m_.last_created();
        queue_.insert(queue_.end(), created.begin(), created.end());
      }
      if (head > (std::size_t{1} << 20) && 2 * head > queue_.size()) {  // keep the queue's memory bounded
        queue_.erase(queue_.begin(), queue_.begin() + static_cast<std::ptrdiff_t>(head + 1));
        head = static_cast<std::size_t>(-1);
      }
    }
    return flips;
  }

  /// The flip of face f of tet t (opposite its vertex p) when the apex e
  /// beyond it lies strictly inside t's circumsphere, within sqrt(reach2) of
  /// p, and the face is neither frozen nor a region border: 2-3 when the two
  /// tets form a convex pair, else 3-2 across the edge that blocks it when
  /// three tets surround that edge. True when it flipped.
  bool lawson_flip(Index t, int f, double reach2) {
    const Tet kt = m_.tet(t);
    const Index p = kt[f];
    const Index n = m_.neighbour(t, f);
    if (n == kNoIndex || m_.frozen(t, f)) return false;
    const Index u = face_tet(n);
    if (m_.region(u) != m_.region(t)) return false;
    const Index e = m_.tet(u)[face_local(n)];
    const Vec3 pe = m_.point(e) - m_.point(p);
    if (dot(pe, pe) > reach2) return false;  // would join p to a far point: leave it
    if (exact::insphere(m_.point(kt[0]), m_.point(kt[1]), m_.point(kt[2]), m_.point(kt[3]), m_.point(e)) <= 0)
      return false;
    const Index a = kt[topo::kFaceVertex[f][0]], b = kt[topo::kFaceVertex[f][1]], c = kt[topo::kFaceVertex[f][2]];
    const std::array<Tet, 3> fresh{Tet{a, b, p, e}, Tet{b, c, p, e}, Tet{c, a, p, e}};
    if (all_positive(fresh)) {
      const std::array<Index, 2> old{t, u};
      const std::array<Index, 3> parent{0, 0, 0};
      m_.replace_cavity(old, fresh, parent);
      return true;
    }
    for (int j = 0; j < 3; ++j) {
      const Index x = fresh[j][0], y = fresh[j][1];
      if (exact::orient3d(m_.point(x), m_.point(y), m_.point(p), m_.point(e)) >= 0) continue;
      if (flip32_delaunay(t, topo::kEdgeIndex[topo::local_vertex(kt, x)][topo::local_vertex(kt, y)])) return true;
    }
    return false;
  }

  /// tet_quality of the alive tet t, through the mesh's cache.
  double quality(Index t) {
    double q = m_.cached_quality(t);
    if (std::isnan(q)) {
      q = tet_quality(m_, m_.tet(t));
      m_.set_cached_quality(t, q);
    }
    return q;
  }

  /// True when t or a face neighbour of t has a dihedral angle above min_max_angle.
  bool near_bad(Index t) {
    if (quality(t) <= bad_cos_) return true;
    for (int f = 0; f < 4; ++f) {
      const Index n = m_.neighbour(t, f);
      if (n != kNoIndex && quality(face_tet(n)) <= bad_cos_) return true;
    }
    return false;
  }

  /// Deferred min-max step at the end of a pass: flips from every tet created
  /// since the last quality evaluation (cache still unknown), in slot order.
  std::size_t reconnect_pass(std::size_t inserted) {
    // While points still go in, a tet of the unfilled interior (an edge over
    // twice split_ratio * h) is left for later: the next passes split it
    // anyway (its quality stays unknown, so the first pass that inserts
    // nothing takes it up).
    queue_.clear();
    for (Index t = 0; t < m_.num_slots(); ++t) {
      if (t + kAhead < m_.num_slots() && std::isnan(m_.cached_quality(t + kAhead))) prefetch_points(t + kAhead);
      if (m_.alive(t) && std::isnan(m_.cached_quality(t)) && (inserted == 0 || !in_void(t)))
        queue_.push_back(t);
    }
    seeds_ = queue_;
    const std::size_t budget = o_.max_flips_per_point * std::max<std::size_t>(inserted, 1);
    std::size_t flips = reconnect(budget, false);
    if (o_.long_edge_ratio > 0.0) flips += shorten_long_edges(budget);
    return flips;
  }

  /// Removes edges longer than long_edge_ratio times the mean h of their ends
  /// from the tets in seeds_ (and the tets those flips create), by
  /// remove_long_edge with the floor min_max_angle: a flip may lower the local
  /// worst angle but keeps it under min_max_angle (or no worse than before).
  std::size_t shorten_long_edges(std::size_t budget) {
    queue_ = seeds_;
    const double floor = bad_cos_ >= -1.0 ? bad_cos_ : -1.0;
    std::size_t flips = 0;
    failed_.clear(m_.num_points());  // as in reconnect: a failure holds until a flip touches both ends
    for (std::size_t head = 0; head < queue_.size() && flips < budget; ++head) {
      if (head + kAhead < queue_.size()) prefetch_points(queue_[head + kAhead]);
      const Index t = queue_[head];
      if (!m_.alive(t)) continue;
      const Tet k = m_.tet(t);
      // The long edges first, asking for their failure records, then the
      // records read in edge order.
      unsigned long_edges = 0;
      for (int e = 0; e < 6; ++e) {
        const Index a = k[topo::kEdgeVertex[e][0]], b = k[topo::kEdgeVertex[e][1]];
        const Vec3 d = m_.point(a) - m_.point(b);
        const double limit = o_.long_edge_ratio * 0.5 * (h_[a] + h_[b]);
        if (dot(d, d) <= limit * limit) continue;
        long_edges |= 1u << e;
        failed_.prefetch(a, b);
      }
      for (int e = 0; e < 6; ++e) {
        if ((long_edges & (1u << e)) == 0) continue;
        const Index a = k[topo::kEdgeVertex[e][0]], b = k[topo::kEdgeVertex[e][1]];
        if (failed_.known(a, b)) continue;
        if (remove_long_edge(m_, t, e, floor) != FlipOutcome::kDone) {
          failed_.add(a, b);
          continue;
        }
        ++flips;
        const auto created = m_.last_created();
        failed_.touch(m_, created);
        queue_.insert(queue_.end(), created.begin(), created.end());
        break;
      }
    }
    if (!m_.last_created().empty()) last_tet_ = m_.last_created()[0];
    return flips;
  }

  /// Flips around the tets the last insertion created; returns the flips done.
  std::size_t reconnect() { return reconnect(o_.max_flips_per_point, true); }

  /// Flips from the tets in queue_ (fill = true: first refill it with the
  /// tets the last insertion created) until `budget` flips succeeded.
  std::size_t reconnect(std::size_t budget, bool fill) {
    if (!fill) {
    } else if (!o_.delaunay) {
      queue_.assign(m_.last_created().begin(), m_.last_created().end());
    } else {  // the tets the Delaunay step left alive, in queue order
      std::size_t kept = 0;
      for (const Index t : queue_)
        if (m_.alive(t)) queue_[kept++] = t;
      queue_.resize(kept);
    }
    // Deferred pass (fill false): only this loop's flips change the mesh, so a
    // failed edge removal stays failed until a flip touches both its ends.
    const bool memo = !fill;
    if (memo) failed_.clear(m_.num_points());
    std::size_t flips = 0;
    for (std::size_t head = 0; head < queue_.size() && flips < budget; ++head) {
      const Index t = queue_[head];
      if (!m_.alive(t)) continue;
      if (bad_cos_ >= -1.0 && !near_bad(t)) continue;
      if (memo) {  // the edges' failure records, read after the face flips below
        const Tet& k = m_.tet(t);
        for (int e = 0; e < 6; ++e) failed_.prefetch(k[topo::kEdgeVertex[e][0]], k[topo::kEdgeVertex[e][1]]);
      }
      bool done = false;
      for (int f = 0; f < 4 && !done; ++f) done = flip23(m_, t, f) == FlipOutcome::kDone;
      for (int e = 0; e < 6 && !done; ++e) {
        const Tet& k = m_.tet(t);
        const Index a = k[topo::kEdgeVertex[e][0]], b = k[topo::kEdgeVertex[e][1]];
        if (memo && failed_.known(a, b)) continue;
        done = remove_edge(m_, t, e) == FlipOutcome::kDone;
        if (memo && !done) failed_.add(a, b);
      }
      if (!done) continue;
      ++flips;
      const auto created = m_.last_created();
      if (memo) failed_.touch(m_, created);
      queue_.insert(queue_.end(), created.begin(), created.end());
    }
    if (!m_.last_created().empty()) last_tet_ = m_.last_created()[0];
    return flips;
  }

  TetMesh& m_;
  const SizingField* sizing_;
  SizingHint sizing_hint_;  ///< consecutive candidates lie near each other
  const RefineOptions& o_;
  std::vector<double> h_;  ///< h at each point, evaluated when it entered the mesh
  /// cavity_insert gives up past this many tets (the refiner's cavities are
  /// small; a large one means a coarse region that flips repair for less).
  std::size_t max_cavity_ = 1024;
  std::vector<Tri> cuts_;  ///< frozen faces of boundary id 0 with insert_within, sorted keys
  std::vector<Candidate> candidates_;
  std::vector<Candidate> voids_;  ///< collect's interior candidates, placed after the front's
  std::vector<std::uint32_t> stamp_;
  std::uint32_t epoch_ = 0;
  std::vector<Index> stack_;  ///< clear_around's packed faces
  std::vector<Index> queue_;
  std::vector<Index> seeds_;
  std::vector<Index> cavity_;
  std::vector<TetMesh::StarFace> star_;  ///< cavity_insert's boundary faces
  std::vector<std::uint32_t> vstamp_;  ///< cavity_insert's vertex marks
  std::uint32_t vepoch_ = 0;
  std::uint32_t in_ = 0, out_ = 0;
  EdgeRing ring_;
  FailedEdges failed_;  ///< the deferred reconnection's failed edge removals
  Index sorted_tets_ = 0;  ///< alive tets at the last sort_tets
  std::vector<std::pair<std::uint64_t, Index>> keys_;  ///< sort_tets' scratch
  Index last_tet_ = 0;
  double bad_cos_ = -2.0;  ///< cosine of min_max_angle; -2 when every tet is tried
};

bool positive_finite(double x) { return std::isfinite(x) && x > 0.0; }

}  // namespace

Status validate(const RefineOptions& o) {
  if (!positive_finite(o.reject_distance))
    return invalid_input(fmt::format("reject_distance must be finite and > 0, got {}", o.reject_distance));
  if (!(std::isfinite(o.boundary_reject_distance) && o.boundary_reject_distance >= 0.0))
    return invalid_input(fmt::format("boundary_reject_distance must be finite and >= 0, got {}",
                                     o.boundary_reject_distance));
  if (!positive_finite(o.split_ratio))
    return invalid_input(fmt::format("split_ratio must be finite and > 0, got {}", o.split_ratio));
  if (!positive_finite(o.advance_ratio))
    return invalid_input(fmt::format("advance_ratio must be finite and > 0, got {}", o.advance_ratio));
  if (!(o.min_max_angle >= 0.0 && o.min_max_angle <= 180.0))
    return invalid_input(fmt::format("min_max_angle must be in [0, 180] degrees, got {}", o.min_max_angle));
  if (o.max_passes < 0) return invalid_input(fmt::format("max_passes must be >= 0, got {}", o.max_passes));
  if (o.max_walk_steps == 0 || o.max_search_tets == 0)
    return invalid_input("max_walk_steps and max_search_tets must be > 0");
  return {};
}

Result<RefineStats> refine(TetMesh& mesh, const SizingField& sizing, const RefineOptions& options,
                           const RefineProgress& progress, std::vector<double>* sizes) {
  PDR_TRY(validate(options));
  Refiner refiner(mesh, &sizing, options);
  if (sizes != nullptr && sizes->size() == mesh.num_points()) refiner.set_sizes(std::move(*sizes));
  RefineStats stats = refiner.run(progress);
  if (sizes != nullptr) *sizes = refiner.take_sizes();
#ifndef NDEBUG
  PDR_TRY(mesh.check());
#endif
  return stats;
}

int insertion_round(std::size_t index) {
  std::uint64_t x = index + 0x9e3779b97f4a7c15ull;  // splitmix64
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  x ^= x >> 31;
  const int level = std::min(kInsertionRounds - 1, std::countr_zero(x | (std::uint64_t{1} << 63)) / 3);
  return kInsertionRounds - 1 - level;
}

Result<InsertPointsStats> insert_points(TetMesh& mesh, std::span<const Vec3> points) {
  RefineOptions options;
  options.min_max = false;
  options.delaunay_reach = std::numeric_limits<double>::infinity();
  options.max_flips_per_point = std::numeric_limits<Index>::max();
  Refiner refiner(mesh, nullptr, options);
  const InsertPointsStats stats = refiner.insert_all(points);
#ifndef NDEBUG
  PDR_TRY(mesh.check());
#endif
  return stats;
}

}  // namespace pdrmesh
