// SPDX-License-Identifier: AGPL-3.0-or-later
// The optimizer's bookkeeping: the bad-tet list and the angle range kept current at
// the cost of the changes, star walks, the created/touched tets of each operation, and
// the fixed and surface points. Nothing here changes the mesh but move_point.
#include "optimizer.hpp"

namespace pdrmesh::optimize_detail {

/// Whether attempt a on tet (or point) i failed under the present
/// parameters and nothing it reads has changed since (s_.failed, s_.stamp).
bool Optimizer::failed_before(Attempt a, Index i) const {
  const OptimizerState::Failures& f = s_.failed[static_cast<std::size_t>(a)];
  const auto it = f.at.find(i);
  if (it == f.at.end() || it->second < f.from) return false;
  const auto later = [&](Index v) { return v < s_.stamp.size() && s_.stamp[v] > it->second; };
  if (a >= Attempt::kSmooth) return !later(i);
  for (Index v : m_.tet(i))
    if (later(v)) return false;
  return true;
}

/// Notes that attempt a on tet (or point) i failed now.
void Optimizer::remember_failure(Attempt a, Index i) {
  s_.failed[static_cast<std::size_t>(a)].at[i] = s_.clock;
}

/// The parameters of attempt a from now on; failures under other ones no longer count.
void Optimizer::attempt_key(Attempt a, const AttemptKey& key) {
  OptimizerState::Failures& f = s_.failed[static_cast<std::size_t>(a)];
  if (f.key == key) return;
  f.key = key;
  f.from = ++s_.clock;
}

/// The badness of the alive tet t, through s_.known (see there).
Badness Optimizer::badness(Index t) const {
  if (t >= s_.known.size()) s_.known.resize(m_.num_slots(), 0);  // never inside bad_flags' parallel scan
  unsigned char& k = s_.known[t];
  if (k == 0) k = static_cast<unsigned char>(1 + static_cast<int>(compute_badness(t)));
  return static_cast<Badness>(k - 1);
}

Badness Optimizer::compute_badness(Index t) const {
  const auto p = corners(m_, m_.tet(t));
  return badness_of(dihedral_range(p[0], p[1], p[2], p[3]));
}

/// The badness of a tet whose dihedral angles span r.
Badness Optimizer::badness_of(const AngleRange& r) const {
  const bool small = r.min < o_.target_min_dihedral, large = r.max > o_.target_max_dihedral;
  if (small && large) return Badness::kSliver;
  return small || large ? Badness::kBad : Badness::kGood;
}

/// Per slot: 1 for a live bad tet (computed in parallel). The first call
/// builds the angle tree (angles()) in the same pass, which notes every
/// tet's badness in s_.known.
std::vector<unsigned char> Optimizer::bad_flags() {
  if (s_.known.size() < m_.num_slots()) s_.known.resize(m_.num_slots(), 0);
  if (!s_.range_built) {
    s_.range.build(m_, [this](Index t, const AngleRange& r) {
      s_.known[t] = static_cast<unsigned char>(1 + static_cast<int>(badness_of(r)));
    });
    s_.range_built = true;
  }
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
const std::vector<Index>& Optimizer::bad_tets() {
  if (!s_.bad_known) {
    const std::vector<unsigned char> is_bad = bad_flags();
    s_.bad.clear();
    for (Index t = 0; t < m_.num_slots(); ++t)
      if (is_bad[t] != 0) s_.bad.push_back(t);
    s_.bad_known = true;
    s_.touched.clear();
    return s_.bad;
  }
  if (s_.touched.empty()) return s_.bad;
  // With parallel_moves, the sort and the badness of the merged tets side by
  // side (each slot once: badness writes only its own entry of s_.known).
  const bool parallel = o_.parallel_moves && s_.touched.size() >= kParallelMovesMin;
  sort_unique(s_.touched, parallel);
  std::vector<Index> merged;
  merged.reserve(s_.bad.size() + s_.touched.size());
  std::set_union(s_.bad.begin(), s_.bad.end(), s_.touched.begin(), s_.touched.end(), std::back_inserter(merged));
  s_.touched.clear();
  if (s_.known.size() < m_.num_slots()) s_.known.resize(m_.num_slots(), 0);
  s_.bad = each_chunk(merged, [&](Index t, std::vector<Index>& out) {
    if (m_.alive(t) && badness(t) != Badness::kGood) out.push_back(t);
  }, parallel);
  return s_.bad;
}

/// The mesh's extreme dihedral angles now (s_.range, built on first use).
AngleRange Optimizer::angles() {
  if (!s_.range_built) {
    s_.range.build(m_, [](Index, const AngleRange&) {});
    s_.range_built = true;
  }
  return s_.range.range(m_);
}

/// Any live tet holding point v, or kNoIndex for a point in none: s_.any_tet,
/// one scan of the mesh on first use, then kept by forget_created.
Index Optimizer::any_tet(Index v) {
  if (!s_.any_known) {
    s_.any_known = true;
    s_.any_tet.assign(m_.num_points(), kNoIndex);
    for (Index t = 0; t < m_.num_slots(); ++t)
      if (m_.alive(t))
        for (Index u : m_.tet(t)) s_.any_tet[u] = t;
  }
  if (v >= s_.any_tet.size()) return kNoIndex;
  const Index t = s_.any_tet[v];
  if (t == kNoIndex || !m_.alive(t)) return kNoIndex;  // a removed point
  for (Index u : m_.tet(t))
    if (u == v) return t;
  return kNoIndex;
}

/// The live tets holding point v, by a walk across the faces through v (for
/// a free point, which lies on no kept face, all of them), appended to out.
void Optimizer::star_tets(Index v, std::vector<Index>& out) {
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
Index Optimizer::first_tet(Index v) {
  walk_.clear();
  star_tets(v, walk_);
  return walk_.empty() ? kNoIndex : *std::min_element(walk_.begin(), walk_.end());
}

/// Marks in s_.fixed the points on a frozen, hull or region face, and in
/// s_.surface those on a boundary triangle that is not a leaf's interface
/// (TetMesh::boundary() with a non-zero id, or any when there are no ids).
void Optimizer::find_fixed() {
  // No operation of the optimizer changes which points are fixed (flips and
  // insertions refuse frozen, hull and region faces; a new point is free),
  // so the marks are found once and only grow with the points after that.
  if (s_.fixed_known) {
    s_.fixed.resize(m_.num_points(), 0);
    s_.surface.resize(m_.num_points(), 0);
    return;
  }
  s_.fixed_known = true;
  s_.surface.assign(m_.num_points(), 0);
  for (std::size_t i = 0; i < m_.boundary().size(); ++i)
    if (surface_triangle(i))
      for (Index v : m_.boundary()[i]) s_.surface[v] = 1;
  s_.fixed.assign(m_.num_points(), 0);
  for (Index t = 0; t < m_.num_slots(); ++t) {
    if (!m_.alive(t)) continue;
    const Tet& k = m_.tet(t);
    for (int f = 0; f < 4; ++f)
      if (kept_face(t, f))
        for (int j = 0; j < 3; ++j) s_.fixed[k[topo::kFaceVertex[f][j]]] = 1;
  }
}

/// The tets of `tets` with no fixed point (as the last smooth() found them;
/// points added since are free).
std::vector<Index> Optimizer::interior(const std::vector<Index>& tets) const {
  std::vector<Index> out;
  for (Index t : tets) {
    bool free = true;
    for (Index v : m_.tet(t)) free = free && (v >= s_.fixed.size() || s_.fixed[v] == 0);
    if (free) out.push_back(t);
  }
  return out;
}

void Optimizer::start_sweep() {
  flips_this_sweep_ = 0;
  flip_budget_ = static_cast<std::size_t>(kMaxFlipsPerTet * m_.num_tets()) + 1;
}

bool Optimizer::push_created() {
  forget_created();
  for (Index c : m_.last_created()) queue_.push_back(c);
  return true;
}

/// Drops the known badness of the tets the last operation created, and
/// notes them (touch); their points now lie in them (s_.any_tet).
void Optimizer::forget_created() {
  for (Index c : m_.last_created()) {
    touch(c);
    if (!s_.any_known) continue;
    for (Index v : m_.tet(c)) {
      if (v >= s_.any_tet.size()) s_.any_tet.resize(v + 1, kNoIndex);
      s_.any_tet[v] = c;
    }
  }
}

/// Slot t holds a new tet, or one whose points moved: its badness is
/// unknown, bad_tets() and angles() look at it again, and its points get a
/// new stamp (failed attempts around them may succeed now).
void Optimizer::touch(Index t) {
  ++s_.clock;
  for (Index v : m_.tet(t)) {
    if (v >= s_.stamp.size()) s_.stamp.resize(std::max<std::size_t>(v + 1, m_.num_points()), 0);
    s_.stamp[v] = s_.clock;
  }
  if (t < s_.known.size()) s_.known[t] = 0;
  if (s_.bad_known) s_.touched.push_back(t);
  if (s_.range_built) s_.range.touch(t);
}

/// No vertex of tet t is fixed (s_.fixed as find_fixed left it; later points are free).
bool Optimizer::free_tet(Index t) const {
  for (Index v : m_.tet(t))
    if (v < s_.fixed.size() && s_.fixed[v] != 0) return false;
  return true;
}

/// Whether a point of face f is on the surface (s_.surface).
bool Optimizer::on_surface(const Tri& f) const {
  for (Index v : f)
    if (v < s_.surface.size() && s_.surface[v] != 0) return true;
  return false;
}

/// The points of link_, each once and ascending, into link_points_.
void Optimizer::gather_link_points() {
  link_points_.clear();
  for (const Tri& f : link_) link_points_.insert(link_points_.end(), f.begin(), f.end());
  sort_unique(link_points_);
}

/// The star of v (gather_star from `start`) and its link faces, turned
/// towards v, into link_ (in star_ order).
void Optimizer::gather_link(Index v, Index start) {
  gather_star(v, start);
  last_failed_ = 0;
  edge_bounds_.clear();
  link_.clear();
  for (const auto& [t, lv] : star_) {
    const Tri f = topo::face_of(m_.tet(t), lv);  // outward: away from v
    link_.push_back({f[0], f[2], f[1]});
  }
}

/// Moves v to x and forgets what was known of its star's tets. In a hand,
/// what the holder keeps (mark_moved, touch) waits in note_ (note_moved).
void Optimizer::move_point(Index v, const Vec3& x) {
  m_.set_point(v, x);
  if (note_ != nullptr) {
    note_->point = v;
    note_->tets.clear();
    for (const auto& s : star_) {
      m_.invalidate_quality(s.first);
      s_.known[s.first] = 0;
      note_->tets.push_back(s.first);
    }
    return;
  }
  mark_moved(v);
  for (const auto& s : star_) {
    m_.invalidate_quality(s.first);
    touch(s.first);
  }
}

/// The holder's part of a hand's move (move_point): as if it had moved the point itself.
void Optimizer::note_moved(const MoveNote& note) {
  mark_moved(note.point);
  for (Index t : note.tets) touch(t);
}

void Optimizer::mark_moved(Index v) {
  if (v >= s_.moved.size()) s_.moved.resize(v + 1, 0);
  if (s_.moved[v] == 0) s_.moved_list.push_back(v);
  s_.moved[v] = 1;
}

/// Whether the angles of r lie within `bounds`.
bool Optimizer::within(const AngleRange& r, const AngleRange& bounds) {
  return r.min >= bounds.min && r.max <= bounds.max;
}

/// Whether boundary triangle i is on the surface, not a leaf's interface: a
/// non-zero id, or any triangle when there are no ids.
bool Optimizer::surface_triangle(std::size_t i) const {
  return m_.boundary_ids().size() != m_.boundary().size() || m_.boundary_ids()[i] != 0;
}

/// Face f of t stays as it is (its points are fixed; a cap repair keeps it):
/// a hull face, a frozen face or a face between two regions.
bool Optimizer::kept_face(Index t, int f) const {
  const Index n = m_.neighbour(t, f);
  return n == kNoIndex || m_.frozen(t, f) || m_.region(face_tet(n)) != m_.region(t);
}

/// The unit normal of t's kept face f, pointing into t, into `n`; false when
/// the face has no area.
bool Optimizer::kept_face_normal(Index t, int f, Vec3& n) const {
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
AngleRange Optimizer::angle_range(const Vec3* x, std::span<const Index> tets) const {
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

/// Whether every point of tet t lies on a surface triangle.
bool Optimizer::all_on_surface(Index t) const {
  for (Index v : m_.tet(t))
    if (v >= s_.surface.size() || s_.surface[v] == 0) return false;
  return true;
}

/// Whether a point of tet t is free (not in s_.fixed as find_fixed left it;
/// later points are free).
bool Optimizer::free_point(Index t) const {
  for (Index v : m_.tet(t))
    if (v >= s_.fixed.size() || s_.fixed[v] == 0) return true;
  return false;
}

}  // namespace pdrmesh::optimize_detail
