// SPDX-License-Identifier: AGPL-3.0-or-later
// Leaf tasks: byte round trips, rejection of corrupted or lying buffers and
// results, the native and TetGen leaf kernels, and the PDR fix-ups.
#include "pdrmesh/leaf_task.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cmath>
#include <cstring>

#include "octree_fixtures.hpp"
#include "pdr_fixtures.hpp"
#include "pdrmesh/decomposition.hpp"
#include "pdrmesh/leaf_kernels.hpp"
#include "pdrmesh/pdr.hpp"
#include "pdrmesh/validate.hpp"
#include "test_fixtures.hpp"

namespace pdrmesh {
namespace {

using fixtures::barycenter_hook;
using fixtures::uniform_sizing;

/// The hull of a whole Kuhn grid as its boundary (id 1), so that the grid
/// itself is a leaf with only geometry faces frozen.
LeafTaskInput whole_grid_input(int k) {
  const VolumeMesh g = fixtures::kuhn_grid(k);
  std::vector<Tri> none;
  std::vector<int> no_ids;
  LeafTaskInput in = build_leaf_input(7, g.points, g.tets, FaceIdTable(none, no_ids));
  for (int& id : in.frozen_ids) id = 1;
  return in;
}

VolumeMesh as_volume(const LeafTaskInput& in, const LeafTaskOutput& out) {
  VolumeMesh v;
  v.points = in.points;
  v.points.insert(v.points.end(), out.new_points.begin(), out.new_points.end());
  v.tets = out.tets;
  // Drop input points the result no longer uses (TetGen drops interior ones).
  std::vector<Index> map(v.points.size(), kNoIndex);
  for (const Tet& t : v.tets)
    for (Index p : t) map[p] = 0;
  std::vector<Vec3> kept;
  for (std::size_t i = 0; i < map.size(); ++i)
    if (map[i] == 0) {
      map[i] = static_cast<Index>(kept.size());
      kept.push_back(v.points[i]);
    }
  v.points = kept;
  for (Tet& t : v.tets)
    for (Index& p : t) p = map[p];
  return v;
}

double volume_of(const VolumeMesh& m) {
  double s = 0;
  for (const Tet& t : m.tets) s += signed_volume(m.points[t[0]], m.points[t[1]], m.points[t[2]], m.points[t[3]]);
  return s;
}

// A leaf input numbers its points in ascending global order, whatever the
// order of the tets' corners: global ids spread over three bytes and
// scrambled, then every tet read back through point_ids.
TEST(LeafInput, NumbersPointsInAscendingGlobalOrder) {
  const VolumeMesh g = fixtures::kuhn_grid(4);
  constexpr Index kPrime = 100003;  // ids i -> i * 7919 mod kPrime: a permutation
  std::vector<Vec3> points(kPrime);
  std::vector<Tet> tets = g.tets;
  for (Tet& t : tets)
    for (Index& v : t) v = static_cast<Index>((std::uint64_t{v} * 7919) % kPrime);
  for (Index v = 0; v < g.points.size(); ++v) points[(std::uint64_t{v} * 7919) % kPrime] = g.points[v];
  const LeafTaskInput in = build_leaf_input(0, points, tets, FaceIdTable());
  ASSERT_EQ(in.point_ids.size(), g.points.size());
  EXPECT_TRUE(std::is_sorted(in.point_ids.begin(), in.point_ids.end()));
  EXPECT_GT(in.point_ids.back(), Index{65536});  // three radix bytes
  ASSERT_EQ(in.tets.size(), tets.size());
  for (std::size_t t = 0; t < tets.size(); ++t)
    for (int c = 0; c < 4; ++c) ASSERT_EQ(in.point_ids[in.tets[t][c]], tets[t][c]) << "tet " << t << " corner " << c;
  for (std::size_t i = 0; i < in.points.size(); ++i) EXPECT_EQ(in.points[i], points[in.point_ids[i]]);
}

TEST(LeafTask, InputRoundTripsExactly) {
  LeafTaskInput in = whole_grid_input(2);
  in.points[3][0] = 0.1;  // a coordinate that is not a small integer
  in.point_ids[5] = (GlobalId{1} << 40) + 3;
  in.frozen_ids[0] = -2;
  const std::string bytes = in.encode();
  Result<LeafTaskInput> back = LeafTaskInput::decode(bytes);
  ASSERT_TRUE(back.ok()) << back.status().to_string();
  EXPECT_EQ(back->leaf, in.leaf);
  EXPECT_EQ(back->point_ids, in.point_ids);
  EXPECT_EQ(back->points, in.points);
  EXPECT_EQ(back->tets, in.tets);
  EXPECT_EQ(back->frozen_faces, in.frozen_faces);
  EXPECT_EQ(back->frozen_ids, in.frozen_ids);
  EXPECT_EQ(back->encode(), bytes);
  EXPECT_EQ(in.frozen_faces.size(), 6u * 4 * 2);  // 6 sides of 2x2 squares, 2 triangles each
  EXPECT_FALSE(back->core.has_value());

  // A buffered round's task carries its leaf's box; an empty or non-finite
  // one does not decode.
  in.core = Box{{0.25, 0, 0}, {1, 1.5, 2}};
  const std::string with_core = in.encode();
  back = LeafTaskInput::decode(with_core);
  ASSERT_TRUE(back.ok()) << back.status().to_string();
  ASSERT_TRUE(back->core.has_value());
  EXPECT_EQ(back->core->lo, in.core->lo);
  EXPECT_EQ(back->core->hi, in.core->hi);
  EXPECT_EQ(back->encode(), with_core);
  in.core = Box{{1, 0, 0}, {0.5, 1, 1}};
  EXPECT_EQ(LeafTaskInput::decode(in.encode()).status().code(), StatusCode::kInvalidInput);
  in.core = Box{{0, 0, 0}, {std::numeric_limits<double>::infinity(), 1, 1}};
  EXPECT_EQ(LeafTaskInput::decode(in.encode()).status().code(), StatusCode::kInvalidInput);

  // Sizes travel bit for bit, one per point or none; a miscounted, zero or
  // non-finite one does not decode.
  in.core.reset();
  for (std::size_t i = 0; i < in.points.size(); ++i) in.sizes.push_back(0.1 + 1.0 / static_cast<double>(i + 3));
  back = LeafTaskInput::decode(in.encode());
  ASSERT_TRUE(back.ok()) << back.status().to_string();
  EXPECT_EQ(back->sizes, in.sizes);
  in.sizes[4] = 0;
  EXPECT_EQ(LeafTaskInput::decode(in.encode()).status().code(), StatusCode::kInvalidInput);
  in.sizes[4] = std::nan("");
  EXPECT_EQ(LeafTaskInput::decode(in.encode()).status().code(), StatusCode::kInvalidInput);
  in.sizes.pop_back();
  EXPECT_EQ(LeafTaskInput::decode(in.encode()).status().code(), StatusCode::kInvalidInput);

  // A seed round's points travel bit for bit; a non-finite one does not decode.
  in.sizes.clear();
  in.seeds = {{0.3, 0.7, 1.1}, {1.0 / 3.0, 0.5, 0.25}};
  back = LeafTaskInput::decode(in.encode());
  ASSERT_TRUE(back.ok()) << back.status().to_string();
  EXPECT_EQ(back->seeds, in.seeds);
  in.seeds[1][2] = std::numeric_limits<double>::infinity();
  EXPECT_EQ(LeafTaskInput::decode(in.encode()).status().code(), StatusCode::kInvalidInput);
}

TEST(LeafTask, ASeedTaskInsertsItsSeedsAndRefinesNothing) {
  LeafTaskInput in = whole_grid_input(2);  // a 2x2x2 grid of unit cubes, its hull frozen
  const SizingField h = uniform_sizing(0.05);  // the refiner would add thousands of points
  in.seeds = {{0.3, 0.6, 0.2}, {1.7, 0.4, 0.3}, {0.4, 1.6, 1.2}, {1.25, 1.5, 1.75}, {5, 5, 5}};
  for (const Vec3& p : in.points) in.sizes.push_back(h.at(p));
  const auto kernel = make_leaf_kernel("native").value();
  Result<LeafTaskOutput> out = run_leaf_kernel(*kernel, in, h);
  ASSERT_TRUE(out.ok()) << out.status().to_string();
  EXPECT_TRUE(validate_leaf_output(in, *out).ok());
  // The four seeds inside, not the one outside every tet; no refinement point.
  std::vector<Vec3> made = out->new_points, inside(in.seeds.begin(), in.seeds.begin() + 4);
  std::sort(made.begin(), made.end());
  std::sort(inside.begin(), inside.end());
  EXPECT_EQ(made, inside);
  EXPECT_EQ(out->new_sizes.size(), 4u);
  // The same task without seeds refines.
  in.seeds.clear();
  out = run_leaf_kernel(*kernel, in, h);
  ASSERT_TRUE(out.ok()) << out.status().to_string();
  EXPECT_GT(out->new_points.size(), 100u);
}

TEST(LeafTask, OutputRoundTripsExactly) {
  LeafTaskOutput out;
  out.leaf = 3;
  out.input_points = 4;
  out.new_points = {{0.25, 1.0 / 3.0, -7.5}};
  out.tets = {{0, 1, 2, 4}, {4, 1, 2, 3}};
  const std::string bytes = out.encode();
  Result<LeafTaskOutput> back = LeafTaskOutput::decode(bytes);
  ASSERT_TRUE(back.ok()) << back.status().to_string();
  EXPECT_EQ(back->leaf, 3u);
  EXPECT_EQ(back->input_points, 4u);
  EXPECT_EQ(back->new_points, out.new_points);
  EXPECT_EQ(back->tets, out.tets);
  EXPECT_EQ(out.encoded_size(), bytes.size());
  out.moved = {1};
  out.moved_to = {{0.5, 0.5, 0.5}};
  EXPECT_EQ(out.encoded_size(), out.encode().size());
  out.new_sizes = {0.3};
  EXPECT_EQ(out.encoded_size(), out.encode().size());
  back = LeafTaskOutput::decode(out.encode());
  ASSERT_TRUE(back.ok()) << back.status().to_string();
  EXPECT_EQ(back->new_sizes, out.new_sizes);
  out.new_sizes = {-1};
  EXPECT_EQ(LeafTaskOutput::decode(out.encode()).status().code(), StatusCode::kInvalidInput);
}

/// Overwrites the little-endian u64 at `pos`.
void put_u64(std::string& b, std::size_t pos, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) b[pos + static_cast<std::size_t>(i)] = static_cast<char>((v >> (8 * i)) & 0xff);
}

TEST(LeafTask, RejectsCorruptedAndLyingInputs) {
  const std::string good = whole_grid_input(1).encode();
  // Every truncation fails.
  for (std::size_t n = 0; n < good.size(); ++n) EXPECT_FALSE(LeafTaskInput::decode(good.substr(0, n)).ok()) << n;
  EXPECT_FALSE(LeafTaskInput::decode(good + "x").ok());  // trailing byte
  // The point count (after magic 8, version 4, leaf 4) lies.
  std::string b = good;
  put_u64(b, 16, std::uint64_t{1} << 60);
  EXPECT_FALSE(LeafTaskInput::decode(b).ok());
  b = good;
  put_u64(b, 16, 7);  // fewer points than the data holds: the rest is misread
  EXPECT_FALSE(LeafTaskInput::decode(b).ok());
  // A non-finite coordinate.
  b = good;
  const double nan = std::nan("");
  std::uint64_t bits = 0;
  std::memcpy(&bits, &nan, 8);
  put_u64(b, 24 + 8, bits);
  EXPECT_FALSE(LeafTaskInput::decode(b).ok());
  // A tet index out of range: the first tet starts after 8 points of 32 bytes.
  b = good;
  const std::size_t tets_at = 24 + 8 * 32 + 8;
  b[tets_at] = static_cast<char>(100);
  Result<LeafTaskInput> r = LeafTaskInput::decode(b);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("tet 0"), std::string::npos) << r.status().message();
  // Bad magic.
  b = good;
  b[0] = 'X';
  EXPECT_FALSE(LeafTaskInput::decode(b).ok());
}

