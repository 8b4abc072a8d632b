// SPDX-License-Identifier: AGPL-3.0-or-later
// MeshOptions.layers (BoundaryLayers) to and from the kernel's LayerRequest
// (layers.hpp), for every side that speaks the service: the CLI, the Python
// client and the coordinator.
#pragma once

#include "pdrmesh/layers.hpp"
#include "pdrmesh/status.hpp"
#include "pdrmesh/v1/pdrmesh.pb.h"

namespace pdrmesh {

/// The request as a job carries it (names and a y+ unresolved: the
/// coordinator resolves them on the job's surface).
void to_proto(const LayerRequest& request, v1::BoundaryLayers& out);

/// The request a job carries; invalid_input when it gives no first height.
/// Its values are checked by validate(LayerRequest).
Result<LayerRequest> from_proto(const v1::BoundaryLayers& in);

}  // namespace pdrmesh
