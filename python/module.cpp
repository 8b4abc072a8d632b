// SPDX-License-Identifier: AGPL-3.0-or-later
// _pdrmesh: the compiled half of the Python package pdrmesh (python/pdrmesh/
// is the other). It converts numpy arrays to the kernel's SurfaceMesh and
// VolumeMesh and back, and runs what the local commands run: the surface
// check, mesh_serial or mesh_parallel with the options the CLI's flags give
// (client/run_options.hpp), the validator, the quality figures, the readers
// and writers. Meshing and the other long steps run without the GIL.
#include "module.hpp"

#include <fmt/format.h>
#include <oneapi/tbb/global_control.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "layer_options.hpp"
#include "pdrmesh/farfield.hpp"
#include "pdrmesh/layered_pipeline.hpp"
#include "pdrmesh/leaf_kernels.hpp"
#include "pdrmesh/pipeline.hpp"
#include "pdrmesh/quality.hpp"
#include "pdrmesh/surface_check.hpp"
#include "pdrmesh/surface_io.hpp"
#include "pdrmesh/validate.hpp"
#include "pdrmesh/volume_io.hpp"

namespace py = pybind11;

namespace pdrmesh::python {

[[noreturn]] void raise(const Status& status) {
  PyObject* type = PyExc_RuntimeError;
  switch (status.code()) {
    case StatusCode::kInvalidInput:
    case StatusCode::kUnsupported: type = PyExc_ValueError; break;
    case StatusCode::kNotFound: type = PyExc_FileNotFoundError; break;
    case StatusCode::kIoError: type = PyExc_OSError; break;
    case StatusCode::kDeadlineExceeded: type = PyExc_TimeoutError; break;
    default: break;
  }
  PyErr_SetString(type, status.to_string().c_str());
  throw py::error_already_set();
}

namespace {

template <class T>
T value_or_raise(Result<T> r) {
  if (!r.ok()) raise(r.status());
  return std::move(r).value();
}

void raise_unless_ok(const Status& s) {
  if (!s.ok()) raise(s);
}

/// f() run without the GIL: the kernel's work touches no Python object.
template <class F>
auto without_gil(F&& f) {
  py::gil_scoped_release release;
  return f();
}

/// Raises ValueError "NAME must be ..., got '...'" when the CLI's rule for the
/// option refuses `value`.
void check_number(const char* name, double value, const cli::Accepts& accepts) {
  std::string text = fmt::format("{}", value);
  if (std::string error = cli::number_check(accepts)(text); !error.empty())
    throw py::value_error(fmt::format("{} {}", name, error));
}

}  // namespace

cli::RunOptionArgs run_options(const std::optional<std::string>& size, std::optional<double> hmin,
                               std::optional<double> hmax, double growth, std::optional<double> max_tets,
                               std::optional<int> depth, const std::string& kernel, bool optimize) {
  cli::RunOptionArgs a;
  if (size) {
    if (!cli::SizeValue::parse(*size))
      throw py::value_error(fmt::format(
          "size must be a positive length or a percentage of the bounding-box diagonal such as '1%', got '{}'", *size));
    a.size.size = *size;
  }
  if (hmin) {
    check_number("hmin", *hmin, cli::kLength);
    a.size.hmin = *hmin;
  }
  if (hmax) {
    check_number("hmax", *hmax, cli::kLength);
    a.size.hmax = *hmax;
  }
  check_number("growth", growth, cli::kGrowth);
  a.size.growth = growth;
  if (max_tets) {
    check_number("max_tets", *max_tets, cli::kTets);
    a.size.max_tets = *max_tets;
  }
  if (depth) {
    check_number("depth", *depth, cli::kDepth);
    a.depth = *depth;
  }
  if (kernel != "native" && kernel != "tetgen")
    throw py::value_error(fmt::format("kernel must be 'native' or 'tetgen', got '{}'", kernel));
  a.kernel = kernel;
  a.no_optimize = !optimize;
  try {
    a.size.check();
  } catch (const CLI::Error& e) {
    throw py::value_error(e.what());
  }
  return a;
}

std::optional<FarfieldOptions> farfield_options(std::optional<double> farfield, const std::string& shape) {
  const auto parsed = parse_farfield_shape(shape);
  if (!parsed) throw py::value_error(fmt::format("farfield_shape must be 'box' or 'sphere', got '{}'", shape));
  if (!farfield) {
    if (*parsed != FarfieldShape::kBox) throw py::value_error("farfield_shape needs farfield (the distance in body lengths)");
    return std::nullopt;
  }
  if (Status st = check_farfield_distance(*farfield, "farfield"); !st.ok()) throw py::value_error(st.message());
  return FarfieldOptions{*farfield, *parsed};
}

std::optional<LayerRequest> layer_request(std::optional<int> layers, const py::handle& first_height,
                                          std::optional<double> reynolds, std::optional<double> reference_length,
                                          double growth_ratio, std::optional<double> max_thickness,
                                          const std::vector<std::string>& on, const std::vector<std::string>& in) {
  if (!layers) {
    if (!first_height.is_none() || reynolds || reference_length || max_thickness || !on.empty() || !in.empty())
      throw py::value_error("first_height, reynolds, reference_length, layers_max_thickness, layers_on and "
                            "layers_in: only with layers");
    return std::nullopt;
  }
  if (first_height.is_none()) throw py::value_error("layers: give the first layer's height with first_height");
  // A number as its shortest round-trip text, a string as the CLI reads it.
  const std::string text = py::isinstance<py::str>(first_height)
                               ? first_height.cast<std::string>()
                               : py::repr(py::float_(first_height.cast<double>())).cast<std::string>();
  const auto height = cli::FirstHeightValue::parse(text);
  if (!height)
    throw py::value_error(fmt::format(
        "first_height must be a positive length or 'yplus:Y' with Y a positive number of wall units, got '{}'", text));
  if (height->yplus && !reynolds) throw py::value_error("first_height yplus:Y: give the Reynolds number with reynolds");
  LayerRequest r;
  r.layers = *layers;
  r.first_height = height->value;
  r.yplus = height->yplus;
  r.reynolds = reynolds.value_or(0);
  r.reference_length = reference_length.value_or(0);
  r.growth_ratio = growth_ratio;
  r.max_thickness = max_thickness;
  r.on = on;
  r.in = in;
  if (Status s = validate(r); !s.ok()) throw py::value_error(s.message());
  return r;
}

namespace {

using F64Array = py::array_t<double, py::array::c_style | py::array::forcecast>;
using I64Array = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>;

std::string shape_text(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t k = 0; k < a.ndim(); ++k) s += fmt::format("{}{}", k ? ", " : "", a.shape(k));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

/// `a` as an N x `columns` array of doubles; ValueError naming `name` otherwise.
F64Array float_rows(const py::handle& a, const char* name, py::ssize_t columns) {
  const F64Array arr = F64Array::ensure(a);
  if (!arr) throw py::value_error(fmt::format("{} must be an array of numbers", name));
  if (arr.ndim() != 2 || arr.shape(1) != columns)
    throw py::value_error(fmt::format("{} must be an N x {} array, got shape {}", name, columns, shape_text(arr)));
  return arr;
}

/// `a` as an integer array of `ndim` dimensions (and `columns` columns when 2);
/// floats are refused rather than truncated.
I64Array int_array(const py::handle& a, const char* name, int ndim, py::ssize_t columns) {
  const py::array any = py::array::ensure(a);
  if (!any) throw py::value_error(fmt::format("{} must be an array of integers", name));
  const char kind = any.dtype().kind();
  if (any.size() > 0 && kind != 'i' && kind != 'u')
    throw py::value_error(fmt::format("{} must hold integers, got dtype {}", name, py::str(any.dtype()).cast<std::string>()));
  const I64Array arr = I64Array::ensure(any);
  const bool shape_ok = ndim == 1 ? arr.ndim() == 1 : (arr.ndim() == 2 && arr.shape(1) == columns);
  if (!shape_ok) {
    throw py::value_error(ndim == 1 ? fmt::format("{} must be a one-dimensional array, got shape {}", name, shape_text(arr))
                                    : fmt::format("{} must be an N x {} array, got shape {}", name, columns,
                                                  shape_text(arr)));
  }
  return arr;
}

std::vector<Vec3> to_points(const py::handle& a, const char* name) {
  const F64Array arr = float_rows(a, name, 3);
  std::vector<Vec3> out(static_cast<std::size_t>(arr.shape(0)));
  if (!out.empty()) std::memcpy(out.data(), arr.data(), out.size() * sizeof(Vec3));
  return out;
}

/// Rows of point indices, each within [0, point_count) (the kernel's checks
/// take any index, but a negative or huge one has no Index to travel as).
template <std::size_t N>
std::vector<std::array<Index, N>> to_cells(const py::handle& a, const char* name, std::size_t point_count) {
  const I64Array arr = int_array(a, name, 2, static_cast<py::ssize_t>(N));
  const auto rows = static_cast<std::size_t>(arr.shape(0));
  std::vector<std::array<Index, N>> out(rows);
  const std::int64_t* v = arr.data();
  for (std::size_t r = 0; r < rows; ++r) {
    for (std::size_t k = 0; k < N; ++k) {
      const std::int64_t i = v[r * N + k];
      if (i < 0 || static_cast<std::uint64_t>(i) >= point_count)
        throw py::value_error(fmt::format("{} row {} names point {}, which does not exist (there are {} points)",
                                          name, r, i, point_count));
      out[r][k] = static_cast<Index>(i);
    }
  }
  return out;
}

std::vector<int> to_ints(const py::handle& a, const char* name, std::size_t count) {
  const I64Array arr = int_array(a, name, 1, 0);
  if (static_cast<std::size_t>(arr.shape(0)) != count)
    throw py::value_error(fmt::format("{} has {} entries; it needs one per row, {}", name, arr.shape(0), count));
  std::vector<int> out(count);
  for (std::size_t i = 0; i < count; ++i) {
    const std::int64_t v = arr.data()[i];
    if (v < std::numeric_limits<int>::min() || v > std::numeric_limits<int>::max())
      throw py::value_error(fmt::format("{}[{}] = {} is out of the range of a 32-bit id", name, i, v));
    out[i] = static_cast<int>(v);
  }
  return out;
}

std::map<int, std::string> to_names(const py::handle& names) {
  if (names.is_none()) return {};
  try {
    return names.cast<std::map<int, std::string>>();
  } catch (const py::cast_error&) {
    throw py::value_error("names must be a dict from integer ids to strings");
  }
}

/// A surface from arrays. Triangle indices are not checked against the
/// points here: the surface check names a bad one with its triangle.
SurfaceMesh to_surface(const py::handle& points, const py::handle& triangles, const py::handle& surface_ids,
                       const py::handle& names) {
  SurfaceMesh s;
  s.points = to_points(points, "points");
  s.triangles = to_cells<3>(triangles, "triangles", std::numeric_limits<Index>::max());
  s.surface_ids = surface_ids.is_none() ? std::vector<int>(s.triangles.size(), 1)
                                        : to_ints(surface_ids, "surface_ids", s.triangles.size());
  s.surface_names = to_names(names);
  s.name = "the surface";
  return s;
}

VolumeMesh to_volume(const py::handle& points, const py::handle& tets, const py::handle& boundary,
                     const py::handle& boundary_ids, const py::handle& regions, const py::handle& names,
                     const py::handle& region_names = py::none(), const py::handle& prisms = py::none(),
                     const py::handle& pyramids = py::none()) {
  VolumeMesh m;
  m.points = to_points(points, "points");
  m.tets = to_cells<4>(tets, "tets", m.points.size());
  if (!prisms.is_none()) m.prisms = to_cells<6>(prisms, "prisms", m.points.size());
  if (!pyramids.is_none()) m.pyramids = to_cells<5>(pyramids, "pyramids", m.points.size());
  if (!boundary.is_none()) m.boundary = to_cells<3>(boundary, "boundary", m.points.size());
  if (!boundary_ids.is_none()) m.boundary_ids = to_ints(boundary_ids, "boundary_ids", m.boundary.size());
  // Regions: one per volume cell, tets then prisms then pyramids (as meshio's blocks).
  if (!regions.is_none()) {
    std::vector<int> all = to_ints(regions, "regions", m.tets.size() + m.prisms.size() + m.pyramids.size());
    const auto at = [&](std::size_t k) { return all.begin() + static_cast<std::ptrdiff_t>(k); };
    m.prism_regions.assign(at(m.tets.size()), at(m.tets.size() + m.prisms.size()));
    m.pyramid_regions.assign(at(m.tets.size() + m.prisms.size()), all.end());
    all.resize(m.tets.size());
    m.tet_regions = std::move(all);
  }
  m.boundary_names = to_names(names);
  m.region_names = to_names(region_names);
  return m;
}

template <std::size_t N>
py::array_t<std::int64_t> cells_array(const std::vector<std::array<Index, N>>& cells) {
  py::array_t<std::int64_t> a({static_cast<py::ssize_t>(cells.size()), static_cast<py::ssize_t>(N)});
  std::int64_t* out = a.mutable_data();
  for (std::size_t r = 0; r < cells.size(); ++r)
    for (std::size_t k = 0; k < N; ++k) out[r * N + k] = cells[r][k];
  return a;
}

py::array_t<double> points_array(const std::vector<Vec3>& points) {
  py::array_t<double> a({static_cast<py::ssize_t>(points.size()), py::ssize_t{3}});
  if (!points.empty()) std::memcpy(a.mutable_data(), points.data(), points.size() * sizeof(Vec3));
  return a;
}

/// A one-dimensional array of `v`'s values.
template <class Out, class In>
py::array_t<Out> vector_array(const std::vector<In>& v) {
  py::array_t<Out> a(static_cast<py::ssize_t>(v.size()));
  std::copy(v.begin(), v.end(), a.mutable_data());
  return a;
}

py::array_t<std::int32_t> ints_array(const std::vector<int>& v) { return vector_array<std::int32_t>(v); }

py::dict surface_dict(const SurfaceMesh& s) {
  py::dict d;
  d["points"] = points_array(s.points);
  d["triangles"] = cells_array(s.triangles);
  d["surface_ids"] = ints_array(s.surface_ids);
  d["names"] = s.surface_names;
  d["name"] = s.name;
  return d;
}

py::dict volume_dict(const VolumeMesh& m) {
  py::dict d;
  d["points"] = points_array(m.points);
  d["tets"] = cells_array(m.tets);
  d["prisms"] = cells_array(m.prisms);
  d["pyramids"] = cells_array(m.pyramids);
  d["boundary"] = cells_array(m.boundary);
  d["boundary_ids"] = ints_array(m.boundary_ids);
  std::vector<int> regions = m.tet_regions;  // per volume cell: tets, prisms, pyramids
  if (m.has_regions()) {
    regions.insert(regions.end(), m.prism_regions.begin(), m.prism_regions.end());
    regions.insert(regions.end(), m.pyramid_regions.begin(), m.pyramid_regions.end());
  }
  d["regions"] = regions.empty() ? py::object(py::none()) : py::object(ints_array(regions));
  d["boundary_names"] = m.boundary_names;
  d["region_names"] = m.region_names;
  return d;
}

py::object parse_json(const std::string& text) { return py::module_::import("json").attr("loads")(text); }

py::dict read_surface_py(const std::filesystem::path& path) {
  return surface_dict(value_or_raise(without_gil([&] { return read_surface(path); })));
}

void write_surface_py(const py::handle& points, const py::handle& triangles, const py::handle& surface_ids,
                      const py::handle& names, const std::filesystem::path& path) {
  const SurfaceMesh s = to_surface(points, triangles, surface_ids, names);
  raise_unless_ok(without_gil([&] { return write_surface(s, path); }));
}

py::object check_py(const py::handle& points, const py::handle& triangles, const py::handle& surface_ids,
                    bool self_intersections) {
  const SurfaceMesh s = to_surface(points, triangles, surface_ids, py::none());
  std::string json, text;
  {
    py::gil_scoped_release release;
    CheckOptions options;
    options.self_intersections = self_intersections;
    const SurfaceReport report = check_surface(s, options);
    json = report_to_json(report, s.name);
    text = format_report(report, s.name);
  }
  py::object report = parse_json(json);
  report["text"] = text;
  return report;
}

using Clock = std::chrono::steady_clock;

/// mesh(): the surface check, the size rules of `pdrmesh mesh` (workers 0) or
/// `pdrmesh run --workers N`, the validation against the surface.
py::dict mesh_py(const py::handle& points, const py::handle& triangles, const py::handle& surface_ids,
                 const py::handle& names, const std::optional<std::string>& size, std::optional<double> hmin,
                 std::optional<double> hmax, double growth, std::optional<double> max_tets, int workers,
                 std::optional<int> depth, const std::string& kernel_name, bool optimize,
                 std::optional<double> time_limit, bool validate, std::optional<double> farfield,
                 const std::string& farfield_shape, const std::optional<LayerRequest>& layer_options) {
  const cli::RunOptionArgs args = run_options(size, hmin, hmax, growth, max_tets, depth, kernel_name, optimize);
  if (workers < 0 || workers > 4096) throw py::value_error(fmt::format("workers must be 0 (serial) or 1 to 4096, got {}", workers));
  if (time_limit) check_number("time_limit", *time_limit, cli::kSeconds);
  if (depth && workers == 0) throw py::value_error("depth is an option of the parallel method: give workers >= 1");
  if (kernel_name != "native" && workers == 0)
    throw py::value_error("kernel is an option of the parallel method: give workers >= 1");
  const std::optional<FarfieldOptions> far = farfield_options(farfield, farfield_shape);
  SurfaceMesh surface = to_surface(points, triangles, surface_ids, names);

  std::string size_line;
  Result<VolumeMesh> result = VolumeMesh{};
  {
    py::gil_scoped_release release;
    result = [&]() -> Result<VolumeMesh> {
      const auto start = Clock::now();
      double body_diagonal = 0;  // what a percentage size refers to with a far field
      std::vector<int> body_ids;   // the default walls of layers with a far field
      if (far) {  // the domain around the body takes its place, as with `pdrmesh mesh --farfield`
        body_diagonal = surface.bounds().diagonal();
        PDR_ASSIGN_OR_RETURN(FarfieldDomain domain, make_farfield(surface, *far));
        body_ids = domain.body_ids();
        surface = std::move(domain.surface);
      }
      PDR_TRY(require_meshable(check_surface(surface), surface.name));
      std::optional<LayerOptions> layers;
      if (layer_options) {
        PDR_ASSIGN_OR_RETURN(layers, resolve_layers(*layer_options, surface, body_ids));
      }
      const SizingOptions sizing = args.size.resolve(surface, size_line, true, body_diagonal);
      PDR_TRY(args.size.check_tet_limit(surface, sizing, true));
      const double limit_s = time_limit.value_or(0);
      const auto deadline = start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(limit_s));
      if (workers == 0) {
        SerialOptions options;
        options.sizing = sizing;
        if (!optimize) options.optimize.reset();
        if (limit_s > 0) {
          options.time_limit_s = std::chrono::duration<double>(deadline - Clock::now()).count();
          if (!(options.time_limit_s > 0)) return deadline_exceeded("the time limit ran out while the surface was checked");
        }
        if (layers) {
          PDR_ASSIGN_OR_RETURN(LayeredResult r, mesh_serial_layered(surface, *layers, options));
          return std::move(r.mesh);
        }
        PDR_ASSIGN_OR_RETURN(SerialResult r, mesh_serial(surface, options));
        return std::move(r.mesh);
      }
      // workers is the whole run's thread budget, as in `pdrmesh run --workers`.
      const tbb::global_control threads(tbb::global_control::max_allowed_parallelism,
                                        static_cast<std::size_t>(workers));
      PDR_ASSIGN_OR_RETURN(const auto kernel, make_leaf_kernel(kernel_name));
      ParallelOptions options = args.parallel_options(sizing);
      options.pdr.workers = static_cast<std::size_t>(workers);
      if (limit_s > 0) {
        options.pdr.tetgen_time_limit_s = std::min(options.pdr.tetgen_time_limit_s, limit_s);
        options.pdr.progress = [deadline](const PdrProgress&) { return Clock::now() < deadline; };
      }
      Result<VolumeMesh> made = VolumeMesh{};
      if (layers) {
        auto r = mesh_parallel_layered(surface, *layers, options, kernel.get());
        if (r.ok()) made = std::move(r->layered.mesh);
        else made = r.status();
      } else {
        auto r = mesh_parallel(surface, options, kernel.get());
        if (r.ok()) made = std::move(r->mesh);
        else made = r.status();
      }
      if (limit_s > 0 && Clock::now() >= deadline)
        return deadline_exceeded(fmt::format("the time limit ({} s) ran out before the mesh was done", limit_s));
      return made;
    }();
    if (result.ok() && validate) {
      const ValidationReport report = validate_mesh(*result, &surface);
      if (!report.ok())
        result = internal_error("the generated mesh failed validation; please report this with the input\n" +
                                format_validation(report));
    }
  }
  VolumeMesh mesh = value_or_raise(std::move(result));
  // The pipelines carry the boundary ids; the names belong to the same ids.
  if (mesh.boundary_names.empty()) mesh.boundary_names = surface.surface_names;
  py::dict d = volume_dict(mesh);
  d["size_text"] = size_line;
  return d;
}

py::object quality_py(const py::handle& points, const py::handle& tets) {
  const VolumeMesh m = to_volume(points, tets, py::none(), py::none(), py::none(), py::none());
  return parse_json(without_gil([&] { return quality_to_json(measure_quality(m, /*interior=*/true)); }));
}

py::array_t<double> min_dihedral_py(const py::handle& points, const py::handle& tets) {
  const VolumeMesh m = to_volume(points, tets, py::none(), py::none(), py::none(), py::none());
  return vector_array<double>(without_gil([&] { return min_dihedral_per_tet(m); }));
}

py::dict validate_py(const py::handle& points, const py::handle& tets, const py::handle& boundary,
                     const py::handle& boundary_ids, const py::handle& regions, const py::handle& surface,
                     const py::handle& prisms, const py::handle& pyramids) {
  // The regions too: a mesh of several regions has its interfaces among the boundary triangles.
  const VolumeMesh m =
      to_volume(points, tets, boundary, boundary_ids, regions, py::none(), py::none(), prisms, pyramids);
  std::optional<SurfaceMesh> s;
  if (!surface.is_none()) {
    const py::tuple t = surface.cast<py::tuple>();
    s = to_surface(t[0], t[1], t[2], py::none());
  }
  ValidationReport r;
  std::string text;
  {
    py::gil_scoped_release release;
    r = validate_mesh(m, s ? &*s : nullptr);
    text = format_validation(r);
  }
  py::dict d;
  d["valid"] = r.ok();
  d["tets"] = r.tets;
  d["points"] = r.points;
  d["boundary_faces"] = r.boundary_faces;
  d["regions"] = r.regions;
  d["interface_faces"] = r.interface_faces;
  d["volume"] = r.volume;
  d["enclosed_volume"] = s ? py::object(py::float_(r.enclosed_volume)) : py::object(py::none());
  d["error_count"] = r.error_count;
  d["errors"] = r.errors;
  d["text"] = text;
  return d;
}

py::dict read_volume_py(const std::filesystem::path& path) {
  return volume_dict(value_or_raise(without_gil([&] { return read_volume(path); })));
}

void write_volume_py(const py::handle& points, const py::handle& tets, const py::handle& boundary,
                     const py::handle& boundary_ids, const py::handle& regions, const py::handle& names,
                     const py::handle& region_names, const std::filesystem::path& path, const py::handle& prisms,
                     const py::handle& pyramids) {
  const VolumeMesh m = to_volume(points, tets, boundary, boundary_ids, regions, names, region_names, prisms, pyramids);
  raise_unless_ok(without_gil([&] { return write_volume(m, path); }));
}

}  // namespace
}  // namespace pdrmesh::python