TEST(LeafTask, RejectsCorruptedOutputs) {
  LeafTaskOutput out;
  out.input_points = 4;
  out.new_points = {{0.25, 0.25, 0.25}};
  out.tets = {{0, 1, 2, 4}};
  const std::string good = out.encode();
  for (std::size_t n = 0; n < good.size(); ++n) EXPECT_FALSE(LeafTaskOutput::decode(good.substr(0, n)).ok()) << n;
  std::string b = good;
  put_u64(b, 20, std::uint64_t{1} << 62);  // new point count
  EXPECT_FALSE(LeafTaskOutput::decode(b).ok());
  b = good;
  b[20 + 8 + 24 + 8] = 5;  // tet 0, reference 0 -> 5 (of 5)
  EXPECT_FALSE(LeafTaskOutput::decode(b).ok());
}

TEST(LeafTask, CoordinatorRejectsLyingResults) {
  const LeafTaskInput in = whole_grid_input(1);  // the unit cube, 6 Kuhn tets
  LeafTaskOutput honest;
  honest.leaf = in.leaf;
  honest.input_points = static_cast<std::uint32_t>(in.points.size());
  honest.tets = in.tets;
  ASSERT_TRUE(validate_leaf_output(in, honest).ok()) << validate_leaf_output(in, honest).to_string();

  LeafTaskOutput r = honest;
  r.leaf = 1;
  EXPECT_FALSE(validate_leaf_output(in, r).ok());
  r = honest;
  r.input_points += 1;
  EXPECT_FALSE(validate_leaf_output(in, r).ok());
  r = honest;
  r.tets.pop_back();  // a frozen face disappears, new hull faces appear
  EXPECT_NE(validate_leaf_output(in, r).message().find("hull"), std::string::npos);
  r = honest;
  std::swap(r.tets[0][0], r.tets[0][1]);  // inverted tet
  EXPECT_NE(validate_leaf_output(in, r).message().find("positively"), std::string::npos);
  r = honest;
  r.new_points.push_back({0.5, 0.5, 0.5});  // unused new point
  EXPECT_NE(validate_leaf_output(in, r).message().find("used by no tet"), std::string::npos);
  r = honest;
  r.tets.push_back(r.tets[0]);  // a tet twice: faces shared thrice or same orientation
  EXPECT_FALSE(validate_leaf_output(in, r).ok());
  // A split of a frozen hull face (1 -> 3 on the face z = 0) is caught too.
  r = honest;
  const Vec3 on_face = {0.6, 0.3, 0.0};
  r.new_points.push_back(on_face);
  const Index p = r.input_points;
  // Tet {0, 1, 3, 7} has the hull face (0, 3, 1) on z = 0: split it into three.
  ASSERT_EQ(r.tets[0], (Tet{0, 1, 3, 7}));
  r.tets[0] = {0, 1, p, 7};
  r.tets.push_back({1, 3, p, 7});
  r.tets.push_back({3, 0, p, 7});
  EXPECT_NE(validate_leaf_output(in, r).message().find("hull"), std::string::npos);
}

