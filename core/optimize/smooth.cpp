// SPDX-License-Identifier: AGPL-3.0-or-later
// Smoothing: each free point of a bad tet moved (line search towards ideal positions,
// then a compass search) to raise its star's worst measure; a move is taken only where
// no tet of the star gets worse than the rules allow and every tet stays positive.
#include "moves.hpp"

namespace pdrmesh::optimize_detail {

/// One smoothing pass over the free vertices of bad tets (with
/// rule.interior_only, of the bad tets with no fixed point), ascending.
std::size_t Optimizer::smooth(const SmoothRule& rule) {
  find_fixed();
  std::vector<Index> bad = bad_tets();
  if (rule.interior_only) bad = interior(bad);
  std::vector<Index> todo, next;
  for (Index t : bad)
    for (Index v : m_.tet(t))
      if (!s_.fixed[v]) todo.push_back(v);
  sort_unique(todo);
  // Passes over the free vertices of bad tets, ascending; the next pass takes
  // the free vertices of the bad tets left in the stars of the points just
  // moved (the topology does not change here).
  // Passes after the first together try at most max(kSmoothRetriesMin,
  // kSmoothRetries * tets) vertices (where most tets are beyond repair, as next to needle
  // triangles, they would otherwise take the time of many sweeps).
  std::size_t moved = 0;
  std::size_t retries =
      std::max(kSmoothRetriesMin, static_cast<std::size_t>(kSmoothRetries * m_.num_tets()));
  attempt_key(Attempt::kSmooth, {rule.interior_only ? 1.0 : 0.0, rule.pin_fixed ? 1.0 : 0.0, rule.pin_floor, 0.0});
  for (int pass = 0; pass < kSmoothPasses && !todo.empty(); ++pass) {
    std::span<const Index> now(todo);
    if (pass > 0) {
      now = now.first(std::min(now.size(), retries));
      retries -= now.size();
    }
    next.clear();
    const std::size_t moved_now = move_points(
        now, Attempt::kSmooth, /*tallied=*/true,
        [&rule](Optimizer& opt, Index v, Index start) { return opt.smooth_vertex(v, start, rule); },
        [](Optimizer& opt, std::vector<Index>& out) { opt.bad_star_points(out); }, next);
    moved += moved_now;
    if (moved_now == 0) break;
    sort_unique(next);
    std::swap(todo, next);
  }
  st_.points_moved += moved;
  return moved;
}

/// The free points of the bad tets of star_, appended to `next`.
void Optimizer::bad_star_points(std::vector<Index>& next) const {
  for (const auto& s : star_)
    if (badness(s.first) != Badness::kGood)
      for (Index u : m_.tet(s.first))
        if (!s_.fixed[u]) next.push_back(u);
}

/// Worst measure of the tets (link face, x); -inf when one is not positive.
double Optimizer::star_quality(const Vec3& x) const {
  double worst = std::numeric_limits<double>::infinity();
  for (const Tri& f : link_) {
    const std::array<Vec3, 4> p{m_.point(f[0]), m_.point(f[1]), m_.point(f[2]), x};
    if (exact::orient3d(p[0], p[1], p[2], p[3]) <= 0)
      return -std::numeric_limits<double>::infinity();
    worst = std::min(worst, measure(p));
  }
  return worst;
}

/// Best position for the apex of the tets over link_ (star_quality), starting
/// from `old` and moving towards the candidate targets with a line search
/// (kLineSteps steps 1, 1/2, 1/4, ...; the first step that beats q0 is taken
/// per target).
/// Returns the best quality found, > q0 only when `best` improves.
/// With `profile` (the smoothing's rule), a position counts as better when
/// its star_profile is lexicographically greater (the first differing quality
/// higher) than the one in profile_old_ (and than the best so far); the
/// return value is then the best profile's worst quality.
double Optimizer::best_position(const Vec3& old, double q0, Vec3& best, const SmoothRule* profile) {
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
    if (profile != nullptr && profile->pin_floor < 1.0 && pinned_[i] && !all_pinned_) continue;
    const Tri& f = link_[i];
    const Vec3 &a = m_.point(f[0]), &b = m_.point(f[1]), &c = m_.point(f[2]);
    const double q = measure({a, b, c, old});
    if (!(q < worst_q)) continue;
    worst_q = q;
    worst_ideal = regular_apex(a, b, c);
  }

