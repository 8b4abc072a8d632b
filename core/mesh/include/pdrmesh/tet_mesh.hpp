// SPDX-License-Identifier: AGPL-3.0-or-later
// The refiner's own tetrahedral mesh: compact per-slot arrays (vertices with
// packed face adjacency, per-tet flags (alive, active, frozen faces)) and a free list, built
// for local operations (flips.hpp, insert.hpp). Converts to and from VolumeMesh.
//
// Local numbering of vertices, faces and edges: topology.hpp.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "pdrmesh/status.hpp"
#include "pdrmesh/types.hpp"
#include "pdrmesh/volume_mesh.hpp"

namespace pdrmesh {

/// Packed face adjacency: neighbour tet u and its local face g in one integer,
/// 4*u + g. kNoIndex stands for "no neighbour" (a hull face). Tet indices stay
/// below kMaxTets so that no packed value equals kNoIndex.
constexpr Index pack_face(Index t, int f) { return 4 * t + static_cast<Index>(f); }
constexpr Index face_tet(Index packed) { return packed >> 2; }
constexpr int face_local(Index packed) { return static_cast<int>(packed & 3u); }
inline constexpr Index kMaxTets = kNoIndex >> 2;

/// The tets around one edge (a, b), in order. Closed ring: tets[i] has the
/// vertices {a, b, ring[i], ring[(i+1) % size]} and
/// orient3d(a, b, ring[i], ring[i+1]) > 0; tets[i] and tets[i+1] share the face
/// (a, b, ring[i+1]). Open ring (the edge is on the hull): the same with
/// size + 1 ring vertices, tets[0] and tets[size-1] each having a hull face on
/// the edge.
struct EdgeRing {
  static constexpr int kMax = 64;  ///< longest ring edge_ring() collects
  Index a = kNoIndex;
  Index b = kNoIndex;
  int size = 0;
  bool closed = false;
  // Only the first size (closed) or size + 1 (open) entries are set; the rest
  // stay uninitialised, so that a ring on the stack costs nothing to declare.
  std::array<Index, kMax> tets;
  std::array<Index, kMax + 1> ring;
};

class TetMesh {
 public:
  /// Per-tet flag word, bit by bit:
  ///   bit 0      kAlive:  the slot holds a tet (clear: dead, on the free list)
  ///   bit 1      kActive: the tet still needs refinement; set on every tet an
  ///                       operation creates, cleared by the refinement passes
  ///   bits 2..5  frozen face 0..3 (frozen_bit(f)): the face may not be split,
  ///              flipped or crossed by an operation, nor may any edge on it be
  ///              removed; kept equal on both sides of an interior face
  ///   bit 6      kMark:   scratch bit, set only inside one operation
  ///   bits 7..15 reserved, zero
  using Flags = std::uint16_t;
  static constexpr Flags kAlive = 1u << 0;
  static constexpr Flags kActive = 1u << 1;
  static constexpr Flags kMark = 1u << 6;
  static constexpr Flags frozen_bit(int f) { return static_cast<Flags>(1u << (2 + f)); }
  static constexpr Flags kFrozenMask = 0xFu << 2;

  TetMesh() = default;

  /// Builds the mesh and its adjacency (by sorting face keys: deterministic).
  /// Point i gets the global id i and new points get n, n+1, ...
  static Result<TetMesh> from_volume_mesh(const VolumeMesh& mesh);
  /// Same with caller-given global ids (one per point) and the first id to give
  /// new points; the caller guarantees that [next_id, ...) is unused.
  /// Every tet must be positive (exact) and every face shared by at most two
  /// tets; every `boundary` triangle must be a face of the mesh, and is frozen.
  static Result<TetMesh> from_volume_mesh(const VolumeMesh& mesh, std::vector<GlobalId> point_ids,
                                          GlobalId next_id);

  /// Alive tets in slot order (call compact() first to know their indices),
  /// with their regions, and the boundary triangles and ids as given.
  VolumeMesh to_volume_mesh() const;