TEST(NativeLeafKernel, RefinesInsideTheFrozenHull) {
  const LeafTaskInput in = whole_grid_input(2);
  const SizingField h = uniform_sizing(0.5);
  const NativeLeafKernel kernel(barycenter_hook(40));
  Result<std::string> bytes = run_leaf_task(kernel, in.encode(), h);
  ASSERT_TRUE(bytes.ok()) << bytes.status().to_string();
  Result<LeafTaskOutput> out = LeafTaskOutput::decode(*bytes);
  ASSERT_TRUE(out.ok()) << out.status().to_string();
  ASSERT_TRUE(validate_leaf_output(in, *out).ok()) << validate_leaf_output(in, *out).to_string();
  EXPECT_EQ(out->new_points.size(), 40u);
  EXPECT_EQ(out->tets.size(), in.tets.size() + 3 * 40);
  const VolumeMesh v = as_volume(in, *out);
  const ValidationReport rep = validate_mesh(v);
  EXPECT_TRUE(rep.ok()) << format_validation(rep);
  EXPECT_NEAR(volume_of(v), 8.0, 1e-12);
}

// The native kernel given its points' sizes makes the same tets and points as
// without them (they are the values it would compute), and hands back the
// sizing field's own value at every new point.
TEST(NativeLeafKernel, GivenSizesChangeNothingAndNewPointsComeWithTheirs) {
  LeafTaskInput in = whole_grid_input(3);
  const SizingField field = uniform_sizing(0.6);
  const SizingField* h = &field;
  Result<std::unique_ptr<LeafKernel>> kernel = make_leaf_kernel("native");
  ASSERT_TRUE(kernel.ok());
  Result<LeafTaskOutput> plain = run_leaf_kernel(**kernel, in, *h);
  ASSERT_TRUE(plain.ok()) << plain.status().to_string();
  for (const Vec3& p : in.points) in.sizes.push_back(h->at(p));
  Result<LeafTaskOutput> sized = run_leaf_kernel(**kernel, in, *h);
  ASSERT_TRUE(sized.ok()) << sized.status().to_string();
  ASSERT_GT(sized->new_points.size(), 0u);
  EXPECT_EQ(sized->new_points, plain->new_points);
  EXPECT_EQ(sized->tets, plain->tets);
  ASSERT_EQ(sized->new_sizes.size(), sized->new_points.size());
  for (std::size_t i = 0; i < sized->new_points.size(); ++i) EXPECT_EQ(sized->new_sizes[i], h->at(sized->new_points[i]));
  EXPECT_TRUE(validate_leaf_output(in, *sized).ok()) << validate_leaf_output(in, *sized).to_string();
  const ValidationReport rep = validate_mesh(as_volume(in, *sized));
  EXPECT_TRUE(rep.ok()) << format_validation(rep);
  LeafTaskOutput lying = *sized;
  lying.new_sizes.pop_back();
  EXPECT_NE(validate_leaf_output(in, lying).message().find("sizes"), std::string::npos);
  lying.new_sizes = sized->new_sizes;
  lying.new_sizes[0] = 0;
  EXPECT_NE(validate_leaf_output(in, lying).message().find("size"), std::string::npos);
}

