// SPDX-License-Identifier: AGPL-3.0-or-later
// Writing and reading tetrahedral volume meshes in the file formats CFD
// solvers and viewers take: Medit (.mesh/.meshb), VTK XML (.vtu), AFLR3/FUN3D
// UGRID (ASCII and C-binary), Gmsh 4.1 (.msh) and SU2 (.su2); and writing
// CGNS (.cgns) and OpenFOAM polyMesh directories.
//
// Every format that is read round-trips exactly: what write_volume writes, read_volume
// returns with bit-identical coordinates, the same tets and boundary triangles
// in the same order and vertex order, and the same surface ids. Regions travel
// where the format holds them (see VolumeFormat). Two documented exceptions:
//  - SU2 stores boundary triangles grouped by marker: they come back grouped by
//    surface id (ascending, stable within an id); a mesh whose boundary is
//    already sorted that way round-trips exactly.
//  - Medit stores "no regions" as tet ref 0: a mesh whose regions are all 0
//    reads back with empty tet_regions.
// Boundary names (VolumeMesh::boundary_names) travel where the format holds
// them: SU2 marker tags (a named id may come back as another number), and a
// FUN3D .mapbc file written beside a UGRID file (see mapbc_path) and read
// back with it. Medit holds none.
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <string_view>
#include <vector>
#include <utility>

#include "pdrmesh/status.hpp"
#include "pdrmesh/volume_mesh.hpp"

namespace pdrmesh {

enum class VolumeFormat {
  kMedit,        ///< .mesh   Medit ASCII; triangle ref = surface id, tet ref = region (0: none)
  kMeditBinary,  ///< .meshb  libMeshb binary, version 2 (32-bit ints, 64-bit reals); reads 1-4
  kVtu,          ///< .vtu    VTK XML UnstructuredGrid (see VtuEncoding); tets + boundary triangles as cells,
                 ///<         boundary names as field data
  kUgridAscii,   ///< .ugrid      AFLR3/FUN3D UGRID, ASCII (no regions)
  kUgridLittle,  ///< .lb8.ugrid  UGRID C-binary, little endian int32/float64 (no regions)
  kUgridBig,     ///< .b8.ugrid   UGRID C-binary, big endian int32/float64 (no regions)
  kGmsh,         ///< .msh    Gmsh 4.1 ASCII (reads 2.2 too); physical surface per surface id (named by
                 ///<         boundary_name), volume per region
  kSu2,          ///< .su2    SU2 ASCII; one marker "surface_<id>" per surface id (no regions)
  kCgns,         ///< .cgns   CGNS (HDF5), written only; a TRI_3 section and BC per surface id (no regions)
  kFoam,         ///< a directory named polyMesh: OpenFOAM, written only; a patch per surface id,
                 ///< a cellZone per region
};

/// How a .vtu file stores its arrays. Reading takes all of these and what
/// VTK, ParaView and meshio write besides (inline base64, appended base64).
enum class VtuEncoding {
  kBinary,      ///< appended raw binary (the default)
  kCompressed,  ///< appended raw binary, zlib-compressed (vtkZLibDataCompressor)
  kAscii,       ///< ascii text
};

/// Choices of the writers that some formats offer.
struct VolumeWriteOptions {
  VtuEncoding vtu = VtuEncoding::kBinary;
};

/// The format named by a file's suffix (case-insensitive), or kFoam for a
/// path whose last component is "polyMesh" (exactly; a trailing '/' allowed).
/// Unknown suffix: `unsupported`, listing the supported suffixes.
Result<VolumeFormat> volume_format_from_path(const std::filesystem::path& path);

/// ".mesh .meshb .vtu .ugrid .lb8.ugrid .b8.ugrid .msh .su2 .cgns polyMesh", for help texts.
std::string_view volume_format_suffixes();


/// Writes `mesh` in the format named by the suffix of `path`, atomically: the
/// bytes go to a hidden file beside `path` (".NAME.PID.partial") that is
/// renamed onto `path` once complete, so a failed or interrupted write never
/// leaves a partial mesh under `path`. A mesh with inconsistent sizes,
/// out-of-range indices or non-finite coordinates is refused with
/// `invalid_input` before anything is written. A polyMesh directory is written
/// the same way (".polyMesh.PID.partial", then renamed), replacing a polyMesh
/// directory already there; missing parent directories (case/constant) are made.
Status write_volume(const VolumeMesh& mesh, const std::filesystem::path& path,
                    const VolumeWriteOptions& options = {});

/// A mesh file written beside its destination but not yet in place
/// (stage_volume): commit() renames it onto the destination; destroying it
/// uncommitted removes it.
class StagedVolume {
 public:
  StagedVolume() = default;
  StagedVolume(StagedVolume&& other) noexcept { *this = std::move(other); }
  StagedVolume& operator=(StagedVolume&& other) noexcept;
  StagedVolume(const StagedVolume&) = delete;
  StagedVolume& operator=(const StagedVolume&) = delete;
  ~StagedVolume() { discard(); }

  /// Puts the file (and a UGRID file's .mapbc) in place; afterwards this
  /// object holds nothing.
  Status commit();
  /// Removes the staged files (no-op once committed or discarded).
  void discard() noexcept;

 private:
  friend Result<StagedVolume> stage_volume(const VolumeMesh& mesh, const std::filesystem::path& path,
                                           const VolumeWriteOptions& options);

  void add(std::filesystem::path staged, std::filesystem::path destination) {
    files_.emplace_back(std::move(staged), std::move(destination));
  }

  /// Each staged file and its destination (a UGRID file has its .mapbc beside it).
  std::vector<std::pair<std::filesystem::path, std::filesystem::path>> files_;
};

/// write_volume without the final rename: for a caller that decides later
/// (say, after validating the mesh alongside the write) whether the file goes
/// in place.
Result<StagedVolume> stage_volume(const VolumeMesh& mesh, const std::filesystem::path& path,
                                  const VolumeWriteOptions& options = {});

/// The FUN3D boundary condition file of a UGRID file: the name without its
/// UGRID suffix, + ".mapbc" ("wing.lb8.ugrid" -> "wing.mapbc").
std::filesystem::path mapbc_path(const std::filesystem::path& ugrid);

/// The .mapbc of `mesh`: the number of surface ids on the first line, then
/// "ID BC NAME" per id in ascending order, NAME its boundary name
/// ("surface_<id>" unnamed) and BC kMapbcDefaultBc. write_volume writes it
/// beside every UGRID file of a mesh with a boundary.
std::string format_mapbc(const VolumeMesh& mesh);

/// FUN3D's boundary condition 3000, tangency (an inviscid wall): what pdrmesh
/// writes for every id, for the user to change per patch.
inline constexpr int kMapbcDefaultBc = 3000;

/// Parses a .mapbc: the names by id (a NAME "surface_<id>", or none, is no
/// name; others go through sanitize_boundary_name). BC codes are not kept.
Result<std::map<int, std::string>> parse_mapbc(std::string_view text, const std::string& name);

/// Reads a volume mesh in the format named by the suffix of `path`. Malformed
/// files give `invalid_input` naming file:line (text) or the byte offset
/// (binary); meshes with other element kinds (hexahedra, quads; prisms and
/// pyramids except in Medit .mesh, which reads them) and the written-only formats (CGNS, polyMesh) give `unsupported`. A UGRID
/// file's names come from its .mapbc when there is one (an id there that the
/// mesh lacks is an error).
Result<VolumeMesh> read_volume(const std::filesystem::path& path);

}  // namespace pdrmesh
