// SPDX-License-Identifier: AGPL-3.0-or-later
// PLY reader: ascii, binary_little_endian and binary_big_endian 1.0.
#include <limits>
#include <optional>

#include "surface_io_internal.hpp"

namespace pdrmesh::surface_io_detail {
namespace {

enum class PlyType { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };
enum class PlyEncoding { kAscii, kLittleEndian, kBigEndian };

bool ply_type_from_name(std::string_view s, PlyType& t) {
  static constexpr std::pair<std::string_view, PlyType> kNames[] = {
      {"char", PlyType::kInt8},      {"int8", PlyType::kInt8},       {"uchar", PlyType::kUint8},
      {"uint8", PlyType::kUint8},    {"short", PlyType::kInt16},     {"int16", PlyType::kInt16},
      {"ushort", PlyType::kUint16},  {"uint16", PlyType::kUint16},   {"int", PlyType::kInt32},
      {"int32", PlyType::kInt32},    {"uint", PlyType::kUint32},     {"uint32", PlyType::kUint32},
      {"float", PlyType::kFloat32},  {"float32", PlyType::kFloat32}, {"double", PlyType::kFloat64},
      {"float64", PlyType::kFloat64}};
  for (const auto& [n, type] : kNames) {
    if (n == s) {
      t = type;
      return true;
    }
  }
  return false;
}

std::string_view ply_type_name(PlyType t) {
  switch (t) {
    case PlyType::kInt8: return "char";
    case PlyType::kUint8: return "uchar";
    case PlyType::kInt16: return "short";
    case PlyType::kUint16: return "ushort";
    case PlyType::kInt32: return "int";
    case PlyType::kUint32: return "uint";
    case PlyType::kFloat32: return "float";
    case PlyType::kFloat64: return "double";
  }
  return "?";
}

std::uint64_t ply_size(PlyType t) {
  switch (t) {
    case PlyType::kInt8:
    case PlyType::kUint8: return 1;
    case PlyType::kInt16:
    case PlyType::kUint16: return 2;
    case PlyType::kInt32:
    case PlyType::kUint32:
    case PlyType::kFloat32: return 4;
    case PlyType::kFloat64: return 8;
  }
  return 8;
}

template <class T>
bool in_range(std::int64_t v) {
  return v >= std::numeric_limits<T>::min() && v <= std::numeric_limits<T>::max();
}

/// Whether an integer read from ASCII fits the declared type.
bool fits(PlyType t, std::int64_t v) {
  switch (t) {
    case PlyType::kInt8: return in_range<std::int8_t>(v);
    case PlyType::kUint8: return in_range<std::uint8_t>(v);
    case PlyType::kInt16: return in_range<std::int16_t>(v);
    case PlyType::kUint16: return in_range<std::uint16_t>(v);
    case PlyType::kInt32: return in_range<std::int32_t>(v);
    case PlyType::kUint32: return in_range<std::uint32_t>(v);
    case PlyType::kFloat32:
    case PlyType::kFloat64: return true;
  }
  return false;
}

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::kFloat32;  ///< of the value, or of the list items
  bool list = false;
  PlyType count_type = PlyType::kUint8;
};

struct PlyElement {
  std::string name;
  std::uint64_t count = 0;
  std::vector<PlyProperty> props;
  std::size_t line = 0;  ///< header line, for messages
};

/// Where the values come from: the text cursor (ascii) or raw bytes (binary).
class PlyBody {
 public:
  PlyBody(TextCursor& c, std::string_view bytes, PlyEncoding enc)
      : c_(c), bytes_(bytes), pos_(c.offset()), enc_(enc) {}

  bool binary() const { return enc_ != PlyEncoding::kAscii; }
  std::uint64_t remaining() const { return binary() ? bytes_.size() - pos_ : c_.remaining(); }

  /// "file:line" or "file: byte N", plus the record being read.
  std::string where() const {
    const std::string record = fmt::format(" (element '{}' record {})", element_, record_ + 1);
    if (binary()) return fmt::format("{}: byte {}{}", c_.name(), pos_, record);
    return fmt::format("{}:{}{}", c_.name(), c_.line(), record);
  }
  void set_record(std::string_view element, std::uint64_t record) {
    element_ = element;
    record_ = record;
  }

