// SPDX-License-Identifier: AGPL-3.0-or-later
// Tests of the flips on tiny named configurations: each accepts when the
// largest dihedral angle drops, and declines when worse, constrained, or when
// the result would invert.
#include "pdrmesh/flips.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <span>

#include "pdrmesh/topology.hpp"
#include "tet_fixtures.hpp"

namespace pdrmesh {
namespace {

using fixtures::build;
using fixtures::max_dihedral;
using fixtures::total_volume;

constexpr int kEdgeAB = topo::kEdgeIndex[0][1];  // edge_ring fixtures hold a, b at local 0, 1

/// Two tets on an equilateral triangle with apexes at heights -hd and he above
/// offsets; points 0..2 = triangle, 3 = d (below), 4 = e (above).
VolumeMesh pair_on_triangle(const Vec3& d, const Vec3& e) {
  const auto tri = fixtures::polygon(3, 1.0 / std::sqrt(3.0));
  return fixtures::two_tets(tri[0], tri[1], tri[2], d, e);
}
VolumeMesh flat_pair() { return pair_on_triangle({0, 0, -0.1}, {0, 0, 0.1}); }
VolumeMesh tall_pair() { return pair_on_triangle({0, 0, -2}, {0, 0, 2}); }
/// e lies above the plane but beyond the edge of the triangle: de misses it.
VolumeMesh skew_pair() { return pair_on_triangle({0, 0, -0.3}, {1.5, 0, 0.3}); }

VolumeMesh ring_around(int n, double ring_radius, double za, double zb) {
  return fixtures::edge_ring({0, 0, za}, {0, 0, zb}, fixtures::polygon(n, ring_radius));
}
/// Four tets around a vertical edge through a thin rhombus: the short diagonal
/// (points 3 and 5) is the better one.
VolumeMesh rhombus_ring(double za, double zb) {
  return fixtures::edge_ring({0, 0, za}, {0, 0, zb},
                             {{1, 0, 0}, {0, 0.3, 0}, {-1, 0, 0}, {0, -0.3, 0}});
}

/// Freezes the face that tet 0 of an edge_ring fixture shares with tet 1.
void freeze_first_ring_face(TetMesh& m) {
  EdgeRing r;
  ASSERT_TRUE(m.edge_ring(0, kEdgeAB, r));
  m.set_frozen(r.tets[0], topo::local_vertex(m.tet(r.tets[0]), r.ring[0]), true);
}

/// Asserts the common properties of an accepted flip.
void expect_done(TetMesh& m, FlipOutcome o, Index tets_after, double volume_before,
                 double max_dihedral_before) {
  ASSERT_EQ(o, FlipOutcome::kDone) << to_string(o);
  EXPECT_TRUE(m.check().ok()) << m.check().to_string();
  EXPECT_EQ(m.num_tets(), tets_after);
  EXPECT_EQ(m.last_created().size(), tets_after);
  for (Index t : m.last_created()) EXPECT_TRUE(m.active(t));
  EXPECT_NEAR(total_volume(m), volume_before, 1e-12 * std::abs(volume_before));
  EXPECT_LT(max_dihedral(m), max_dihedral_before);
}

/// Asserts a declined flip with the given outcome left the mesh as it was.
void expect_declined(TetMesh& m, FlipOutcome got, FlipOutcome want, const VolumeMesh& before) {
  EXPECT_EQ(got, want) << to_string(got) << " instead of " << to_string(want);
  EXPECT_EQ(m.to_volume_mesh().tets, before.tets);
  EXPECT_TRUE(m.check().ok());
}

/// Builds v, optionally freezes a face on its edge ab, applies `op` to edge ab
/// of tet 0 and expects it to decline with `want`, leaving the mesh unchanged.
using EdgeFlip = FlipOutcome (*)(TetMesh&, Index, int);
void expect_edge_flip_declined(const VolumeMesh& v, EdgeFlip op, FlipOutcome want,
                               bool freeze = false) {
  TetMesh m = build(v);
  if (freeze) freeze_first_ring_face(m);
  expect_declined(m, op(m, 0, kEdgeAB), want, v);
}

TEST(Flip23, AcceptsWhenTheFlatPairImproves) {
  TetMesh m = build(flat_pair());
  const double v = total_volume(m), worst = max_dihedral(m);
  expect_done(m, flip23(m, 0, 3), 3, v, worst);
  EXPECT_NE(fixtures::find_edge(m, 3, 4).first, kNoIndex);  // the new edge de
  // The 3-2 back to where it came from is worse.
  const auto [t, e] = fixtures::find_edge(m, 3, 4);
  EXPECT_EQ(flip32(m, t, e), FlipOutcome::kNotBetter);
}

TEST(Flip23, DeclinesWhenNotBetter) {
  TetMesh m = build(tall_pair());
  expect_declined(m, flip23(m, 0, 3), FlipOutcome::kNotBetter, tall_pair());
}

TEST(Flip23, DeclinesWhenResultWouldInvert) {
  TetMesh m = build(skew_pair());
  expect_declined(m, flip23(m, 0, 3), FlipOutcome::kWouldInvert, skew_pair());
}

TEST(Flip23, DeclinesFrozenFace) {
  TetMesh m = build(flat_pair());
  m.set_frozen(0, 3, true);
  expect_declined(m, flip23(m, 0, 3), FlipOutcome::kConstrained, flat_pair());
}

TEST(Flip23, DeclinesHullFace) {
  TetMesh m = build(flat_pair());
  expect_declined(m, flip23(m, 0, 0), FlipOutcome::kNotApplicable, flat_pair());
}

TEST(Flip23, DeclinesAcrossRegions) {
  VolumeMesh v = flat_pair();
  v.tet_regions = {1, 2};
  TetMesh m = build(v);
  expect_declined(m, flip23(m, 0, 3), FlipOutcome::kConstrained, v);
}

TEST(Flip32, AcceptsRemovingALongEdge) {
  TetMesh m = build(ring_around(3, 1.0, -2, 2));
  const double v = total_volume(m), worst = max_dihedral(m);
  expect_done(m, flip32(m, 0, kEdgeAB), 2, v, worst);
  EXPECT_EQ(fixtures::find_edge(m, 0, 1).first, kNoIndex);
}

TEST(Flip32, DeclinesWhenNotBetter) {
  expect_edge_flip_declined(ring_around(3, 1.0, -0.1, 0.1), flip32, FlipOutcome::kNotBetter);
}

TEST(Flip32, DeclinesWhenResultWouldInvert) {
  // The edge lies above the ring's plane: both new tets cannot be positive.
  expect_edge_flip_declined(ring_around(3, 1.0, 1, 2), flip32, FlipOutcome::kWouldInvert);
}

TEST(Flip32, DeclinesEdgeOnFrozenFace) {
  expect_edge_flip_declined(ring_around(3, 1.0, -2, 2), flip32, FlipOutcome::kConstrained, true);
}

TEST(Flip32, DeclinesHullEdgeAndOtherRingSizes) {
  const VolumeMesh cube = fixtures::cube();
  TetMesh m = build(cube);
  const auto [t, e] = fixtures::find_edge(m, 0, 1);
  expect_declined(m, flip32(m, t, e), FlipOutcome::kNotApplicable, cube);
  const VolumeMesh four = ring_around(4, 1.0, -2, 2);
  TetMesh m4 = build(four);
  expect_declined(m4, flip32(m4, 0, kEdgeAB), FlipOutcome::kNotApplicable, four);
}

TEST(Flip44, AcceptsAndPicksTheShortDiagonal) {
  TetMesh m = build(rhombus_ring(-1, 1));
  const double v = total_volume(m), worst = max_dihedral(m);
  expect_done(m, flip44(m, 0, kEdgeAB), 4, v, worst);
  EXPECT_NE(fixtures::find_edge(m, 3, 5).first, kNoIndex);
  EXPECT_EQ(fixtures::find_edge(m, 2, 4).first, kNoIndex);
  EXPECT_EQ(fixtures::find_edge(m, 0, 1).first, kNoIndex);
}

TEST(Flip44, DeclinesWhenNotBetter) {
  expect_edge_flip_declined(rhombus_ring(-0.05, 0.05), flip44, FlipOutcome::kNotBetter);
}

TEST(Flip44, DeclinesWhenResultWouldInvert) {
  expect_edge_flip_declined(rhombus_ring(1, 2), flip44, FlipOutcome::kWouldInvert);
}

TEST(Flip44, DeclinesEdgeOnFrozenFace) {
  expect_edge_flip_declined(rhombus_ring(-1, 1), flip44, FlipOutcome::kConstrained, true);
}

TEST(EdgeRemoval, AcceptsLongEdgesWithThreeToSevenTets) {
  for (int n = 3; n <= 7; ++n) {
    SCOPED_TRACE(n);
    TetMesh m = build(ring_around(n, 1.0, -3, 3));
    const double v = total_volume(m), worst = max_dihedral(m);
    expect_done(m, remove_edge(m, 0, kEdgeAB), static_cast<Index>(2 * (n - 2)), v, worst);
  }
}

TEST(EdgeRemoval, DeclinesFiveTetsAroundAShortEdge) {
  expect_edge_flip_declined(ring_around(5, 1.0, -0.1, 0.1), remove_edge, FlipOutcome::kNotBetter);
}

TEST(EdgeRemoval, DeclinesFiveTetsWhenEveryTriangulationInverts) {
  expect_edge_flip_declined(ring_around(5, 1.0, 1, 2), remove_edge, FlipOutcome::kWouldInvert);
}

TEST(EdgeRemoval, DeclinesFiveTetsAroundAFrozenFace) {
  expect_edge_flip_declined(ring_around(5, 1.0, -3, 3), remove_edge, FlipOutcome::kConstrained,
                            true);
}

TEST(EdgeRemoval, DeclinesRingsLongerThanTheLimit) {
  expect_edge_flip_declined(ring_around(kMaxRemovalRing + 1, 1.0, -3, 3), remove_edge,
                            FlipOutcome::kNotApplicable);
}

TEST(EdgeRemoval, NonConvexRingKeepsOnlyValidTriangulations) {
  // A ring with a reflex vertex (seen along the edge): some triangulations of
  // the ring invert; the chosen one must not.
  const VolumeMesh v = fixtures::edge_ring(
      {0, 0, -3}, {0, 0, 3}, {{1, 0, 0}, {0.1, 0.1, 0}, {0, 1, 0}, {-1, 0, 0}, {0, -1, 0}});
  TetMesh m = build(v);
  const double vol = total_volume(m), worst = max_dihedral(m);
  expect_done(m, remove_edge(m, 0, kEdgeAB), 6, vol, worst);
}

TEST(LongEdgeRemoval, AcceptsAWorseResultAboveTheFloor) {
  // A short edge through a wide ring: remove_edge finds nothing better, but
  // with a floor the 3-2 flip (which adds no edge) goes through.
  const VolumeMesh v = ring_around(3, 1.0, -0.3, 0.3);
  expect_edge_flip_declined(v, remove_edge, FlipOutcome::kNotBetter);
  TetMesh m = build(v);
  const double vol = total_volume(m);
  ASSERT_EQ(remove_long_edge(m, 0, kEdgeAB, -0.999), FlipOutcome::kDone);
  EXPECT_TRUE(m.check().ok()) << m.check().to_string();
  EXPECT_EQ(m.num_tets(), 2u);
  EXPECT_NEAR(total_volume(m), vol, 1e-12 * vol);
  for (Index t : m.last_created()) EXPECT_GT(tet_quality(m, m.tet(t)), -0.999);
}

TEST(LongEdgeRemoval, DeclinesBelowTheFloor) {
  // Nothing has a largest dihedral angle under 1e-3 degrees' cosine.
  TetMesh m = build(ring_around(3, 1.0, -0.3, 0.3));
  const VolumeMesh before = m.to_volume_mesh();
  expect_declined(m, remove_long_edge(m, 0, kEdgeAB, std::cos(1e-3)), FlipOutcome::kNotBetter, before);
}

TEST(LongEdgeRemoval, NeverCreatesAnEdgeAsLongAsTheRemovedOne) {
  // Four tets around a short edge: every triangulation of the square ring adds
  // a diagonal of length 2 > 0.6.
  TetMesh m = build(ring_around(4, 1.0, -0.3, 0.3));
  const VolumeMesh before = m.to_volume_mesh();
  expect_declined(m, remove_long_edge(m, 0, kEdgeAB, -0.999), FlipOutcome::kNotBetter, before);
  // Around a long edge (6 > 2) it goes through.
  TetMesh tall = build(ring_around(4, 1.0, -3, 3));
  ASSERT_EQ(remove_long_edge(tall, 0, kEdgeAB, -0.999), FlipOutcome::kDone);
  EXPECT_TRUE(tall.check().ok());
  EXPECT_EQ(fixtures::find_edge(tall, 0, 1).first, kNoIndex);
  EXPECT_EQ(remove_long_edge(tall, 0, kEdgeAB, std::nan("")), FlipOutcome::kNotApplicable);
}

TEST(FlipCriterion, QualityDependsOnTheVertexSetOnly) {
  const TetMesh m = build(fixtures::cube());
  const Tet& k = m.tet(0);
  // The 12 even permutations give the same positive tet, bit for bit.
  const double q = tet_quality(m, k);
  for (const auto& p : std::array<std::array<int, 4>, 12>{{{0, 1, 2, 3},
                                                           {0, 2, 3, 1},
                                                           {0, 3, 1, 2},
                                                           {1, 0, 3, 2},
                                                           {1, 2, 0, 3},
                                                           {1, 3, 2, 0},
                                                           {2, 0, 1, 3},
                                                           {2, 1, 3, 0},
                                                           {2, 3, 0, 1},
                                                           {3, 0, 2, 1},
                                                           {3, 1, 0, 2},
                                                           {3, 2, 1, 0}}})
    EXPECT_EQ(tet_quality(m, {k[p[0]], k[p[1]], k[p[2]], k[p[3]]}), q);
  // And it is the cosine of the largest dihedral angle.
  const double deg = dihedral_range(m.point(k[0]), m.point(k[1]), m.point(k[2]), m.point(k[3])).max;
  EXPECT_NEAR(std::acos(q) * 180.0 / 3.14159265358979323846, deg, 1e-9);
}

/// A criterion for the tests: MaxDihedral's scores, turned upside down when
/// `inverted` (the flattest tets win), and the last word `verdict`.
class TestCriterion final {
 public:
  TestCriterion(TetMesh& m, bool inverted, bool verdict) : m_(m), inverted_(inverted), verdict_(verdict) {}
  double bar(std::span<const Index> old) {
    double worst = std::numeric_limits<double>::infinity();
    for (Index t : old) worst = std::min(worst, score(m_.tet(t)));
    ++bars;
    return worst;
  }
  double score(const Tet& k) const { return inverted_ ? -tet_quality(m_, k) : tet_quality(m_, k); }
  bool accepts(std::span<const Tet> fresh) {
    accepted_size = fresh.size();
    return verdict_;
  }
  void done(std::span<const Index> created, std::span<const double>) { done_with = created.size(); }
  int bars = 0;
  std::size_t accepted_size = 0, done_with = 0;

