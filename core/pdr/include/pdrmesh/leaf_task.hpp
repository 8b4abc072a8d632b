// SPDX-License-Identifier: AGPL-3.0-or-later
// A PDR leaf task as a pure, serialisable function: the coordinator packs one
// octree leaf (its tets, its points with their global ids, and its frozen hull)
// into LeafTaskInput bytes; a kernel refines the leaf's interior and returns
// LeafTaskOutput bytes; the coordinator decodes and validates them before it
// trusts anything (the task may run on a remote worker: a result that lies about
// counts, indices or the frozen hull is rejected).
//
// Local numbering. Input point i (0 <= i < points.size()) has the global id
// point_ids[i]. Output tets use local references: r < input_points is input
// point r, r >= input_points is new point r - input_points. The output names no
// global ids at all, so the coordinator numbers new points itself (see pdr.hpp)
// and merges by id, never by matching coordinates.
//
// Frozen faces are the leaf's hull: every face of a leaf tet that no other leaf
// tet shares, oriented outward w.r.t. the leaf. Each is an interface face (id 0:
// shared with another leaf) or a geometry boundary face (its surface id, >= 1).
// Those are engine ids (surface_ids.hpp): run_pdr numbers a surface whose ids
// are not all >= 1 (a Medit ref 0, a negative PLY id) from 1 on entry and
// gives the user's ids back on exit, so no surface face ever carries id 0.
// A kernel must return a tet set whose hull is exactly these faces (same
// triangles, same orientation), so that the neighbours still conform. Input
// points off the hull may be dropped (TetGen re-fills the hull); hull points
// may not. Input points off the hull may be moved (an optimization kernel
// smooths them): the output lists them with their new coordinates; no other
// leaf uses such a point, so the coordinator applies the move as it merges.
//
// Binary layout (little-endian; u32/u64 unsigned, f64 IEEE bits):
//   input:  magic "PDRLEAFI", u32 version, u32 leaf,
//           u64 n, n x (u64 id, 3 x f64), u64 m, m x 4 x u32,
//           u64 k, k x (3 x u32, u32 id as two's complement),
//           u32 has_core, then if 1: 6 x f64 (core lo, core hi),
//           u64 s (0 or n), s x f64 (sizes), u64 q, q x 3 x f64 (seeds)
//   output: magic "PDRLEAFO", u32 version, u32 leaf, u32 input_points,
//           u64 n, n x 3 x f64, u64 s (0 or n), s x f64 (new_sizes),
//           u64 m, m x 4 x u32, u64 k, k x (u32, 3 x f64)
// The version is 5; bytes of any other version are refused.
// decode() checks every count against the bytes left, indices against the
// point count, finiteness, repeated vertices and trailing bytes.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "pdrmesh/sizing.hpp"
#include "pdrmesh/status.hpp"
#include "pdrmesh/tet_mesh.hpp"
#include "pdrmesh/types.hpp"
#include "pdrmesh/volume_mesh.hpp"

namespace pdrmesh {

struct LeafTaskInput {
  std::uint32_t leaf = 0;              ///< index into the decomposition's leaves
  std::vector<GlobalId> point_ids;     ///< one per point
  std::vector<Vec3> points;            ///< the points used by `tets`
  std::vector<Tet> tets;               ///< local indices into points, positive
  std::vector<Tri> frozen_faces;       ///< the leaf's hull, outward, local indices
  std::vector<int> frozen_ids;         ///< per frozen face: engine surface id >= 1, 0 = interface
  /// Set: the leaf's own closed box. The tets are then the leaf's and a buffer
  /// of its neighbours' around it, and a refining kernel adds points only
  /// inside the box (run_pdr's buffered rounds); unset: the tets are the leaf.
  std::optional<Box> core;
  /// Empty, or per point h there (SizingField::at, bit for bit), so that a
  /// kernel need not evaluate the sizing field again at points an earlier
  /// task made (their h comes back in LeafTaskOutput::new_sizes).
  std::vector<double> sizes;
  /// Non-empty: a seed round's task (PdrPlan::leaf_seeds). A refining kernel
  /// inserts these points (insert_points, refine.hpp), the initial mesh's
  /// seeds that lie in the core, and refines nothing; those in no tet of the
  /// task, or on its frozen faces, are skipped.
  std::vector<Vec3> seeds;

  std::string encode() const;
  static Result<LeafTaskInput> decode(std::string_view bytes);
};

struct LeafTaskOutput {
  std::uint32_t leaf = 0;          ///< must equal the input's leaf
  std::uint32_t input_points = 0;  ///< must equal the input's point count
  std::vector<Vec3> new_points;    ///< local reference input_points + k
  std::vector<double> new_sizes;   ///< empty, or per new point h there (SizingField::at), finite and > 0
  std::vector<Tet> tets;           ///< local references (see the file comment), positive
  std::vector<Index> moved;        ///< input points (off the hull) given new coordinates, ascending
  std::vector<Vec3> moved_to;      ///< their new coordinates, one per entry of `moved`