  Status value(PlyType t, double& out) {
    if (!binary()) {
      const std::string_view tok = c_.token();
      if (t == PlyType::kFloat32 || t == PlyType::kFloat64) {
        if (!parse_double(tok, out)) return bad(tok, "a number");
        return {};
      }
      std::int64_t v = 0;
      if (!parse_int(tok, v) || !fits(t, v)) {
        return bad(tok, fmt::format("an integer of type {}", ply_type_name(t)));
      }
      out = static_cast<double>(v);
      return {};
    }
    const std::uint64_t size = ply_size(t);
    if (size > bytes_.size() - pos_) {
      return invalid_input(fmt::format("{}: file ends inside the record", where()));
    }
    const char* p = bytes_.data() + pos_;
    const bool big = enc_ == PlyEncoding::kBigEndian;
    switch (t) {
      case PlyType::kInt8: out = load_scalar<std::int8_t>(p, big); break;
      case PlyType::kUint8: out = load_scalar<std::uint8_t>(p, big); break;
      case PlyType::kInt16: out = load_scalar<std::int16_t>(p, big); break;
      case PlyType::kUint16: out = load_scalar<std::uint16_t>(p, big); break;
      case PlyType::kInt32: out = load_scalar<std::int32_t>(p, big); break;
      case PlyType::kUint32: out = load_scalar<std::uint32_t>(p, big); break;
      case PlyType::kFloat32: out = load_scalar<float>(p, big); break;
      case PlyType::kFloat64: out = load_scalar<double>(p, big); break;
    }
    pos_ += size;
    return {};
  }

  /// An integer value (list count, index, id); floats must hold an integer.
  Status integer(PlyType t, std::int64_t& out, std::string_view what) {
    double v = 0;
    PDR_TRY(value(t, v));
    if (!(v >= -9.0e15 && v <= 9.0e15) || v != std::floor(v)) {
      return invalid_input(fmt::format("{}: {} {} is not an integer", where(), what, v));
    }
    out = static_cast<std::int64_t>(v);
    return {};
  }

  bool at_end() { return binary() ? pos_ == bytes_.size() : c_.at_end(); }

 private:
  Status bad(std::string_view tok, std::string_view what) const {
    if (tok.empty())
      return invalid_input(fmt::format("{}: file ends where {} was expected", where(), what));
    return invalid_input(fmt::format("{}: expected {}, got {}", where(), what, quote_token(tok)));
  }

  TextCursor& c_;
  std::string_view bytes_;
  std::size_t pos_;
  PlyEncoding enc_;
  std::string_view element_;
  std::uint64_t record_ = 0;
};

struct PlyHeader {
  PlyEncoding encoding = PlyEncoding::kAscii;
  std::vector<PlyElement> elements;
};

Result<PlyHeader> parse_ply_header(TextCursor& c) {
  PlyHeader h;
  if (c.line_token() != "ply") return c.error("not a PLY file (the first line must be 'ply')");
  c.next_line();
  bool have_format = false;
  for (;;) {
    if (c.remaining() == 0) return c.error("file ends before 'end_header'");
    const std::string_view kw = c.line_token();
    if (kw == "end_header") {
      c.next_line();
      break;
    }
    if (kw == "format") {
      const std::string_view enc = c.line_token();
      if (enc == "ascii") {
        h.encoding = PlyEncoding::kAscii;
      } else if (enc == "binary_little_endian") {
        h.encoding = PlyEncoding::kLittleEndian;
      } else if (enc == "binary_big_endian") {
        h.encoding = PlyEncoding::kBigEndian;
      } else {
        return c.bad_token(enc, "ascii, binary_little_endian or binary_big_endian");
      }
      if (const std::string_view version = c.line_token(); version != "1.0") {
        return c.bad_token(version, "version 1.0");
      }
      have_format = true;
    } else if (kw == "element") {
      PlyElement e;
      e.name = std::string(c.line_token());
      if (e.name.empty()) return c.bad_token({}, "an element name");
      std::int64_t n = 0;
      PDR_TRY(c.read_int(n, "an element count", true));
      if (n < 0) return c.error(fmt::format("negative element count {}", n));
      e.count = static_cast<std::uint64_t>(n);
      e.line = c.line();
      h.elements.push_back(std::move(e));
    } else if (kw == "property") {
      if (h.elements.empty()) return c.error("property before any element");
      PlyProperty p;
      std::string_view type = c.line_token();
      if (type == "list") {
        p.list = true;
        const std::string_view count_type = c.line_token();
        if (!ply_type_from_name(count_type, p.count_type)) {
          return c.bad_token(count_type, "a PLY scalar type for the list count");
        }
        type = c.line_token();
      }
      if (!ply_type_from_name(type, p.type)) return c.bad_token(type, "a PLY scalar type");
      p.name = std::string(c.line_token());
      if (p.name.empty()) return c.bad_token({}, "a property name");
      h.elements.back().props.push_back(std::move(p));
    } else if (kw != "comment" && kw != "obj_info" && !kw.empty()) {
      return c.error(fmt::format("unknown PLY header keyword {}", quote_token(kw)));
    }
    c.next_line();
  }
  if (!have_format) return c.error("PLY header has no 'format' line");
  return h;
}

/// Position in `e` of the first property with one of `names` that is a list
/// (or a scalar, as `list` says).
std::optional<std::size_t> find_property(const PlyElement& e,
                                         std::initializer_list<std::string_view> names, bool list) {
  for (std::size_t i = 0; i < e.props.size(); ++i) {
    for (std::string_view n : names) {
      if (e.props[i].name == n && e.props[i].list == list) return i;
    }
  }
  return std::nullopt;
}

}  // namespace