TEST(LeafTask, MovedInteriorPointsRoundTripAndAreChecked) {
  const LeafTaskInput in = whole_grid_input(2);  // 27 points, the centre (1, 1, 1) the only interior one
  Index centre = kNoIndex;
  for (Index v = 0; v < in.points.size(); ++v)
    if (in.points[v] == Vec3{1, 1, 1}) centre = v;
  ASSERT_NE(centre, kNoIndex);
  LeafTaskOutput out;
  out.leaf = in.leaf;
  out.input_points = static_cast<std::uint32_t>(in.points.size());
  out.tets = in.tets;
  out.moved = {centre};
  out.moved_to = {{1.1, 0.95, 1.05}};
  Result<LeafTaskOutput> back = LeafTaskOutput::decode(out.encode());
  ASSERT_TRUE(back.ok()) << back.status().to_string();
  EXPECT_EQ(back->moved, out.moved);
  EXPECT_EQ(back->moved_to, out.moved_to);
  EXPECT_TRUE(validate_leaf_output(in, out).ok()) << validate_leaf_output(in, out).to_string();
  LeafTaskOutput r = out;
  r.moved_to = {{2.5, 1, 1}};  // out of the cube: the tets on the face x = 2 invert
  EXPECT_NE(validate_leaf_output(in, r).message().find("positively"), std::string::npos);
  r = out;
  r.moved = {in.frozen_faces[0][0]};  // a hull point may not move
  EXPECT_NE(validate_leaf_output(in, r).message().find("hull point"), std::string::npos);
  r = out;
  r.moved_to.clear();
  EXPECT_FALSE(validate_leaf_output(in, r).ok());
}

