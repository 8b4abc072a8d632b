// SPDX-License-Identifier: AGPL-3.0-or-later
// The PDR engine: initial mesh, decomposition, fix-ups, leaf tasks, merge,
// interface round. See pdr.hpp for the numbering and determinism argument.
#include "pdrmesh/pdr.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <mutex>
#include <numeric>
#include <shared_mutex>
#include <string>
#include <utility>

#include "pdrmesh/leaf_kernels.hpp"
#include "pdrmesh/tetgen_adapter.hpp"
#include "pdrmesh/topology.hpp"
#include "pdrmesh/validate.hpp"

namespace pdrmesh {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

/// Packed face neighbours (4 * u + g, or kNoIndex) of every tet face.
std::vector<Index> face_neighbours(const VolumeMesh& m) {
  struct Rec {
    Tri key;
    Index packed;
    bool operator<(const Rec& o) const { return key < o.key || (key == o.key && packed < o.packed); }
  };
  std::vector<Rec> faces;
  faces.reserve(4 * m.tets.size());
  for (Index t = 0; t < m.tets.size(); ++t)
    for (int f = 0; f < 4; ++f) faces.push_back({topo::sorted_key(topo::face_of(m.tets[t], f)), 4 * t + Index(f)});
  std::sort(faces.begin(), faces.end());
  std::vector<Index> nbr(faces.size(), kNoIndex);
  for (std::size_t i = 0; i + 1 < faces.size(); ++i) {
    if (faces[i].key == faces[i + 1].key) {
      nbr[faces[i].packed] = faces[i + 1].packed;
      nbr[faces[i + 1].packed] = faces[i].packed;
    }
  }
  return nbr;
}

/// Minimal union-find over [0, n).
struct UnionFind {
  std::vector<Index> parent;
  explicit UnionFind(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), Index{0}); }
  Index find(Index x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  }
  void unite(Index a, Index b) {
    a = find(a);
    b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);  // the lowest index is the root
  }
};

/// The working state of the fix-ups: adjacency, vertex stars, leaf membership.
class Fixer {
 public:
  Fixer(const VolumeMesh& m, Decomposition& d) : m_(m), d_(d), nbr_(face_neighbours(m)) {
    start_.assign(m.points.size() + 1, 0);
    for (const Tet& t : m.tets)
      for (Index v : t) ++start_[v + 1];
    std::partial_sum(start_.begin(), start_.end(), start_.begin());
    star_.resize(start_.back());
    pinned_.assign(m.tets.size(), 0);
    std::vector<Index> fill(start_.begin(), start_.end() - 1);
    for (Index t = 0; t < m.tets.size(); ++t)
      for (Index v : m.tets[t]) star_[fill[v]++] = t;
  }

  /// Tets of leaf l that partition swap moves out: every face component of the
  /// leaf that shares a vertex with a larger one (ties: the lower-numbered
  /// component stays), ascending.
  std::vector<Index> loose_tets(Index l) const {
    const std::vector<Index>& tets = d_.leaf_tets[l];
    std::vector<Index> comp(tets.size(), kNoIndex);
    auto pos = [&](Index t) { return static_cast<Index>(std::lower_bound(tets.begin(), tets.end(), t) - tets.begin()); };
    std::vector<Index> size;
    std::vector<Index> queue;
    for (Index i = 0; i < tets.size(); ++i) {
      if (comp[i] != kNoIndex) continue;
      const auto c = static_cast<Index>(size.size());
      size.push_back(0);
      comp[i] = c;
      queue.assign(1, i);
      while (!queue.empty()) {
        const Index j = queue.back();
        queue.pop_back();
        ++size[c];
        for (int f = 0; f < 4; ++f) {
          const Index u = nbr_[4 * tets[j] + Index(f)];
          if (u == kNoIndex || d_.tet_leaf[u / 4] != l) continue;
          const Index k = pos(u / 4);
          if (comp[k] == kNoIndex) {
            comp[k] = c;
            queue.push_back(k);
          }
        }
      }
    }
    if (size.size() < 2) return {};
    // Components sharing a vertex form a group (vertex -> component pairs, sorted).
    std::vector<std::pair<Index, Index>> vc;
    for (Index i = 0; i < tets.size(); ++i)
      for (Index v : m_.tets[tets[i]]) vc.emplace_back(v, comp[i]);
    std::sort(vc.begin(), vc.end());
    UnionFind groups(size.size());
    for (std::size_t i = 1; i < vc.size(); ++i)
      if (vc[i].first == vc[i - 1].first) groups.unite(vc[i].second, vc[i - 1].second);
    std::vector<Index> keep(size.size(), kNoIndex);  // per group root: the kept component
    for (Index c = 0; c < size.size(); ++c) {
      Index& k = keep[groups.find(c)];
      if (k == kNoIndex || size[c] > size[k]) k = c;
    }
    std::vector<Index> out;
    for (Index i = 0; i < tets.size(); ++i)
      if (keep[groups.find(comp[i])] != comp[i]) out.push_back(tets[i]);
    return out;
  }

