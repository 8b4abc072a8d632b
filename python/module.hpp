// SPDX-License-Identifier: AGPL-3.0-or-later
// What the two halves of the extension module _pdrmesh share: the exceptions
// a Status becomes, and the checks of the keyword arguments that the CLI's
// option rules (client/options.hpp) decide.
#pragma once

#include <pybind11/pybind11.h>

#include <optional>
#include <string>
#include <vector>

#include "options.hpp"
#include "pdrmesh/farfield.hpp"
#include "pdrmesh/layers.hpp"
#include "pdrmesh/status.hpp"
#include "run_options.hpp"

namespace pdrmesh::python {

/// Raises the Python exception for `status` (not ok), its message the
/// Status's text: ValueError for bad input or an unsupported request,
/// FileNotFoundError, OSError for I/O, TimeoutError for a time limit,
/// RuntimeError otherwise.
[[noreturn]] void raise(const Status& status);

/// The mesh options the keyword arguments of mesh() and Client.submit()
/// name, as the CLI's flags take them: `size` a length or "P%", the rest
/// numbers or None. A value the CLI would refuse raises ValueError with the
/// CLI's message, naming the keyword ("hmin must be a positive length, got '-1'").
cli::RunOptionArgs run_options(const std::optional<std::string>& size, std::optional<double> hmin,
                               std::optional<double> hmax, double growth, std::optional<double> max_tets,
                               std::optional<int> depth, const std::string& kernel, bool optimize);

/// The far field of the keywords farfield (body lengths, None: none) and
/// farfield_shape ("box" or "sphere"), as --farfield and --farfield-shape
/// take them; ValueError for a distance or shape they refuse, or a sphere
/// without a distance.
std::optional<FarfieldOptions> farfield_options(std::optional<double> farfield, const std::string& shape);

/// The layers of the keywords layers (None: none), first_height (a length,
/// or "yplus:Y" with reynolds), reynolds, reference_length, growth_ratio,
/// layers_max_thickness, layers_on (boundary names or ids) and layers_in
/// (region names or ids), as `pdrmesh mesh --layers ...` takes them;
/// ValueError for what the CLI refuses.
std::optional<LayerRequest> layer_request(std::optional<int> layers, const pybind11::handle& first_height,
                                          std::optional<double> reynolds, std::optional<double> reference_length,
                                          double growth_ratio, std::optional<double> max_thickness,
                                          const std::vector<std::string>& on, const std::vector<std::string>& in);

/// Binds the service client (service.cpp).
void bind_service(pybind11::module_& m);

}  // namespace pdrmesh::python