TEST(NativeLeafKernel, ReportsHookErrorsWithTheLeaf) {
  const NativeLeafKernel kernel([](TetMesh&, const SizingField&, const std::optional<Box>&) { return internal_error("boom"); });
  Result<LeafTaskOutput> r = kernel.run(whole_grid_input(1), uniform_sizing(1));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("leaf 7"), std::string::npos);
}

TEST(TetgenLeafKernel, FillsAKuhnGridLeaf) {
  // Leaf 0 of a 4^3 Kuhn grid at depth 1 is the cube [0, 2]^3; its hull has
  // interface faces on x = 2, y = 2, z = 2 and geometry faces elsewhere.
  VolumeMesh g = fixtures::kuhn_grid(4);
  Result<Decomposition> d = decompose(g, 1);
  ASSERT_TRUE(d.ok());
  ASSERT_EQ(d->leaves.size(), 8u);
  std::vector<Tet> tets;
  for (Index t : d->leaf_tets[0]) tets.push_back(g.tets[t]);
  std::vector<Tri> hull;
  {
    // The geometry boundary: the whole grid's hull, id 1.
    const LeafTaskInput all = build_leaf_input(0, g.points, g.tets, FaceIdTable());
    for (const Tri& f : all.frozen_faces) hull.push_back({Index(all.point_ids[f[0]]), Index(all.point_ids[f[1]]),
                                                          Index(all.point_ids[f[2]])});
  }
  const std::vector<int> ids(hull.size(), 1);
  const LeafTaskInput in = build_leaf_input(0, g.points, tets, FaceIdTable(hull, ids));
  std::size_t interface = 0;
  for (int id : in.frozen_ids) interface += id == 0 ? 1 : 0;
  EXPECT_EQ(interface, 3u * 4 * 2);  // three 2x2 sides of two triangles
  EXPECT_EQ(in.frozen_faces.size(), 6u * 4 * 2);

  const TetgenLeafKernel kernel;
  const SizingField h = uniform_sizing(0.4);
  Result<LeafTaskOutput> out = kernel.run(in, h);
  ASSERT_TRUE(out.ok()) << out.status().to_string();
  ASSERT_TRUE(validate_leaf_output(in, *out).ok()) << validate_leaf_output(in, *out).to_string();
  EXPECT_GT(out->new_points.size(), 20u);
  const VolumeMesh v = as_volume(in, *out);
  const ValidationReport rep = validate_mesh(v);
  EXPECT_TRUE(rep.ok()) << format_validation(rep);
  EXPECT_NEAR(volume_of(v), 8.0, 1e-9);
  // TetGen respects the volume bound up to its documented best effort.
  std::size_t over = 0;
  for (const Tet& t : v.tets)
    over += signed_volume(v.points[t[0]], v.points[t[1]], v.points[t[2]], v.points[t[3]]) >
                    2 * regular_tet_volume(0.4) ? 1 : 0;
  EXPECT_LT(over, v.tets.size() / 5);
}