  /// Boundary extraction's move for leaf l: at the first hull edge, then hull
  /// vertex, where the leaf's tets form several sectors, the smallest sector of
  /// other leaves' tets that holds no pinned tet goes into l; failing that, the
  /// smallest sector of l goes to the lowest leaf holding a face neighbour of it
  /// there. Empty when the hull is manifold; `stuck` counts bad elements with
  /// no move.
  struct Move {
    std::vector<Index> tets;
    Index to = kNoIndex;
    bool stuck = false;
  };
  Move extraction(Index l) const {
    Move move;
    std::vector<std::array<Index, 2>> elements;  // edges (a < b), then vertices (v, kNoIndex)
    std::vector<std::array<Index, 2>> vertices;
    for (Index t : d_.leaf_tets[l]) {
      for (int f = 0; f < 4; ++f) {
        const Index u = nbr_[4 * t + Index(f)];
        if (u != kNoIndex && d_.tet_leaf[u / 4] == l) continue;
        const Tri tri = topo::face_of(m_.tets[t], f);
        for (int k = 0; k < 3; ++k) {
          elements.push_back({std::min(tri[k], tri[(k + 1) % 3]), std::max(tri[k], tri[(k + 1) % 3])});
          vertices.push_back({tri[k], kNoIndex});
        }
      }
    }
    std::sort(elements.begin(), elements.end());
    elements.erase(std::unique(elements.begin(), elements.end()), elements.end());
    std::sort(vertices.begin(), vertices.end());
    vertices.erase(std::unique(vertices.begin(), vertices.end()), vertices.end());
    elements.insert(elements.end(), vertices.begin(), vertices.end());
    for (const auto& x : elements) {
      std::vector<Index> star;
      for (Index i = start_[x[0]]; i < start_[x[0] + 1]; ++i) {
        const Index t = star_[i];
        if (x[1] == kNoIndex || topo::local_vertex(m_.tets[t], x[1]) >= 0) star.push_back(t);
      }
      // Sectors: star tets joined across faces that contain x, on the same side.
      UnionFind uf(star.size());
      auto pos = [&](Index t) { return static_cast<Index>(std::lower_bound(star.begin(), star.end(), t) - star.begin()); };
      for (Index i = 0; i < star.size(); ++i) {
        const Tet& v = m_.tets[star[i]];
        const bool in_l = d_.tet_leaf[star[i]] == l;
        for (int f = 0; f < 4; ++f) {
          if (v[f] == x[0] || v[f] == x[1]) continue;  // face f lacks the opposite vertex v[f]
          const Index u = nbr_[4 * star[i] + Index(f)];
          if (u == kNoIndex || (d_.tet_leaf[u / 4] == l) != in_l) continue;
          uf.unite(i, pos(u / 4));
        }
      }
      std::size_t l_sectors = 0;
      Index best_in = kNoIndex, best_out = kNoIndex;  // roots of the smallest movable sectors
      std::vector<Index> count(star.size(), 0);
      std::vector<unsigned char> pinned(star.size(), 0);
      for (Index i = 0; i < star.size(); ++i) {
        ++count[uf.find(i)];
        pinned[uf.find(i)] |= pinned_[star[i]];
      }
      for (Index i = 0; i < star.size(); ++i) {
        if (uf.find(i) != i) continue;
        Index& best = d_.tet_leaf[star[i]] == l ? best_out : best_in;
        l_sectors += d_.tet_leaf[star[i]] == l ? 1 : 0;
        if (best == kNoIndex || count[i] < count[best]) best = i;
      }
      if (l_sectors < 2) continue;
      if (best_in != kNoIndex && pinned[best_in] != 0) {
        // Prefer any unpinned outside sector; else move the smallest own sector out.
        best_in = kNoIndex;
        for (Index i = 0; i < star.size(); ++i)
          if (uf.find(i) == i && d_.tet_leaf[star[i]] != l && pinned[i] == 0 &&
              (best_in == kNoIndex || count[i] < count[best_in]))
            best_in = i;
      }
      const Index root = best_in != kNoIndex ? best_in : best_out;
      for (Index i = 0; i < star.size(); ++i)
        if (uf.find(i) == root) move.tets.push_back(star[i]);
      if (root == best_in) {
        move.to = l;
        return move;
      }
      for (Index t : move.tets) {
        for (int f = 0; f < 4; ++f) {
          const Index u = nbr_[4 * t + Index(f)];
          if (u != kNoIndex && d_.tet_leaf[u / 4] != l) move.to = std::min(move.to, d_.tet_leaf[u / 4]);
        }
      }
      if (move.to != kNoIndex) return move;
      move.tets.clear();
      move.stuck = true;
    }
    return move;
  }

