// SPDX-License-Identifier: AGPL-3.0-or-later
// How well a mesh's interior edges match the point distribution function.
#pragma once

#include <cstddef>

#include "pdrmesh/sizing.hpp"
#include "pdrmesh/volume_mesh.hpp"

namespace pdrmesh {

/// The edges with no endpoint on a mesh.boundary triangle, each once, by
/// length l against h at the midpoint.
struct SizeBand {
  std::size_t edges = 0;
  std::size_t shorter = 0;  ///< l < 0.6 h
  std::size_t within = 0;   ///< 0.6 h <= l <= 1.5 h
  std::size_t longer = 0;   ///< l > 1.5 h
};
SizeBand measure_size_band(const VolumeMesh& mesh, const SizingField& h);

}  // namespace pdrmesh