  std::string encode() const;
  /// encode().size(), without encoding.
  std::uint64_t encoded_size() const;
  static Result<LeafTaskOutput> decode(std::string_view bytes);
};

/// The coordinator's acceptance test of `out` for `in`: same leaf and input
/// point count; references in range; every new point finite and used; no tet
/// with a repeated vertex or not positively oriented (exact::orient3d); every
/// face shared by at most two tets, with opposite orientations; the hull
/// (faces used once) equal to in.frozen_faces exactly, orientation included;
/// moved points ascending, input points not on the hull, finite, and used as
/// moved in the orientation test; new_sizes empty or one per new point,
/// finite and positive.
/// invalid_input naming the leaf and the first problem otherwise.
Status validate_leaf_output(const LeafTaskInput& in, const LeafTaskOutput& out);

/// The most bytes an honest result for `in` can take: a remote worker's result
/// announced above it is refused before it is received, and the engine refuses
/// a local one above it too (same rule on both paths, so the same bytes; a
/// kernel that is only ever local and trusted is exempt).
/// h_lo = sizing.lower_bound(box of the leaf's points). New points are taken to
/// keep at least 0.4 h_lo apart (the refiner rejects closer than 0.6 h and the
/// optimization's insertions than 0.5 h), so at most V / (4/3 pi (0.2 h_lo)^3)
/// fit in the leaf's box grown by 0.2 h_lo (volume V); tets are taken as at most
/// 12 per point (a Delaunay-like mesh has 6 to 7); every input point may move.
/// About 40 times what a leaf refined to a uniform h_lo holds; never above
/// 2^62. Does not depend on the kernel or on which worker runs it.
std::uint64_t leaf_output_byte_limit(const LeafTaskInput& in, const SizingField& sizing);

/// The leaf as a TetMesh: points and global-id-free local numbering (point i
/// has id i, new points get ids from points.size() on), frozen faces as its
/// frozen boundary with their ids.
Result<TetMesh> leaf_tet_mesh(const LeafTaskInput& in);

/// The inverse for a TetMesh built by leaf_tet_mesh and then refined: its
/// alive tets in slot order, with points beyond in.points as new points and
/// input points whose coordinates changed as moved.
LeafTaskOutput leaf_output_from(const LeafTaskInput& in, const TetMesh& mesh);

/// A leaf refinement kernel. run() must be a deterministic function of its
/// arguments (same bytes in, same bytes out), thread-safe (it is called for
/// several leaves at once), and must keep the frozen faces (see above).
class LeafKernel {
 public:
  virtual ~LeafKernel() = default;
  virtual Result<LeafTaskOutput> run(const LeafTaskInput& in, const SizingField& sizing) const = 0;
  virtual std::string_view name() const = 0;
  /// True when the kernel needs each leaf's hull to be a closed 2-manifold and
  /// each leaf face-connected (the paper's partition swap and boundary
  /// extraction fix-ups; run_pdr applies them before building the tasks).
  virtual bool needs_manifold_hull() const { return false; }
  /// True when the kernel's results need no acceptance test task by task: it
  /// runs in this process, on the input itself, with operations that keep the
  /// frozen hull and positive orientation by construction. run_pdr then skips
  /// the byte limit and checks them (validate_leaf_output) only in debug
  /// builds; a result from another process is always checked.
  virtual bool trusted() const { return false; }
};

/// True when `s` says the kernel itself gave up on the leaf (kInternal: a
/// crash, TetGen failing on the hull; kDeadlineExceeded: the kernel's own time
/// limit): the same task fails the same way anywhere, so the engine may keep
/// the leaf unrefined. False for what a kernel reports when the task could not
/// be run (a dispatcher's kIoError, kResourceExhausted, kInvalidInput refusals,
/// kCancelled): keeping the leaf then would make the output depend on faults.
bool is_kernel_failure(const Status& s);

/// kernel.run(in, sizing), with an exception turned into the leaf's status:
/// std::bad_alloc is kResourceExhausted "out of memory while refining (...)"
/// (the machine, not the leaf, is at fault, so it is not kept unrefined: the
/// run fails with that message), any other exception kInternal. What the
/// engine's tasks and a worker run, so that no leaf takes its process down.
Result<LeafTaskOutput> run_leaf_kernel(const LeafKernel& kernel, const LeafTaskInput& in,
                                       const SizingField& sizing);

/// Bytes in, bytes out: decodes an input, runs the kernel (run_leaf_kernel),
/// encodes its output.
Result<std::string> run_leaf_task(const LeafKernel& kernel, std::string_view input,
                                  const SizingField& sizing);

}  // namespace pdrmesh