  /// Moves tet t to leaf `to`; `pin`: boundary extraction moved it there, and
  /// no other leaf's extraction may take it back (which could cycle forever).
  void move(Index t, Index to, bool pin = false) {
    pinned_[t] = pin ? 1 : 0;
    auto& from = d_.leaf_tets[d_.tet_leaf[t]];
    from.erase(std::lower_bound(from.begin(), from.end(), t));
    auto& dst = d_.leaf_tets[to];
    dst.insert(std::lower_bound(dst.begin(), dst.end(), t), t);
    d_.tet_leaf[t] = to;
  }

  /// Lowest leaf other than tet t's own that holds a face neighbour of t.
  Index neighbour_leaf(Index t) const {
    Index best = kNoIndex;
    for (int f = 0; f < 4; ++f) {
      const Index u = nbr_[4 * t + Index(f)];
      if (u != kNoIndex && d_.tet_leaf[u / 4] != d_.tet_leaf[t]) best = std::min(best, d_.tet_leaf[u / 4]);
    }
    return best;
  }

 private:
  const VolumeMesh& m_;
  Decomposition& d_;
  std::vector<Index> nbr_;
  std::vector<Index> start_, star_;  // vertex -> tets (CSR)
  std::vector<unsigned char> pinned_;
};

}  // namespace

FaceIdTable::FaceIdTable(std::span<const Tri> faces, std::span<const int> ids) {
  sorted_.reserve(faces.size());
  for (std::size_t i = 0; i < faces.size(); ++i)
    sorted_.emplace_back(topo::sorted_key(faces[i]), i < ids.size() ? ids[i] : 0);
  std::sort(sorted_.begin(), sorted_.end());
}

int FaceIdTable::lookup(const Tri& face) const {
  const Tri key = topo::sorted_key(face);
  const auto it = std::lower_bound(sorted_.begin(), sorted_.end(), std::pair<Tri, int>{key, std::numeric_limits<int>::min()});
  return it != sorted_.end() && it->first == key ? it->second : 0;
}

LeafTaskInput build_leaf_input(std::uint32_t leaf, std::span<const Vec3> points, std::span<const Tet> tets,
                               const FaceIdTable& boundary) {
  LeafTaskInput in;
  in.leaf = leaf;
  std::vector<Index> used;
  used.reserve(4 * tets.size());
  for (const Tet& t : tets) used.insert(used.end(), t.begin(), t.end());
  std::sort(used.begin(), used.end());
  used.erase(std::unique(used.begin(), used.end()), used.end());
  auto local = [&](Index g) { return static_cast<Index>(std::lower_bound(used.begin(), used.end(), g) - used.begin()); };
  in.point_ids.assign(used.begin(), used.end());
  in.points.reserve(used.size());
  for (Index g : used) in.points.push_back(points[g]);
  in.tets.reserve(tets.size());
  struct Face {
    Tri key;
    Tri tri;
    bool operator<(const Face& o) const { return key < o.key || (key == o.key && tri < o.tri); }
  };
  std::vector<Face> faces;
  faces.reserve(4 * tets.size());
  for (const Tet& t : tets) {
    const Tet lt = {local(t[0]), local(t[1]), local(t[2]), local(t[3])};
    in.tets.push_back(lt);
    for (int f = 0; f < 4; ++f) {
      const Tri tri = topo::face_of(lt, f);
      faces.push_back({topo::sorted_key(tri), tri});
    }
  }
  std::sort(faces.begin(), faces.end());
  for (std::size_t i = 0; i < faces.size();) {
    std::size_t j = i + 1;
    while (j < faces.size() && faces[j].key == faces[i].key) ++j;
    if (j - i == 1) {
      const Tri& t = faces[i].tri;
      in.frozen_faces.push_back(t);
      in.frozen_ids.push_back(boundary.lookup({used[t[0]], used[t[1]], used[t[2]]}));
    }
    i = j;
  }
  return in;
}

