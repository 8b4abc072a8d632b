// SPDX-License-Identifier: AGPL-3.0-or-later
#include "layers_proto.hpp"

namespace pdrmesh {

void to_proto(const LayerRequest& r, v1::BoundaryLayers& out) {
  out.set_count(r.layers);
  if (r.yplus) out.set_first_height_yplus(r.first_height);
  else out.set_first_height(r.first_height);
  out.set_reynolds(r.reynolds);
  out.set_reference_length(r.reference_length);
  out.set_growth_ratio(r.growth_ratio);
  if (r.max_thickness) out.set_max_thickness(*r.max_thickness);
  for (const std::string& name : r.on) out.add_on(name);
  for (const std::string& name : r.in) out.add_in_regions(name);
}

Result<LayerRequest> from_proto(const v1::BoundaryLayers& in) {
  if (in.first_case() == v1::BoundaryLayers::FIRST_NOT_SET)
    return invalid_input("job option layers: give the first layer's height (first_height or first_height_yplus)");
  LayerRequest r;
  r.layers = in.count();
  r.yplus = in.first_case() == v1::BoundaryLayers::kFirstHeightYplus;
  r.first_height = r.yplus ? in.first_height_yplus() : in.first_height();
  r.reynolds = in.reynolds();
  r.reference_length = in.reference_length();
  if (in.has_growth_ratio()) r.growth_ratio = in.growth_ratio();
  if (in.has_max_thickness()) r.max_thickness = in.max_thickness();
  r.on.assign(in.on().begin(), in.on().end());
  r.in.assign(in.in_regions().begin(), in.in_regions().end());
  return r;
}

}  // namespace pdrmesh
