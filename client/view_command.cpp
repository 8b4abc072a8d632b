// SPDX-License-Identifier: AGPL-3.0-or-later
#include "view_command.hpp"

#include <fmt/format.h>

#include <charconv>
#include <cmath>
#include <fstream>
#include <memory>
#include <string>

#include "exit_codes.hpp"
#include "mesh_picture.hpp"
#include "options.hpp"
#include "pdrmesh/volume_io.hpp"

namespace pdrmesh::cli {
namespace {

/// "x", "y", "z", or one of them with "=VALUE" (a finite number).
bool parse_plane(const std::string& text, int& axis, std::optional<double>& at) {
  if (text.empty() || text[0] < 'x' || text[0] > 'z') return false;
  axis = text[0] - 'x';
  if (text.size() == 1) return true;
  if (text[1] != '=' || text.size() == 2) return false;
  double v = 0;
  const char* end = text.data() + text.size();
  const auto [p, ec] = std::from_chars(text.data() + 2, end, v);
  if (ec != std::errc() || p != end || !std::isfinite(v)) return false;
  at = v;
  return true;
}

std::string lower_suffix(const std::string& path) {
  std::string s = std::filesystem::path(path).extension().string();
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

int run_view(const std::string& mesh_path, const std::string& output, const std::string& plane, int width,
             int height, bool quiet) {
  picture::Options o;
  parse_plane(plane, o.axis, o.at);  // checked while parsing
  o.width = width;
  o.height = height;
  o.title = std::filesystem::path(mesh_path).filename().string();
  auto mesh = read_volume(mesh_path);
  auto report = [](const pdrmesh::Status& s) {
    fmt::print(stderr, "pdrmesh: error: {}\n", s.to_string());
    return cli::exit_code_for(s);  // not service_commands.cpp's gRPC overload (unity builds)
  };
  if (!mesh.ok()) return report(mesh.status());
  const picture::Format format = lower_suffix(output) == ".png" ? picture::Format::kPng : picture::Format::kSvg;
  auto pic = picture::draw(*mesh, o, format);
  if (!pic.ok()) return report(pdrmesh::Status(pic.status().code(), fmt::format("{}: {}", mesh_path, pic.status().message())));
  std::ofstream out(output, std::ios::binary);
  out.write(pic->bytes.data(), static_cast<std::streamsize>(pic->bytes.size()));
  out.close();
  if (!out) return report(io_error(fmt::format("{}: cannot write the file", output)));
  if (!quiet)
    fmt::print(stderr, "cut {} = {:.6g}: {} tets cut, {} boundary triangles behind; wrote {}\n",
               static_cast<char>('x' + o.axis), pic->at, pic->cut_tets, pic->boundary_drawn, output);
  return kExitOk;
}

}  // namespace

void add_view_command(CLI::App& app, int& exit_code) {
  auto* cmd = app.add_subcommand(
      "view", "Draw a cut through a volume mesh into an SVG or PNG picture: the tets the plane cuts coloured by "
              "their smallest dihedral angle, the boundary behind the plane shaded.");
  auto mesh = std::make_shared<std::string>();
  auto output = std::make_shared<std::string>();
  auto plane = std::make_shared<std::string>("z");
  auto width = std::make_shared<int>(960);
  auto height = std::make_shared<int>(720);
  auto quiet = std::make_shared<bool>(false);
  cmd->add_option("MESH", *mesh, fmt::format("volume mesh ({})", volume_format_suffixes()))->required();
  cmd->add_option("-o,--output", *output, "the picture: .svg or .png")
      ->required()
      ->check(output_check(OutputKind::kFile))
      ->check(CLI::Validator(
          [](std::string& path) -> std::string {
            const std::string s = lower_suffix(path);
            return s == ".svg" || s == ".png" ? std::string()
                                              : fmt::format("must end in .svg or .png, got '{}'", path);
          },
          "PICTURE"));
  cmd->add_option("--plane", *plane,
                  "the cut: x, y or z (through the centre of the mesh's bounding box) or AXIS=VALUE (say z=0.25)")
      ->check(CLI::Validator(
          [](std::string& text) -> std::string {
            int axis = 0;
            std::optional<double> at;
            return parse_plane(text, axis, at) ? std::string()
                                               : fmt::format("must be x, y, z or AXIS=VALUE (z=0.25), got '{}'", text);
          },
          "x|y|z[=VALUE]"))
      ->capture_default_str();
  add_number(cmd, "--width", *width, "picture width in pixels", kPixels)->capture_default_str();
  add_number(cmd, "--height", *height, "picture height in pixels", kPixels)->capture_default_str();
  cmd->add_flag("-q,--quiet", *quiet, "no summary on stderr");
  cmd->footer(help_footer({{"pdrmesh view part.vtu -o cut.png", "a cut normal to z through the middle"},
                           {"pdrmesh view part.msh -o cut.svg --plane x=0.25", "the cut x = 0.25, as SVG"}}));
  cmd->callback([&exit_code, mesh, output, plane, width, height, quiet] {
    exit_code = run_view(*mesh, *output, *plane, *width, *height, *quiet);
  });
}

}  // namespace pdrmesh::cli