FixupStats apply_fixups(const VolumeMesh& mesh, Decomposition& d, std::size_t max_sweeps) {
  FixupStats stats;
  Fixer fixer(mesh, d);
  for (; stats.sweeps < max_sweeps; ++stats.sweeps) {
    bool changed = false;
    auto t0 = Clock::now();
    for (Index l = 0; l < d.size(); ++l) {
      for (Index t : fixer.loose_tets(l)) {
        const Index to = fixer.neighbour_leaf(t);
        if (to == kNoIndex) continue;
        fixer.move(t, to);
        ++stats.swaps;
        changed = true;
      }
    }
    stats.swap_s += seconds_since(t0);
    t0 = Clock::now();
    for (Index l = 0; l < d.size(); ++l) {
      // Bounded: a tet moved in or out is pinned where it goes, so it never
      // comes back into l by l's own extraction.
      for (std::size_t pass = 0; pass < 2 * mesh.tets.size(); ++pass) {
        const Fixer::Move move = fixer.extraction(l);
        if (move.tets.empty()) break;
        for (Index t : move.tets) fixer.move(t, move.to, true);
        stats.moves += move.tets.size();
        changed = true;
      }
    }
    stats.extraction_s += seconds_since(t0);
    if (!changed) break;
  }
  stats.unresolved = leaves_needing_fixups(mesh, d).size();
  return stats;
}

std::vector<Index> leaves_needing_fixups(const VolumeMesh& mesh, const Decomposition& d) {
  Decomposition copy = d;  // Fixer takes a mutable decomposition; nothing is moved here
  const Fixer fixer(mesh, copy);
  std::vector<Index> out;
  for (Index l = 0; l < d.size(); ++l) {
    const Fixer::Move move = fixer.extraction(l);
    if (!fixer.loose_tets(l).empty() || !move.tets.empty() || move.stuck) out.push_back(l);
  }
  return out;
}