Result<SurfaceMesh> parse_ply(std::string_view bytes, std::string_view name) {
  TextCursor c(bytes, name, '\0');
  PDR_ASSIGN_OR_RETURN(PlyHeader h, parse_ply_header(c));
  const auto where_element = [&](const PlyElement& e) {
    return fmt::format("{}:{}", name, e.line);
  };

  // The vertex and face elements and the positions of the properties we use.
  const PlyElement* vertex = nullptr;
  const PlyElement* face = nullptr;
  std::array<std::size_t, 3> xyz{};
  std::size_t indices = 0;
  std::optional<std::size_t> ids;
  for (const PlyElement& e : h.elements) {
    if (e.name == "vertex" && vertex == nullptr) {
      vertex = &e;
      for (std::size_t k = 0; k < 3; ++k) {
        const std::string_view axis = k == 0 ? "x" : k == 1 ? "y" : "z";
        const auto found = find_property(e, {axis}, false);
        if (!found) {
          return invalid_input(fmt::format("{}: element 'vertex' has no scalar property '{}'",
                                           where_element(e), axis));
        }
        xyz[k] = *found;
      }
    } else if (e.name == "face" && face == nullptr) {
      face = &e;
      const auto found = find_property(e, {"vertex_indices", "vertex_index"}, true);
      if (!found) {
        return invalid_input(fmt::format(
            "{}: element 'face' has no list property 'vertex_indices' or 'vertex_index'",
            where_element(e)));
      }
      indices = *found;
      ids = find_property(e, {"surface_id"}, false);
    }
  }
  const std::uint64_t nv = vertex != nullptr ? vertex->count : 0;

  SurfaceBuilder out(name, "face");
  PlyBody body(c, bytes, h.encoding);
  std::vector<double> values;
  std::vector<std::int64_t> polygon;
  for (const PlyElement& e : h.elements) {
    std::uint64_t min_bytes = 0;
    for (const PlyProperty& p : e.props) {
      min_bytes += body.binary() ? ply_size(p.list ? p.count_type : p.type) : 2;
    }
    PDR_TRY(check_count_fits(e.count, std::max<std::uint64_t>(min_bytes, 1), body.remaining() + 1,
                             where_element(e), fmt::format("element '{}' count", e.name)));
    if (&e == vertex) out.reserve(e.count, 0);
    if (&e == face) out.reserve(nv, e.count);
    values.resize(e.props.size());
    for (std::uint64_t r = 0; r < e.count; ++r) {
      body.set_record(e.name, r);
      for (std::size_t k = 0; k < e.props.size(); ++k) {
        const PlyProperty& p = e.props[k];
        if (!p.list) {
          PDR_TRY(body.value(p.type, values[k]));
          continue;
        }
        std::int64_t n = 0;
        PDR_TRY(body.integer(p.count_type, n, "list length"));
        if (n < 0)
          return invalid_input(fmt::format("{}: negative list length {}", body.where(), n));
        const bool keep = &e == face && k == indices;
        if (keep) polygon.clear();
        for (std::int64_t i = 0; i < n; ++i) {
          if (keep) {
            std::int64_t index = 0;
            PDR_TRY(body.integer(p.type, index, "point index"));
            polygon.push_back(index);
          } else {
            double ignored = 0;
            PDR_TRY(body.value(p.type, ignored));
          }
        }
      }
      if (&e == vertex) {
        const Vec3 pt{values[xyz[0]], values[xyz[1]], values[xyz[2]]};
        PDR_TRY(out.add_point(pt, [&] { return body.where(); }));
      } else if (&e == face) {
        const double id = ids ? values[*ids] : 1.0;
        if (!(id >= INT32_MIN && id <= INT32_MAX) || id != std::floor(id)) {
          return invalid_input(fmt::format("{}: surface_id {} is not an int", body.where(), id));
        }
        PDR_TRY(out.add_face(
            polygon, 0, static_cast<int>(id), [&] { return body.where(); }, nv));
      }
    }
  }
  if (!body.at_end()) {
    return invalid_input(fmt::format(
        "{}: unexpected data after the last element the header announced",
        body.binary() ? fmt::format("{}: byte {}", name, bytes.size() - body.remaining())
                      : fmt::format("{}:{}", name, c.line())));
  }
  return std::move(out).finish();
}

}  // namespace pdrmesh::surface_io_detail
