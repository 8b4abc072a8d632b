// SPDX-License-Identifier: AGPL-3.0-or-later
// PDR data decomposition: a uniform octree of depth d (2^d leaves per side) over
// the initial mesh's bounding cube. Every tet goes to the leaf holding its
// barycenter; each non-empty leaf knows its level-one and level-two neighbours
// (the paper's N1 and N2) and its interface faces (faces shared with a tet of
// another leaf).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <utility>
#include <vector>

#include "pdrmesh/status.hpp"
#include "pdrmesh/types.hpp"
#include "pdrmesh/volume_mesh.hpp"

namespace pdrmesh {

/// Grid id of a leaf: i + n * (j + n * k) with n = 2^depth, (i, j, k) its integer
/// coordinates along x, y, z.
using LeafId = std::uint32_t;

/// The deepest octree: n^3 = 2^30 leaf ids still fit a LeafId.
inline constexpr int kMaxDepth = 10;

struct Decomposition {
  /// The octree's root box, a cube: its side is the mesh bounding box's largest
  /// extent enlarged by a relative 1e-6 (and at least 1e-300), centred on the
  /// bounding box. Cubic leaves keep subdomains isotropic; the margin keeps every
  /// barycenter strictly inside, so the far faces need no special rule.
  Box box;
  int depth = 0;
  int per_side = 1;  ///< n = 2^depth
  std::vector<LeafId> leaves;                 ///< the non-empty leaves, ascending
  std::vector<std::vector<Index>> leaf_tets;  ///< per entry of `leaves`: its tets, ascending
  std::vector<Index> tet_leaf;                ///< per tet: index into `leaves`
  /// Per entry of `leaves`, ascending indices into `leaves`:
  /// n1 = the non-empty leaves L' != L whose closed boxes touch L's box (the
  ///      26-neighbourhood in the grid);
  /// n2 = the leaves in n1 of a member of n1, not L and not in n1 (the paper's
  ///      equation, with n1 as above). In a grid without empty leaves this is
  ///      the ring at Chebyshev distance 2; an empty leaf breaks chains, so a
  ///      leaf at distance 2 reached only through empty leaves is not in n2.
  ///      n1 ∪ n2 is exactly the set of leaves whose lock sets ({L} ∪ n1)
  ///      intersect L's (the scheduler's conflict graph).
  std::vector<std::vector<Index>> n1, n2;
  /// Per entry of `leaves`: (tet, local face) pairs, face f opposite vertex f,
  /// whose face-neighbour tet lies in another leaf; ascending. Mesh boundary
  /// faces (one tet) are never interface faces.
  std::vector<std::vector<std::pair<Index, int>>> interface_faces;

  std::size_t size() const { return leaves.size(); }
};

/// The leaf of the grid over `box` (any box, not only a cube) that holds p:
/// per axis c = floor((p - lo) / (hi - lo) * n) computed in doubles (a
/// measurement, not an orientation decision; deterministic), clamped to
/// [0, n - 1]. A point exactly on a boundary between two leaves (c integral)
/// therefore goes to the upper leaf. This formula *defines* "the leaf that
/// holds p" throughout pdrmesh.
LeafId leaf_of_point(const Box& box, int depth, const Vec3& p);

/// Integer coordinates (i, j, k) of a grid id.
std::array<std::uint32_t, 3> leaf_coords(LeafId id, int depth);

/// The closed box of grid leaf `id` (lo + c * width / n per axis).
Box leaf_box(const Box& box, int depth, LeafId id);

/// The barycenter of tet t, ((p0 + p1) + (p2 + p3)) / 4 in doubles.
Vec3 tet_barycenter(const VolumeMesh& mesh, Index t);

/// Builds the decomposition of `mesh` at `depth`. Errors: depth outside
/// [0, kMaxDepth]; a tet referring to a missing point; a face shared by more than
/// two tets. A mesh without tets gives zero leaves. Deterministic: depends only
/// on the mesh, not on the number of threads it runs on (oneTBB, fixed chunks).
Result<Decomposition> decompose(const VolumeMesh& mesh, int depth);

/// The same over a caller-given root box (any box; `box` is stored as is).
/// Barycenters outside it go to the nearest edge leaf (leaf_of_point clamps),
/// so a box shifted by half a leaf puts every interface of the unshifted
/// grid inside a leaf (the PDR interface round).
Result<Decomposition> decompose(const VolumeMesh& mesh, int depth, const Box& box);

/// The same without interface_faces (left empty) and without the check of
/// faces shared by more than two tets: the face sort is most of the cost, and
/// the PDR rounds, which build each leaf's hull themselves, need neither.
Result<Decomposition> decompose_leaves(const VolumeMesh& mesh, int depth, const Box& box);

/// Decomposition::n1 for the grid leaves `leaves` (ascending grid ids at
/// `depth`): per entry, the indices of the entries whose boxes touch it.
std::vector<std::vector<Index>> grid_n1(std::span<const LeafId> leaves, int depth);

/// The octree's root cube for a bounding box (Decomposition::box: what
/// decompose(mesh, depth) uses for the mesh's bounding box).
Box root_cube(const Box& bounding_box);

/// The octree depth for a mesh of `target_tets` (the initial mesh's tet count)
/// so that leaves hold about `tets_per_leaf` tets: the smallest d with
/// 8^d * tets_per_leaf >= target_tets, clamped to [0, kMaxDepth]. It counts all
/// 8^d leaves as occupied, so for a mesh filling a fraction f of its bounding
/// cube the non-empty leaves hold about tets_per_leaf / f tets each. The paper's
/// horn bulb (3.77M tets, depth 4) corresponds to tets_per_leaf ~ 1000.
/// tets_per_leaf == 0 is read as 1.
int default_depth(std::size_t target_tets, std::size_t tets_per_leaf);

/// The same with the leaves the body occupies: the smallest d with
/// occupied_leaves(d) * tets_per_leaf >= target_tets, where occupied_leaves(d)
/// estimates the non-empty leaves at depth d (at least 1; more than 8^d counts
/// as 8^d). A thin body then gets the depth its own extent needs (frame fills
/// 58 of the 512 leaves of depth 3).
int default_depth(std::size_t target_tets, std::size_t tets_per_leaf,
                  const std::function<std::size_t(int depth)>& occupied_leaves);

/// An estimate of the leaves a closed surface's body occupies at `depth` over
/// root_cube(surface bounds): the leaves holding a surface point, or the
/// enclosed volume in leaf volumes, whichever is more (a lower bound of the
/// leaves a tet barycenter reaches when the surface's triangles are smaller
/// than a leaf).
std::size_t occupied_leaves_estimate(std::span<const Vec3> surface_points, double enclosed_volume, int depth);

}  // namespace pdrmesh