namespace {

struct RoundResult {
  std::size_t leaves = 0;
  std::size_t max_leaf_tets = 0;
  double merge_s = 0;
  ScheduleStats schedule;
  FixupStats fixups;
};

struct TaskResult {
  LeafTaskInput input;
  Result<std::string> output;
};

/// One refinement round over decomposition d of `cur` (its tets in d's order
/// are replaced, its points appended to).
Status run_round(std::string_view phase, VolumeMesh& cur, Decomposition d, const FaceIdTable& boundary,
                 const SizingField& sizing, const LeafKernel& kernel, const PdrOptions& options, bool fixups,
                 RoundResult& rr) {
  if (fixups) rr.fixups = apply_fixups(cur, d, options.max_fixup_sweeps);
  rr.leaves = d.size();
  std::vector<std::vector<Tet>> leaf_tets(d.size());
  for (Index l = 0; l < d.size(); ++l) {
    for (Index t : d.leaf_tets[l]) leaf_tets[l].push_back(cur.tets[t]);
    rr.max_leaf_tets = std::max(rr.max_leaf_tets, leaf_tets[l].size());
  }
  std::vector<Vec3>& points = cur.points;
  std::shared_mutex mu;  // tasks read points while (kDynamic) merges append
  Status error;

  std::atomic<bool> stop{false};
  std::size_t merged = 0;
  std::size_t tet_count = cur.tets.size();
  if (options.progress && !options.progress({phase, 0, d.size(), tet_count})) {
    return cancelled(fmt::format("stopped before the {}", phase));
  }
  std::function<TaskResult(Index)> task = [&](Index l) -> TaskResult {
    if (stop.load()) return {LeafTaskInput{}, cancelled("stopped")};
    LeafTaskInput in;
    {
      std::shared_lock lock(mu);
      in = build_leaf_input(l, points, leaf_tets[l], boundary);
    }
    if (in.tets.empty()) {
      LeafTaskOutput empty;
      empty.leaf = l;
      return {std::move(in), empty.encode()};
    }
    Result<std::string> out = run_leaf_task(kernel, in.encode(), sizing);
    return {std::move(in), std::move(out)};
  };
  std::function<void(Index, TaskResult&&)> merge = [&](Index l, TaskResult&& r) {
    if (!error.ok()) return;
    const auto t0 = Clock::now();
    if (!r.output.ok()) {
      error = r.output.status();
      stop = true;
      return;
    }
    Result<LeafTaskOutput> out = LeafTaskOutput::decode(*r.output);
    if (!out.ok()) {
      error = Status(out.status().code(), fmt::format("leaf {}: {}", l, out.status().message()));
      stop = true;
      return;
    }
    if (Status s = validate_leaf_output(r.input, *out); !s.ok()) {
      error = s;
      stop = true;
      return;
    }
    const auto ni = static_cast<Index>(r.input.points.size());
    std::unique_lock lock(mu);
    const auto base = static_cast<Index>(points.size());
    points.insert(points.end(), out->new_points.begin(), out->new_points.end());
    std::vector<Tet>& tets = leaf_tets[l];
    tet_count = tet_count - tets.size() + out->tets.size();
    tets.clear();
    for (const Tet& t : out->tets) {
      Tet g;
      for (int i = 0; i < 4; ++i) g[i] = t[i] < ni ? static_cast<Index>(r.input.point_ids[t[i]]) : base + (t[i] - ni);
      tets.push_back(g);
    }
    rr.merge_s += seconds_since(t0);
    ++merged;
    if (options.progress && !options.progress({phase, merged, d.size(), tet_count})) {
      error = cancelled(fmt::format("stopped after {} of {} leaves ({})", merged, d.size(), phase));
      stop = true;
    }
  };
  rr.schedule = run_leaves<TaskResult>(d, std::max<std::size_t>(options.workers, 1), task, merge, options.policy);
  PDR_TRY(error);

  cur.tets.clear();
  cur.tet_regions.clear();
  for (Index l = 0; l < d.size(); ++l) {
    cur.tets.insert(cur.tets.end(), leaf_tets[l].begin(), leaf_tets[l].end());
    cur.tet_regions.insert(cur.tet_regions.end(), leaf_tets[l].size(), static_cast<int>(d.leaves[l]));
  }
  return {};
}

/// Drops points no tet uses, keeping the order of the others.
void remove_unused_points(VolumeMesh& m) {
  std::vector<Index> map(m.points.size(), kNoIndex);
  for (const Tet& t : m.tets)
    for (Index v : t) map[v] = 0;
  Index next = 0;
  for (std::size_t i = 0; i < map.size(); ++i) {
    if (map[i] == kNoIndex) continue;
    map[i] = next;
    m.points[next++] = m.points[i];
  }
  m.points.resize(next);
  for (Tet& t : m.tets)
    for (Index& v : t) v = map[v];
  for (Tri& f : m.boundary)
    for (Index& v : f) v = map[v];
}

}  // namespace