/// Cube (x, y, z) of a 4^3 Kuhn grid, local tet i.
Index kuhn_tet(int x, int y, int z, int i) { return static_cast<Index>(6 * (x + 4 * (y + 4 * z)) + i); }

void move_tet(Decomposition& d, Index t, Index to) {
  auto& from = d.leaf_tets[d.tet_leaf[t]];
  from.erase(std::find(from.begin(), from.end(), t));
  d.leaf_tets[to].insert(std::lower_bound(d.leaf_tets[to].begin(), d.leaf_tets[to].end(), t), t);
  d.tet_leaf[t] = to;
}

/// Every leaf's tets form a mesh whose hull is a closed 2-manifold.
void expect_manifold_leaves(const VolumeMesh& g, const Decomposition& d) {
  for (Index l = 0; l < d.size(); ++l) {
    std::vector<Tet> tets;
    for (Index t : d.leaf_tets[l]) tets.push_back(g.tets[t]);
    const LeafTaskInput in = build_leaf_input(l, g.points, tets, FaceIdTable());
    VolumeMesh v;
    v.points = in.points;
    v.tets = in.tets;
    const ValidationReport rep = validate_mesh(v);
    EXPECT_TRUE(rep.ok()) << "leaf " << l << "\n" << format_validation(rep);
  }
}

TEST(PdrFixups, PartitionSwapMovesAVertexConnectedTet) {
  const VolumeMesh g = fixtures::kuhn_grid(4);
  Result<Decomposition> d = decompose(g, 1);
  ASSERT_TRUE(d.ok());
  ASSERT_TRUE(leaves_needing_fixups(g, *d).empty());
  // A tet of cube (2, 2, 2) touches leaf 0 = [0, 2]^3 only at the point (2, 2, 2).
  const Index t = kuhn_tet(2, 2, 2, 3);
  ASSERT_NE(d->tet_leaf[t], 0u);
  move_tet(*d, t, 0);
  EXPECT_EQ(leaves_needing_fixups(g, *d), std::vector<Index>{0});

  const FixupStats s = apply_fixups(g, *d, 10);
  EXPECT_EQ(s.swaps, 1u);
  EXPECT_EQ(s.moves, 0u);
  EXPECT_EQ(s.unresolved, 0u);
  EXPECT_NE(d->tet_leaf[t], 0u);
  EXPECT_TRUE(leaves_needing_fixups(g, *d).empty());
  expect_manifold_leaves(g, *d);
}

TEST(PdrFixups, BoundaryExtractionMendsANonManifoldEdge) {
  const VolumeMesh g = fixtures::kuhn_grid(4);
  Result<Decomposition> d = decompose(g, 1);
  ASSERT_TRUE(d.ok());
  // Around the diagonal (1,1,1)-(2,2,2) of cube (1, 1, 1) the six tets form the
  // ring 0, 1, 4, 5, 3, 2. Tet 0 has a face on x = 2 (leaf 1), tet 5 one on
  // z = 2 (leaf 4): reassigning them there (each face-connected in its new
  // leaf) splits leaf 0's tets around the diagonal into two sectors.
  move_tet(*d, kuhn_tet(1, 1, 1, 0), 1);
  move_tet(*d, kuhn_tet(1, 1, 1, 5), 4);
  EXPECT_EQ(leaves_needing_fixups(g, *d), std::vector<Index>{0});

  const FixupStats s = apply_fixups(g, *d, 10);
  EXPECT_EQ(s.swaps, 0u);
  EXPECT_EQ(s.moves, 1u);
  EXPECT_EQ(s.unresolved, 0u);
  EXPECT_TRUE(leaves_needing_fixups(g, *d).empty());
  expect_manifold_leaves(g, *d);
}

}  // namespace
}  // namespace pdrmesh