  // ---- points
  Index num_points() const { return static_cast<Index>(points_.size()); }
  const Vec3& point(Index v) const { return points_[v]; }
  GlobalId point_id(Index v) const { return ids_[v]; }
  const std::vector<Vec3>& points() const { return points_; }
  const std::vector<GlobalId>& point_ids() const { return ids_; }
  GlobalId next_id() const { return next_id_; }
  /// Appends a point with the next global id; returns its index.
  Index add_point(const Vec3& p);
  /// Moves point v to p (smoothing). The caller keeps every tet around v
  /// positive (exact::orient3d) and calls invalidate_quality on each of them.
  void set_point(Index v, const Vec3& p) { points_[v] = p; }
  /// Drops the points from index `first` on that no alive tet uses (the
  /// optimizer's point removal leaves them behind), keeping the order and the
  /// global ids of the others; the tets and boundary triangles are renumbered
  /// (a dead slot's stale vertices are not). Returns old index -> new index
  /// (kNoIndex for a dropped point).
  std::vector<Index> remove_unused_points(Index first = 0);

  // ---- tets
  /// Number of slots, alive or dead; tet indices run below this.
  Index num_slots() const { return static_cast<Index>(cells_.size()); }
  Index num_tets() const { return alive_count_; }
  const Tet& tet(Index t) const { return cells_[t].v; }
  Flags flags(Index t) const { return flags_[t]; }
  bool alive(Index t) const { return (flags_[t] & kAlive) != 0; }
  bool active(Index t) const { return (flags_[t] & kActive) != 0; }
  bool frozen(Index t, int f) const { return (flags_[t] & frozen_bit(f)) != 0; }
  /// Packed neighbour across face f (pack_face), or kNoIndex.
  Index neighbour(Index t, int f) const { return cells_[t].adj[f]; }
  /// Asks the cache for tet t's vertices, neighbours and flags ahead of a
  /// walk's visit (a hint only: no effect on results).
  void prefetch(Index t) const {
    __builtin_prefetch(&cells_[t]);
    __builtin_prefetch(&flags_[t]);
  }
  /// Region of tet t (0 when the input had none).
  int region(Index t) const { return regions_.empty() ? 0 : regions_[t]; }
  const std::vector<Tri>& boundary() const { return boundary_; }
  const std::vector<int>& boundary_ids() const { return boundary_ids_; }

  /// Cached flip criterion of tet t (flips.hpp's tet_quality), NaN until a flip
  /// computes it. Reset whenever a slot receives a new tet; whoever moves a
  /// point must reset the tets around it (invalidate_quality).
  double cached_quality(Index t) const { return quality_[t]; }
  void set_cached_quality(Index t, double q) { quality_[t] = q; }
  void invalidate_quality(Index t);

  void set_active(Index t, bool on);
  /// Freezes or thaws face f of t and the same face seen from its neighbour.
  void set_frozen(Index t, int f, bool on);

  /// Collects the tets around edge e of tet t. False when the ring holds more
  /// than max_size (at most EdgeRing::kMax) tets (r is then unusable); a small
  /// max_size stops the walk early.
  bool edge_ring(Index t, int e, EdgeRing& r, int max_size = EdgeRing::kMax) const;