PYBIND11_MODULE(_pdrmesh, m) {
  using namespace pdrmesh::python;
  using py::arg;
  m.doc() = "pdrmesh's compiled core; use the package pdrmesh, which wraps it";
  // Opaque: made by layer_request, passed to mesh() and ServiceClient.submit().
  py::class_<pdrmesh::LayerRequest>(m, "LayerRequest");
  m.def("read_surface", &read_surface_py, arg("path"));
  m.def("write_surface", &write_surface_py, arg("points"), arg("triangles"), arg("surface_ids"), arg("names"),
        arg("path"));
  m.def("check", &check_py, arg("points"), arg("triangles"), arg("surface_ids"), arg("self_intersections"));
  m.def("mesh", &mesh_py, arg("points"), arg("triangles"), arg("surface_ids"), arg("names"), arg("size"),
        arg("hmin"), arg("hmax"), arg("growth"), arg("max_tets"), arg("workers"), arg("depth"), arg("kernel"),
        arg("optimize"), arg("time_limit"), arg("validate"), arg("farfield"), arg("farfield_shape"), arg("layers"));
  m.def("layer_request", &layer_request, arg("layers"), arg("first_height"), arg("reynolds"), arg("reference_length"),
        arg("growth_ratio"), arg("max_thickness"), arg("on"), arg("in"));
  m.def("quality", &quality_py, arg("points"), arg("tets"));
  m.def("min_dihedral", &min_dihedral_py, arg("points"), arg("tets"));
  m.def("validate", &validate_py, arg("points"), arg("tets"), arg("boundary"), arg("boundary_ids"), arg("regions"),
        arg("surface"), arg("prisms"), arg("pyramids"));
  m.def("read_volume", &read_volume_py, arg("path"));
  m.def("write_volume", &write_volume_py, arg("points"), arg("tets"), arg("boundary"), arg("boundary_ids"),
        arg("regions"), arg("names"), arg("region_names"), arg("path"), arg("prisms"), arg("pyramids"));
  bind_service(m);
}
