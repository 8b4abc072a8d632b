// SPDX-License-Identifier: AGPL-3.0-or-later
// Writes the ASCII STL copy of a test surface at build time, so that tests/data
// holds each surface once (as .mesh) and the tests that read STL get the same
// triangles in the same order: read back, the STL gives the surface's points
// welded and numbered in order of first use, as the corpus's own STL files did.
//   pdrmesh_make_test_stl IN.mesh OUT.stl
#include <cstdio>

#include "pdrmesh/surface_io.hpp"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s IN.mesh OUT.stl\n", argv[0]);
    return 2;
  }
  pdrmesh::Result<pdrmesh::SurfaceMesh> s = pdrmesh::read_surface(argv[1]);
  if (!s.ok()) {
    std::fprintf(stderr, "%s\n", s.status().to_string().c_str());
    return 1;
  }
  const pdrmesh::Status written = pdrmesh::write_surface(*s, argv[2]);
  if (!written.ok()) {
    std::fprintf(stderr, "%s\n", written.to_string().c_str());
    return 1;
  }
  return 0;
}