 private:
  TetMesh& m_;
  bool inverted_, verdict_;
};
static_assert(Criterion<TestCriterion>);
static_assert(Criterion<MaxDihedral>);

TEST(FlipCriterion, Flip23TakesTheCriterionItIsGiven) {
  // The tall pair's 2-3 makes flatter tets: MaxDihedral declines it, a
  // criterion that prefers flat tets takes it.
  TetMesh m = build(tall_pair());
  TestCriterion flat(m, /*inverted=*/true, /*verdict=*/true);
  EXPECT_EQ(flip23(m, 0, 3, flat), Outcome::kDone);
  EXPECT_EQ(flat.bars, 1);
  EXPECT_EQ(flat.accepted_size, 3u);
  EXPECT_EQ(flat.done_with, 3u);
  EXPECT_EQ(m.num_tets(), 3u);
  EXPECT_TRUE(m.check().ok()) << m.check().to_string();
  EXPECT_NEAR(total_volume(m), total_volume(build(tall_pair())), 1e-12);
}

TEST(FlipCriterion, Flip23DeclinesWhenTheCriterionHasTheLastWordAgainst) {
  TetMesh m = build(flat_pair());
  TestCriterion refuses(m, /*inverted=*/false, /*verdict=*/false);
  expect_declined(m, flip23(m, 0, 3, refuses), Outcome::kNotBetter, flat_pair());
  EXPECT_EQ(refuses.accepted_size, 3u);  // asked only once the scores beat the bar
  EXPECT_EQ(refuses.done_with, 0u);
}

TEST(FlipCriterion, Flip23ChecksOrientationBeforeAskingTheCriterion) {
  TetMesh m = build(skew_pair());
  TestCriterion flat(m, /*inverted=*/true, /*verdict=*/true);
  expect_declined(m, flip23(m, 0, 3, flat), Outcome::kWouldInvert, skew_pair());
  EXPECT_EQ(flat.bars, 0);
}

TEST(FlipCriterion, EdgeRemovalKeepsToTheTriangulationsItMayUse) {
  // Five tets around a long edge: removable (EdgeRemoval above), unless every
  // triangulation is excluded.
  TetMesh m = build(ring_around(5, 1.0, -3, 3));
  MaxDihedral criterion(m);
  const auto none = [&m](const EdgeRing&, int, int, int) { return m.num_tets() > 0; };  // excludes every one
  expect_declined(m, remove_edge(m, 0, kEdgeAB, criterion, none), Outcome::kNotBetter, ring_around(5, 1.0, -3, 3));
  EXPECT_EQ(remove_edge(m, 0, kEdgeAB, criterion), Outcome::kDone);
  EXPECT_EQ(m.num_tets(), 6u);
  EXPECT_TRUE(m.check().ok());
  // MaxDihedral caches its scores: each new tet's cached quality is its tet_quality.
  for (Index t : m.last_created()) EXPECT_EQ(m.cached_quality(t), tet_quality(m, m.tet(t)));
}

TEST(FlipCriterion, EdgeRemovalTakesTheCriterionItIsGiven) {
  // Five tets around a short edge: MaxDihedral declines (EdgeRemoval above);
  // a criterion that prefers flat tets removes the edge.
  TetMesh m = build(ring_around(5, 1.0, -0.1, 0.1));
  TestCriterion flat(m, /*inverted=*/true, /*verdict=*/true);
  EXPECT_EQ(remove_edge(m, 0, kEdgeAB, flat), Outcome::kDone);
  EXPECT_EQ(flat.done_with, 6u);
  EXPECT_TRUE(m.check().ok()) << m.check().to_string();
}

}  // namespace
}  // namespace pdrmesh