  double best_q = q0;
  best = old;
  if (profile != nullptr) profile_best_ = profile_old_;
  for (const Vec3& target : {laplace, ideal, worst_ideal}) {
    double step = 1.0;
    for (int i = 0; i < kLineSteps; ++i, step *= 0.5) {
      const Vec3 x = old + step * (target - old);
      if (profile != nullptr) {
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
bool Optimizer::star_measures(const Vec3& x, std::vector<double>& out, double floor) const {
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
void Optimizer::to_profile(const std::vector<double>& measures, std::vector<double>& out) const {
  out.clear();
  for (std::size_t i = 0; i < measures.size(); ++i)
    if (!pinned_[i] || all_pinned_) out.push_back(std::min(measures[i], 1.0));
  std::sort(out.begin(), out.end());
}

/// Whether apex position x keeps every edge bound of edge_bounds_.
bool Optimizer::keeps_edge_sizes(const Vec3& x) const {
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
bool Optimizer::smoothing_accepts(const Vec3& x) {
  if (!keeps_edge_sizes(x)) return false;
  // The tet that failed the last trial first: most trials fail, mostly on
  // the tet that failed the one before, and the decision does not depend on
  // the order.
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
std::optional<double> Optimizer::link_measure(std::size_t i, const Vec3& x) const {
  const Tri& f = link_[i];
  const std::array<Vec3, 4> p{m_.point(f[0]), m_.point(f[1]), m_.point(f[2]), x};
  const double q = measure(p);
  if (q < lower_[i] || exact::orient3d(p[0], p[1], p[2], p[3]) <= 0) return std::nullopt;
  return q;
}

/// With keep_edge_sizes and a sizing field: the least lengths of the edges
/// from a point at `old` to the link points off the surface (edge_bounds_):
/// kShortEdge times h at the edge's midpoint, or its old length when that
/// is less.
void Optimizer::bound_edge_sizes(const Vec3& old) {
  if (sizing_ == nullptr || !o_.keep_edge_sizes) return;
  gather_link_points();
  for (Index u : link_points_) {
    if (u < s_.surface.size() && s_.surface[u] != 0) continue;
    const Vec3& p = m_.point(u);
    const double least = std::min(norm(old - p), kShortEdge * size_at(0.5 * (old + p)));
    edge_bounds_.push_back({u, least * least});
  }
}

/// Smoothing of the free point v (smooth): kDone when it moved, kWouldInvert
/// when its star holds a tet that is not positive already, else kNotBetter.
Outcome Optimizer::smooth_vertex(Index v, Index start, const SmoothRule& rule) {
  gather_link(v, start);
  const Vec3 old = m_.point(v);
  Vec3 best;
  if (!star_measures(old, measures_old_)) return Outcome::kWouldInvert;
  // In the polishing rounds, a tet with a fixed point is pinned: it only
  // must not get worse, and the move is judged by the other tets' profile.
  const bool pin = rule.interior_only && rule.pin_fixed;
  pinned_.assign(link_.size(), 0);
  all_pinned_ = true;
  for (std::size_t i = 0; i < link_.size(); ++i) {
    bool pinned = false;
    for (Index u : link_[i]) pinned = pinned || (pin && u < s_.fixed.size() && s_.fixed[u] != 0);
    pinned_[i] = pinned ? 1 : 0;
    all_pinned_ = all_pinned_ && pinned;
  }
  to_profile(measures_old_, profile_old_);
  if (profile_old_.front() >= 1.0) return Outcome::kNotBetter;  // the star is good already
  bound_edge_sizes(old);
  lower_.resize(link_.size());
  for (std::size_t i = 0; i < link_.size(); ++i)
    lower_[i] = pinned_[i] && !all_pinned_ ? std::min(measures_old_[i], on_surface(link_[i]) ? rule.pin_floor : 1.0)
                                           : profile_old_.front();
  // Targets and line search as best_position, but compared by the star's
  // profile (smoothing_accepts): a move may improve a bad tet while the
  // star's worst tet, which v cannot help (e.g. a tet on the boundary), stays
  // as it is; tets within the targets count as equal.
  const double q0 = profile_old_.front();
  (void)best_position(old, q0, best, &rule);
  if (best == old) {
    // Steps that smoothing_accepts and whose profile beats profile_best_
    // (the old profile: no target helped).
    best = compass_search(old, [this](const Vec3& y) {
      if (!smoothing_accepts(y) || !(profile_best_ < profile_new_)) return false;
      std::swap(profile_best_, profile_new_);
      return true;
    });
  }
  if (best == old) return Outcome::kNotBetter;
  move_point(v, best);
  return Outcome::kDone;
}

}  // namespace pdrmesh::optimize_detail
