// SPDX-License-Identifier: AGPL-3.0-or-later
// Reading and writing triangulated surfaces: STL, OBJ, OFF, PLY, Medit .mesh, AFLR3 .surf.
//
// Readers take the whole file in memory (the service receives uploads as bytes)
// and return a SurfaceMesh or an invalid_input Status whose message names the
// file and the line (text formats) or byte offset (binary formats), e.g.
// "bunny.stl:123: expected 'vertex', got 'vertx'". Record numbers in messages
// ("point 5", "triangle 17", "face 3") count from 1 in file order. Counts in
// headers are checked against the number of bytes that could hold them before
// anything is allocated. Every reader rejects non-finite coordinates, point
// indices out of range and files without triangles.
//
// Format rules:
// - STL: ASCII or binary. Binary when the size is 84 + 50 * n for the n in the
//   header; otherwise ASCII if it starts with "solid" and has no NUL byte in its
//   first 4 KiB; otherwise binary (reported as truncated or too long). Points with identical coordinates (exact; +0.0 == -0.0) are welded
//   and numbered in order of first appearance. Facet normals are ignored. In
//   ASCII files each `solid NAME ... endsolid` block gets the surface id 1, 2,
//   3, ... in file order, named NAME (blocks of one NAME share its id; a block
//   without a NAME has an id of its own and no name); binary files get id 1.
// - OBJ: `v`, `f` (i, i/t, i//n, i/t/n, negative relative indices; a vertex must
//   be defined before a face uses it), `g`/`o` names: each distinct name that
//   carries faces gets the id 1, 2, ... in order of first use, named by it
//   (faces before any g/o: an unnamed id; no names at all: all 1).
//   STL and OBJ names become SurfaceMesh::surface_names through
//   sanitize_boundary_name (boundary_names.hpp); "surface_<n>" is no name, and
//   two names that become one are an error naming both.
//   vt, vn, vp, usemtl, mtllib, s, l, p and comments are ignored.
// - OFF: optional OFF/COFF/NOFF/CNOFF header, `nv nf ne`, vertices (extra
//   values on a vertex line are ignored), faces `k i0 .. ik-1` (extra values such
//   as colours after the indices are ignored); 0-based; all ids 1.
// - PLY: ascii, binary_little_endian and binary_big_endian 1.0. Vertex x, y, z
//   of any scalar type; faces from the list `vertex_indices` or `vertex_index`;
//   a scalar face property `surface_id` (as written by write_surface) gives the
//   ids, otherwise all ids are 1. Other properties and elements are skipped.
// - Medit .mesh (ASCII, Dimension 3): Vertices, Triangles (reference = surface
//   id) and Quadrilaterals (split as below); other known sections are skipped,
//   an unknown keyword is an error.
// - AFLR3 .surf (ASCII): `nTri nQuad nNodes`, nodes `x y z ...`, triangles
//   `n1 n2 n3 [id [reconnect [bc]]]`, quads `n1 n2 n3 n4 [id ...]`; 1-based;
//   a missing id reads as 1.
// Polygons with k > 3 vertices v0..vk-1 are fan-triangulated as
// (v0, v1, v2), (v0, v2, v3), ..., (v0, vk-2, vk-1), every triangle keeping the
// polygon's id; a quad therefore becomes (v0, v1, v2), (v0, v2, v3).
//
// Writers print coordinates as shortest exact round-trip decimals, so reading a
// written file gives back the same doubles. What each format keeps:
// .mesh, .surf and .ply keep points, triangles and ids exactly (unused points
// included). .obj keeps points and triangles; ids come back as 1, 2, ... in
// order of first appearance. .off loses ids (all 1). .stl (ASCII, one solid per
// distinct id, ascending) keeps triangles and coordinates; points come back
// welded and numbered in order of first use, ids as 1..k in ascending id order.
// .stl solids and .obj groups are named by boundary_name (surface_names, else
// "surface_<id>"), so names come back; the other formats keep none.
#pragma once

#include <filesystem>
#include <string_view>

#include "pdrmesh/status.hpp"
#include "pdrmesh/surface.hpp"

namespace pdrmesh {

enum class SurfaceFormat { kStl, kObj, kOff, kPly, kMedit, kAflr3Surf };

/// The format named by the suffix (case-insensitive): .stl .obj .off .ply .mesh
/// .surf; `unsupported` for anything else.
Result<SurfaceFormat> surface_format_from_path(const std::filesystem::path& path);

/// Reads the file and parses it in the format its suffix names. The stored
/// name (and the one used in messages) is the file name without directories.
Result<SurfaceMesh> read_surface(const std::filesystem::path& path);

/// Parses a surface held in memory. `name` is used in messages and stored in
/// SurfaceMesh::name.
Result<SurfaceMesh> parse_surface(std::string_view bytes, SurfaceFormat format,
                                  std::string_view name);

/// Writes the surface in the format its suffix names (STL is written as ASCII,
/// PLY as ASCII). Rejects non-finite coordinates, indices out of range and a
/// surface_ids array of the wrong length with invalid_input.
Status write_surface(const SurfaceMesh& surface, const std::filesystem::path& path);

/// The same, into memory.
Result<std::string> format_surface(const SurfaceMesh& surface, SurfaceFormat format);

}  // namespace pdrmesh