  // ---- low-level rewriting, for local operations (flips.cpp, insert.cpp)
  /// Replaces the tets `old_tets` (a connected cavity) by `new_tets`, which must
  /// fill exactly the same region: every face of a new tet is an outer face of
  /// the cavity, a face of another new tet, or a piece of an unfrozen hull face
  /// of the cavity that the operation subdivides (it stays on the hull, unfrozen).
  /// Faces inside the cavity must not be frozen. New tets are alive and active,
  /// inherit the region of old_tets[parent[j]] and the frozen marks of the outer
  /// faces they take over. The old slots are freed and reused first (see
  /// free-list policy below). Allocation-free once the scratch buffers have grown.
  void replace_cavity(std::span<const Index> old_tets, std::span<const Tet> new_tets,
                      std::span<const Index> parent);
  /// A face of a cavity's boundary for replace_star: its points as seen from
  /// outside the cavity (face_of of the cavity tet `parent` that holds it),
  /// the tet across it (packed, or kNoIndex on the hull) and its frozen mark.
  struct StarFace {
    Tri points;
    Index neighbour;
    Index parent;  ///< index into old_tets
    bool frozen;
  };
  /// replace_cavity for a cavity that is star-shaped from `apex` (every
  /// boundary face seen strictly from it, as a Bowyer-Watson insertion makes
  /// it): new tet j is (points[0], points[2], points[1], apex) over faces[j],
  /// which it takes over as its face 3. The same tets, slots, adjacency, marks
  /// and regions as replace_cavity with those tets, faster: the new tets' other
  /// faces pair by the boundary edge they hold, each edge shared by two faces.
  void replace_star(std::span<const Index> old_tets, Index apex, std::span<const StarFace> faces);
  /// Tet indices created by the last replace_cavity or replace_star, in new_tets order.
  std::span<const Index> last_created() const { return created_; }

  /// Free-list policy: LIFO. Freed slots are pushed in reverse cavity order, so
  /// the j-th new tet of an operation takes the slot of the j-th old tet; tets
  /// beyond the old count take older free slots, then new slots at the end.
  /// Deterministic for a deterministic sequence of operations.
  ///
  /// Moves the alive tets to the front keeping their order and empties the free
  /// list. Returns old index -> new index (kNoIndex for dead slots).
  std::vector<Index> compact();
  /// Moves the alive tets to slots 0, 1, ... in the order `order` (every alive
  /// tet exactly once) and empties the free list; returns old index -> new
  /// index (kNoIndex for dead slots). The refiner puts tets in a spatial order
  /// with it so that neighbouring tets share cache lines.
  std::vector<Index> reorder(std::span<const Index> order);

  /// Full validity check, for tests and debug builds: flags, free list,
  /// adjacency symmetric and on matching faces, frozen marks equal on both
  /// sides, every alive tet positive by exact::orient3d, every boundary
  /// triangle a frozen face. The first problem found, with tet and points.
  Status check() const;

 private:
  Index allocate_tet();
  void free_tet(Index t);

  std::vector<Vec3> points_;
  std::vector<GlobalId> ids_;
  GlobalId next_id_ = 0;

  /// A tet's vertices and its packed face neighbours side by side, in one
  /// 32-byte block (half a cache line): the walks read both for each tet.
  struct alignas(32) Cell {
    Tet v;
    std::array<Index, 4> adj;
  };
  std::vector<Cell> cells_;
  std::vector<Flags> flags_;
  std::vector<int> regions_;     ///< empty, or one per slot
  std::vector<double> quality_;  ///< one per slot, NaN when not computed
  std::vector<Index> free_;      ///< dead slots, used as a stack
  Index alive_count_ = 0;

  std::vector<Tri> boundary_;
  std::vector<int> boundary_ids_;

  // Scratch buffers of replace_cavity, kept to avoid allocating per operation.
  struct FaceSlot {
    Tri key;
    Index who;   ///< packed face of a new tet, or index into outer_
    bool outer;  ///< an outer face of the cavity
  };
  struct OuterFace {
    Index neighbour;  ///< packed, or kNoIndex
    bool frozen;
  };
  std::vector<FaceSlot> faces_;
  std::vector<OuterFace> outer_;
  std::vector<int> old_regions_;
  std::vector<Index> created_;
  std::vector<Index> bucket_;  ///< replace_cavity's face table: index into faces_, or kNoIndex
  struct EdgeSlot {
    std::uint64_t edge;  ///< (smaller point << 32) | larger point; kNoEdge when empty
    Index face;          ///< packed face of the new tet that holds it
  };
  static constexpr std::uint64_t kNoEdge = ~std::uint64_t{0};
  std::vector<EdgeSlot> edges_;  ///< replace_star's edge table
};

}  // namespace pdrmesh