Result<VolumeMesh> run_pdr(const SurfaceMesh& surface, const SizingField& sizing, const LeafKernel& kernel,
                           const PdrOptions& options, PdrProfile* profile) {
  const auto t_total = Clock::now();
  PdrProfile local;
  PdrProfile& prof = profile ? *profile : local;
  prof = PdrProfile{};
  if (options.depth > kMaxDepth) {
    return invalid_input(fmt::format("octree depth {} is outside [0, {}] (or -1)", options.depth, kMaxDepth));
  }
  if (!(options.initial_volume_divisor > 0) || !std::isfinite(options.initial_volume_divisor)) {
    return invalid_input(fmt::format("initial_volume_divisor must be positive, got {}", options.initial_volume_divisor));
  }
  if (surface.points.empty() || surface.triangles.empty()) {
    return invalid_input(fmt::format("{}: the surface is empty", surface.name));
  }
  const Box bb = surface.bounds();
  const double side = std::max({bb.hi[0] - bb.lo[0], bb.hi[1] - bb.lo[1], bb.hi[2] - bb.lo[2]});
  int depth = options.depth;
  if (depth < 0) {
    double sum_h = 0;
    for (const Vec3& p : surface.points) sum_h += sizing.at(p);
    const double estimate =
        enclosed_volume(surface) / regular_tet_volume(sum_h / static_cast<double>(surface.points.size()));
    const double capped = std::isfinite(estimate) ? std::clamp(estimate, 0.0, 1e15) : 0.0;
    depth = default_depth(static_cast<std::size_t>(capped), options.final_tets_per_leaf);
  }
  prof.depth = depth;

  const auto report = [&](std::string_view phase, std::size_t tets) {
    return !options.progress || options.progress({phase, 0, 0, tets});
  };
  if (!report("initial mesh", 0)) return cancelled("stopped before the initial mesh");
  auto t0 = Clock::now();
  TetgenOptions tg;
  const double leaf_side = side / static_cast<double>(1 << depth);
  tg.max_volume = leaf_side * leaf_side * leaf_side / options.initial_volume_divisor;
  tg.time_limit_s = options.tetgen_time_limit_s;
  if (!(*tg.max_volume > 0) || !std::isfinite(*tg.max_volume)) tg.max_volume.reset();
  Result<VolumeMesh> initial = tetrahedralize(surface, tg);
  if (!initial.ok()) return initial.status();
  prof.initial = seconds_since(t0);
  prof.initial_tets = initial->tets.size();
  VolumeMesh cur = std::move(*initial);
  const FaceIdTable boundary(cur.boundary, cur.boundary_ids);
  const bool fixups = options.fixups.value_or(kernel.needs_manifold_hull());

  t0 = Clock::now();
  PDR_ASSIGN_OR_RETURN(Decomposition d1, decompose(cur, depth));
  prof.decomposition = seconds_since(t0);
  const Box box1 = d1.box;
  RoundResult r1;
  t0 = Clock::now();
  PDR_TRY(run_round("refinement", cur, std::move(d1), boundary, sizing, kernel, options, fixups, r1));
  prof.leaves = seconds_since(t0) - r1.fixups.swap_s - r1.fixups.extraction_s;
  prof.leaf_count = r1.leaves;
  prof.max_leaf_tets = r1.max_leaf_tets;
  prof.max_concurrency = r1.schedule.max_concurrency;

  RoundResult r2;
  if (options.interface_round && depth > 0) {
    t0 = Clock::now();
    Box box2 = box1;
    const double half = 0.5 * (box1.hi[0] - box1.lo[0]) / static_cast<double>(1 << depth);
    for (int k = 0; k < 3; ++k) {
      box2.lo[k] += half;
      box2.hi[k] += half;
    }
    const auto td = Clock::now();
    PDR_ASSIGN_OR_RETURN(Decomposition d2, decompose(cur, depth, box2));
    prof.decomposition += seconds_since(td);
    PDR_TRY(run_round("interface round", cur, std::move(d2), boundary, sizing, kernel, options, fixups, r2));
    prof.interface_round = seconds_since(t0);
    prof.interface_leaf_count = r2.leaves;
    prof.max_concurrency = std::max(prof.max_concurrency, r2.schedule.max_concurrency);
  }
  prof.partition_swap = r1.fixups.swap_s + r2.fixups.swap_s;
  prof.boundary_extraction = r1.fixups.extraction_s + r2.fixups.extraction_s;
  prof.fixups = prof.partition_swap + prof.boundary_extraction;
  prof.fixup_swaps = r1.fixups.swaps + r2.fixups.swaps;
  prof.fixup_moves = r1.fixups.moves + r2.fixups.moves;
  prof.fixup_unresolved = r1.fixups.unresolved + r2.fixups.unresolved;
  prof.merge = r1.merge_s + r2.merge_s;

  remove_unused_points(cur);
  prof.interior_points = cur.points.size() - surface.points.size();
  if (options.optimize) {
    if (!report("optimization", cur.tets.size())) return cancelled("stopped before the optimization");
    t0 = Clock::now();
    PDR_TRY(options.optimize(cur));
    prof.optimization = seconds_since(t0);
  }
  prof.final_tets = cur.tets.size();
  prof.total = seconds_since(t_total);
  return cur;
}

}  // namespace pdrmesh
