// SPDX-License-Identifier: AGPL-3.0-or-later
// Reading VTK XML UnstructuredGrid (.vtu) files (the layout is described in
// volume_io_vtu.cpp). Not a general XML parser: it finds the elements it
// needs by name. With appended data the XML ends where <AppendedData> begins,
// so binary bytes are never searched for markup.
#include <zlib.h>

#include <algorithm>
#include <optional>
#include <utility>
#include <vector>

#include "volume_io_detail.hpp"

namespace pdrmesh::volio {
namespace {

/// Bytes a String array of unknown length may decompress to.
constexpr std::uint64_t kMaxStringBytes = std::uint64_t{1} << 26;

/// The value of attribute `key` in an XML start tag, if present.
std::optional<std::string_view> attribute(std::string_view tag, std::string_view key) {
  std::size_t from = 0;
  while (true) {
    const std::size_t at = tag.find(key, from);
    if (at == std::string_view::npos) return std::nullopt;
    from = at + key.size();
    if (at == 0 || (tag[at - 1] != ' ' && tag[at - 1] != '\t' && tag[at - 1] != '\n' && tag[at - 1] != '\r'))
      continue;
    std::size_t p = from;
    while (p < tag.size() && (tag[p] == ' ' || tag[p] == '\t')) ++p;
    if (p >= tag.size() || tag[p] != '=') continue;
    ++p;
    while (p < tag.size() && (tag[p] == ' ' || tag[p] == '\t')) ++p;
    if (p >= tag.size() || (tag[p] != '"' && tag[p] != '\'')) continue;
    const char quote = tag[p];
    const std::size_t close = tag.find(quote, p + 1);
    if (close == std::string_view::npos) return std::nullopt;
    return tag.substr(p + 1, close - p - 1);
  }
}

/// Decodes base64, skipping whitespace. Padding ends a segment and a new one
/// may follow: VTK encodes an array's header and its data as two streams.
bool decode_base64(std::string_view text, std::string& out) {
  auto value = [](char c) -> int {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    if (c == '+') return 62;
    if (c == '/') return 63;
    return -1;
  };
  out.clear();
  out.reserve(text.size() / 4 * 3);
  int quad[4];
  int n = 0, pad = 0;
  for (char c : text) {
    if (c == ' ' || c == '\n' || c == '\r' || c == '\t') continue;
    if (c == '=') {
      if (n < 2) return false;
      ++pad;
      quad[n++] = 0;
    } else {
      if (pad > 0) return false;
      const int v = value(c);
      if (v < 0) return false;
      quad[n++] = v;
    }
    if (n == 4) {
      const std::uint32_t w = (static_cast<std::uint32_t>(quad[0]) << 18) | (static_cast<std::uint32_t>(quad[1]) << 12) |
                              (static_cast<std::uint32_t>(quad[2]) << 6) | static_cast<std::uint32_t>(quad[3]);
      out.push_back(static_cast<char>(w >> 16));
      if (pad < 2) out.push_back(static_cast<char>((w >> 8) & 0xff));
      if (pad < 1) out.push_back(static_cast<char>(w & 0xff));
      n = 0;
      pad = 0;
    }
  }
  return n == 0;
}

struct Element {
  std::size_t start = 0;  ///< position of '<'
  std::string_view tag;   ///< the start tag, '<' to '>'
  std::size_t content_begin = 0, content_end = 0;
};

/// A DataArray's type: bytes a value, and how to read one.
struct ValueType {
  int width = 0;
  bool is_float = false, is_signed = false;
};

std::optional<ValueType> value_type(std::string_view type) {
  if (type == "Int8" || type == "Char") return ValueType{1, false, true};
  if (type == "UInt8" || type == "String") return ValueType{1, false, false};
  if (type == "Int16") return ValueType{2, false, true};
  if (type == "UInt16") return ValueType{2, false, false};
  if (type == "Int32") return ValueType{4, false, true};
  if (type == "UInt32") return ValueType{4, false, false};
  if (type == "Int64" || type == "IdType") return ValueType{8, false, true};
  if (type == "UInt64") return ValueType{8, false, false};
  if (type == "Float32") return ValueType{4, true, true};
  if (type == "Float64") return ValueType{8, true, true};
  return std::nullopt;
}

class VtuReader {
 public:
  VtuReader(std::string_view text, const std::string& name) : text_(text), in_(text, name) {}

  Result<VolumeMesh> read();

 private:
  /// Finds the first element `<name` in [from, to); its content ends at `</name>`.
  Result<std::optional<Element>> find(std::string_view name, std::size_t from, std::size_t to);
  Result<std::size_t> attribute_count(const Element& e, std::string_view key);
  Status setup_binary(const Element& file);
  template <class T>
  Status parse_ascii(const Element& e, std::size_t n, std::vector<T>& out, std::string_view what);
  /// The decoded bytes of a binary or appended array; `expected` bytes when known.
  Status array_bytes(const Element& e, std::optional<std::uint64_t> expected, std::string& storage,
                     std::string_view& bytes, std::string_view what);
  Status unpack(std::string_view stream, std::optional<std::uint64_t> expected, std::string& storage,
                std::string_view& bytes, const Element& e, std::string_view what);
  /// unpack() of base64 text (a copy is made: the decoded text does not outlive the call).
  Status unpack_base64(std::string_view text, std::optional<std::uint64_t> expected, std::string& storage,
                       std::string_view& bytes, const Element& e, std::string_view what);
  template <class T>
  Status read_array(const Element& e, std::size_t n, std::vector<T>& out, std::string_view what);
  Status read_strings(const Element& e, std::size_t n, std::vector<std::string>& out);
  Result<std::optional<Element>> named_array(const Element& section, std::string_view name);
  Status read_field_data(std::size_t from, std::size_t to, VolumeMesh& mesh);
  Status error_in(const Element& e, std::string_view what, std::string_view message) const {
    return invalid_input(fmt::format("{}:{}: {} array '{}': {}", in_.name(), in_.line_at(e.start), what,
                                     attribute(e.tag, "Name").value_or(""), message));
  }

  std::string_view text_;
  TextScanner in_;
  std::size_t xml_end_ = 0;            ///< where <AppendedData> begins (or the text's end)
  std::size_t appended_begin_ = 0;     ///< first byte after the '_' marker
  std::size_t appended_end_ = 0;       ///< end of the appended data
  bool appended_ = false, appended_base64_ = false;
  std::vector<std::uint64_t> appended_offsets_;  ///< sorted, for base64 extents
  int header_bytes_ = 4;
  bool swap_ = false;
  std::optional<bool> zlib_;  ///< unset: a compressor we cannot read
  std::string compressor_;
};

Result<std::optional<Element>> VtuReader::find(std::string_view name, std::size_t from, std::size_t to) {
  std::size_t at = from;
  const std::string open = fmt::format("<{}", name);
  for (;;) {
    at = text_.find(open, at);
    if (at == std::string_view::npos || at >= to) return std::optional<Element>{};
    const char after = at + open.size() < text_.size() ? text_[at + open.size()] : '\0';
    if (after == ' ' || after == '>' || after == '/' || after == '\n' || after == '\t' || after == '\r') break;
    at += open.size();
  }
  const std::size_t close = text_.find('>', at);
  if (close == std::string_view::npos || close >= to)
    return in_.error_at(at, fmt::format("unterminated <{}> tag", name));
  Element e;
  e.start = at;
  e.tag = text_.substr(at, close + 1 - at);
  e.content_begin = close + 1;
  if (text_[close - 1] == '/') {
    e.content_end = e.content_begin;
  } else {
    const std::size_t end = text_.find(fmt::format("</{}>", name), e.content_begin);
    if (end == std::string_view::npos || end > to) return in_.error_at(at, fmt::format("<{}> is not closed", name));
    e.content_end = end;
  }
  return std::optional<Element>{e};
}

Result<std::size_t> VtuReader::attribute_count(const Element& e, std::string_view key) {
  const auto v = attribute(e.tag, key);
  if (!v) return in_.error_at(e.start, fmt::format("missing attribute {}", key));
  std::int64_t n = 0;
  const auto [p, ec] = std::from_chars(v->data(), v->data() + v->size(), n);
  if (ec != std::errc() || p != v->data() + v->size() || n < 0 || static_cast<std::uint64_t>(n) >= kNoIndex)
    return in_.error_at(e.start, fmt::format("attribute {}=\"{}\" is not a valid count", key, *v));
  return static_cast<std::size_t>(n);
}

/// Byte order, header width, compressor and the appended-data block.
Status VtuReader::setup_binary(const Element& file) {
  const std::string_view order = attribute(file.tag, "byte_order").value_or("LittleEndian");
  if (order != "LittleEndian" && order != "BigEndian")
    return in_.error_at(file.start, fmt::format("byte_order=\"{}\" is neither LittleEndian nor BigEndian", order));
  swap_ = (order == "BigEndian") == kHostLittle;
  const std::string_view header = attribute(file.tag, "header_type").value_or("UInt32");
  if (header != "UInt32" && header != "UInt64")
    return in_.error_at(file.start, fmt::format("header_type=\"{}\" is neither UInt32 nor UInt64", header));
  header_bytes_ = header == "UInt64" ? 8 : 4;
  const auto compressor = attribute(file.tag, "compressor");
  compressor_ = std::string(compressor.value_or(""));
  if (!compressor) zlib_ = false;
  else if (*compressor == "vtkZLibDataCompressor") zlib_ = true;

  const std::size_t at = text_.find("<AppendedData");
  if (at == std::string_view::npos || at < file.content_begin) {
    xml_end_ = text_.size();
    return {};
  }
  xml_end_ = at;
  const std::size_t close = text_.find('>', at);
  if (close == std::string_view::npos) return in_.error_at(at, "unterminated <AppendedData> tag");
  const std::string_view tag = text_.substr(at, close + 1 - at);
  const std::string_view encoding = attribute(tag, "encoding").value_or("");
  if (encoding != "raw" && encoding != "base64")
    return unsupported(fmt::format("{}:{}: AppendedData encoding=\"{}\"; raw and base64 are read", in_.name(),
                                   in_.line_at(at), encoding));
  const std::size_t mark = text_.find('_', close);
  if (mark == std::string_view::npos) return in_.error_at(at, "<AppendedData> has no '_' before its data");
  appended_ = true;
  appended_base64_ = encoding == "base64";
  appended_begin_ = mark + 1;
  appended_end_ = text_.size();
  if (appended_base64_) {
    appended_end_ = std::min(text_.size(), text_.find('<', appended_begin_));
    // Each array's base64 text runs to the next array's offset.
    for (std::size_t from = 0;;) {
      PDR_ASSIGN_OR_RETURN(const std::optional<Element> e, find("DataArray", from, xml_end_));
      if (!e) break;
      from = e->content_begin;
      if (attribute(e->tag, "format") != "appended") continue;
      std::uint64_t o = 0;
      const std::string_view v = attribute(e->tag, "offset").value_or("");
      if (std::from_chars(v.data(), v.data() + v.size(), o).ec == std::errc()) appended_offsets_.push_back(o);
    }
    std::sort(appended_offsets_.begin(), appended_offsets_.end());
  }
  return {};
}

template <class T>
Status VtuReader::parse_ascii(const Element& e, std::size_t n, std::vector<T>& out, std::string_view what) {
  // The values end where nested markup (VTK's <InformationKey>) begins.
  const std::size_t end = std::min(e.content_end, text_.find('<', e.content_begin));
  const std::size_t length = end - e.content_begin;
  if (static_cast<std::uint64_t>(n) * 2 > length + 1)
    return in_.error_at(e.start, fmt::format("{} needs {} values but holds only {} bytes", what, n, length));
  in_.set_range(e.content_begin, end);
  out.resize(n);
  for (T& v : out) {
    if constexpr (std::is_same_v<T, double>) {
      PDR_TRY(in_.real(v, what));
    } else {
      std::int64_t w = 0;
      PDR_TRY(in_.integer(w, what));
      if (!std::in_range<T>(w)) return in_.error(fmt::format("{} value {} is out of range", what, w));
      v = static_cast<T>(w);
    }
  }
  if (!in_.next().empty()) return in_.error(fmt::format("{} has more than the {} values expected", what, n));
  return {};
}

Status VtuReader::unpack(std::string_view stream, std::optional<std::uint64_t> expected, std::string& storage,
                         std::string_view& bytes, const Element& e, std::string_view what) {
  const std::size_t hb = static_cast<std::size_t>(header_bytes_);
  std::size_t at = 0;
  auto header = [&](std::uint64_t& v) -> bool {
    if (stream.size() - at < hb) return false;
    if (hb == 8) {
      std::memcpy(&v, stream.data() + at, 8);
      if (swap_) v = byteswap_value(v);
    } else {
      std::uint32_t w = 0;
      std::memcpy(&w, stream.data() + at, 4);
      v = swap_ ? byteswap_value(w) : w;
    }
    at += hb;
    return true;
  };
  if (!*zlib_) {
    std::uint64_t size = 0;
    if (!header(size)) return error_in(e, what, "the data ends inside its header");
    if (expected && size != *expected)
      return error_in(e, what, fmt::format("holds {} bytes, {} expected", size, *expected));
    if (size > stream.size() - at)
      return error_in(e, what, fmt::format("needs {} bytes but only {} remain", size, stream.size() - at));
    bytes = stream.substr(at, size);
    return {};
  }
  std::uint64_t blocks = 0, block = 0, last = 0;
  if (!header(blocks) || !header(block) || !header(last)) return error_in(e, what, "the data ends inside its header");
  if (blocks > (stream.size() - at) / hb)
    return error_in(e, what, fmt::format("{} compressed blocks are more than the data can hold", blocks));
  if (blocks > 0 && (block == 0 || last > block))
    return error_in(e, what, fmt::format("block size {} with last block {} is not valid", block, last));
  const std::uint64_t last_size = last == 0 ? block : last;
  if (blocks > 0 && block > (std::uint64_t{1} << 40))
    return error_in(e, what, fmt::format("block size {} is not plausible", block));
  const std::uint64_t total = blocks == 0 ? 0 : (blocks - 1) * block + last_size;
  if (expected ? total != *expected : total > kMaxStringBytes)
    return error_in(e, what, fmt::format("decompresses to {} bytes, {} expected", total,
                                         expected ? std::to_string(*expected) : "fewer"));
  std::vector<std::uint64_t> sizes(blocks);
  std::uint64_t packed = 0;
  for (std::uint64_t& s : sizes) {
    header(s);
    packed += s;
    if (s > stream.size()) return error_in(e, what, "a compressed block is longer than the file");
  }
  if (packed > stream.size() - at)
    return error_in(e, what, fmt::format("compressed blocks need {} bytes but only {} remain", packed, stream.size() - at));
  // zlib expands by at most about 1032 to 1: a larger claim is damage, found before allocating.
  if (total > 1040 * packed + 64)
    return error_in(e, what, fmt::format("{} compressed bytes cannot hold the {} bytes claimed", packed, total));
  storage.resize(total);
  for (std::uint64_t k = 0; k < blocks; ++k) {
    const std::uint64_t want = k + 1 == blocks ? last_size : block;
    uLongf got = static_cast<uLongf>(want);
    const int rc = uncompress(reinterpret_cast<Bytef*>(storage.data() + k * block), &got,
                              reinterpret_cast<const Bytef*>(stream.data() + at), static_cast<uLong>(sizes[k]));
    if (rc != Z_OK || got != want)
      return error_in(e, what, fmt::format("compressed block {} of {} is damaged (zlib: {})", k + 1, blocks,
                                           rc == Z_OK ? "wrong length" : zError(rc)));
    at += sizes[k];
  }
  bytes = storage;
  return {};
}

Status VtuReader::array_bytes(const Element& e, std::optional<std::uint64_t> expected, std::string& storage,
                              std::string_view& bytes, std::string_view what) {
  const std::string_view format = attribute(e.tag, "format").value_or("");
  if (!zlib_)
    return unsupported(fmt::format("{}:{}: compressor=\"{}\"; only vtkZLibDataCompressor (or none) is read",
                                   in_.name(), in_.line_at(e.start), compressor_));
  if (format == "binary") {
    const std::size_t end = std::min(e.content_end, text_.find('<', e.content_begin));
    return unpack_base64(text_.substr(e.content_begin, end - e.content_begin), expected, storage, bytes, e, what);
  }
  if (format != "appended")
    return unsupported(fmt::format("{}:{}: DataArray '{}' has format=\"{}\"; ascii, binary and appended are read",
                                   in_.name(), in_.line_at(e.start), attribute(e.tag, "Name").value_or(""), format));
  if (!appended_) return error_in(e, what, "format=\"appended\" but the file has no <AppendedData>");
  const std::string_view v = attribute(e.tag, "offset").value_or("");
  std::uint64_t offset = 0;
  const auto [p, ec] = std::from_chars(v.data(), v.data() + v.size(), offset);
  if (ec != std::errc() || p != v.data() + v.size())
    return error_in(e, what, fmt::format("offset=\"{}\" is not a number", v));
  const std::size_t region = appended_end_ - appended_begin_;
  if (offset > region) return error_in(e, what, fmt::format("offset {} lies beyond the appended data", offset));
  if (!appended_base64_) return unpack(text_.substr(appended_begin_ + offset, region - offset), expected, storage, bytes, e, what);
  const auto next = std::upper_bound(appended_offsets_.begin(), appended_offsets_.end(), offset);
  const std::size_t end = next == appended_offsets_.end() ? region : static_cast<std::size_t>(std::min<std::uint64_t>(*next, region));
  return unpack_base64(text_.substr(appended_begin_ + offset, end - offset), expected, storage, bytes, e, what);
}

Status VtuReader::unpack_base64(std::string_view text, std::optional<std::uint64_t> expected, std::string& storage,
                                std::string_view& bytes, const Element& e, std::string_view what) {
  std::string decoded;
  if (!decode_base64(text, decoded)) return error_in(e, what, "the base64 data is not valid");
  std::string_view out;
  PDR_TRY(unpack(decoded, expected, storage, out, e, what));
  if (!*zlib_) storage.assign(out);
  bytes = storage;
  return {};
}

/// One value of type `t` at `p` as T; false when it does not fit T.
template <class T>
bool convert_value(const char* p, ValueType t, bool swap, T& out) {
  auto load = [&](auto v) {
    std::memcpy(&v, p, sizeof(v));
    return swap ? byteswap_value(v) : v;
  };
  auto fits = [&](auto v) {
    if constexpr (std::is_same_v<T, double>) {
      out = static_cast<double>(v);
      return std::isfinite(out);
    } else if constexpr (std::is_floating_point_v<decltype(v)>) {
      return false;
    } else {
      if (!std::in_range<T>(v)) return false;
      out = static_cast<T>(v);
      return true;
    }
  };
  if (t.is_float) return t.width == 8 ? fits(load(double{})) : fits(load(float{}));
  switch (t.width) {
    case 1: return t.is_signed ? fits(load(std::int8_t{})) : fits(load(std::uint8_t{}));
    case 2: return t.is_signed ? fits(load(std::int16_t{})) : fits(load(std::uint16_t{}));
    case 4: return t.is_signed ? fits(load(std::int32_t{})) : fits(load(std::uint32_t{}));
    default: return t.is_signed ? fits(load(std::int64_t{})) : fits(load(std::uint64_t{}));
  }
}

template <class T>
Status VtuReader::read_array(const Element& e, std::size_t n, std::vector<T>& out, std::string_view what) {
  const std::string_view format = attribute(e.tag, "format").value_or("");
  if (format == "ascii") return parse_ascii(e, n, out, what);
  const std::string_view type_name = attribute(e.tag, "type").value_or("");
  const std::optional<ValueType> type = value_type(type_name);
  if (!type || type_name == "String")
    return unsupported(fmt::format("{}:{}: {} array has type=\"{}\"", in_.name(), in_.line_at(e.start), what, type_name));
  std::string storage;
  std::string_view bytes;
  PDR_TRY(array_bytes(e, static_cast<std::uint64_t>(n) * static_cast<std::uint64_t>(type->width), storage, bytes, what));
  out.resize(n);
  for (std::size_t i = 0; i < n; ++i)
    if (!convert_value(bytes.data() + i * static_cast<std::size_t>(type->width), *type, swap_, out[i]))
      return error_in(e, what, fmt::format("value {} is not finite or out of range for a {}", i, what));
  return {};
}

Status VtuReader::read_strings(const Element& e, std::size_t n, std::vector<std::string>& out) {
  std::string storage;
  std::string_view bytes;
  if (attribute(e.tag, "format") == "ascii") {
    const std::size_t end = std::min(e.content_end, text_.find('<', e.content_begin));
    in_.set_range(e.content_begin, end);
    for (std::string_view t = in_.next(); !t.empty(); t = in_.next()) {
      std::int64_t c = 0;
      PDR_TRY(in_.parse_integer(t, c, "character code"));
      if (c < 0 || c > 255) return in_.error(fmt::format("character code {} is out of range", c));
      storage.push_back(static_cast<char>(c));
    }
    bytes = storage;
  } else {
    std::string raw;
    PDR_TRY(array_bytes(e, std::nullopt, raw, bytes, "string"));
    storage.assign(bytes);
    bytes = storage;
  }
  out.clear();
  std::size_t from = 0;
  while (from < bytes.size() && out.size() < n) {
    const std::size_t zero = std::min(bytes.size(), bytes.find('\0', from));
    out.emplace_back(bytes.substr(from, zero - from));
    from = zero + 1;
  }
  if (out.size() != n) return error_in(e, "string", fmt::format("holds {} strings, {} expected", out.size(), n));
  return {};
}

Result<std::optional<Element>> VtuReader::named_array(const Element& section, std::string_view name) {
  std::size_t at = section.content_begin;
  for (;;) {
    PDR_ASSIGN_OR_RETURN(std::optional<Element> e, find("DataArray", at, section.content_end));
    if (!e) return std::optional<Element>{};
    if (attribute(e->tag, "Name") == name) return e;
    at = e->content_end;
  }
}

/// Boundary and region names from <FieldData>: `boundary_ids` and
/// `boundary_names` side by side, `region_ids` and `region_names` likewise.
Status VtuReader::read_field_data(std::size_t from, std::size_t to, VolumeMesh& mesh) {
  PDR_ASSIGN_OR_RETURN(const std::optional<Element> field, find("FieldData", from, to));
  if (!field) return {};
  for (const std::string what : {"boundary", "region"}) {
    PDR_ASSIGN_OR_RETURN(const std::optional<Element> ids_el, named_array(*field, what + "_ids"));
    PDR_ASSIGN_OR_RETURN(const std::optional<Element> names_el, named_array(*field, what + "_names"));
    if (!ids_el || !names_el) continue;
    PDR_ASSIGN_OR_RETURN(const std::size_t n, attribute_count(*ids_el, "NumberOfTuples"));
    std::vector<int> ids;
    std::vector<std::string> names;
    PDR_TRY(read_array(*ids_el, n, ids, (what + " id").c_str()));
    PDR_TRY(read_strings(*names_el, n, names));
    auto& map = what == "boundary" ? mesh.boundary_names : mesh.region_names;
    for (std::size_t i = 0; i < n; ++i) map[ids[i]] = std::move(names[i]);
  }
  return {};
}

Result<VolumeMesh> VtuReader::read() {
  // <VTKFile>: its content ends at </VTKFile>, or where appended data begins.
  const std::size_t at = text_.find("<VTKFile");
  const std::size_t close = at == std::string_view::npos ? at : text_.find('>', at);
  if (close == std::string_view::npos) return in_.error_at(0, "not a VTK XML file (no <VTKFile>)");
  Element file;
  file.start = at;
  file.tag = text_.substr(at, close + 1 - at);
  file.content_begin = close + 1;
  if (attribute(file.tag, "type") != "UnstructuredGrid")
    return unsupported(fmt::format("{}: VTKFile type=\"{}\"; only UnstructuredGrid is read", in_.name(),
                                   attribute(file.tag, "type").value_or("")));
  PDR_TRY(setup_binary(file));
  file.content_end = appended_ ? xml_end_ : text_.find("</VTKFile>", file.content_begin);
  if (file.content_end == std::string_view::npos) return in_.error_at(at, "<VTKFile> is not closed");

  PDR_ASSIGN_OR_RETURN(const std::optional<Element> piece, find("Piece", file.content_begin, file.content_end));
  if (!piece) return in_.error_at(file.start, "no <Piece>");
  PDR_ASSIGN_OR_RETURN(const std::optional<Element> second, find("Piece", piece->content_end, file.content_end));
  if (second) return unsupported(fmt::format("{}:{}: more than one <Piece>", in_.name(), in_.line_at(second->start)));
  PDR_ASSIGN_OR_RETURN(const std::size_t np, attribute_count(*piece, "NumberOfPoints"));
  PDR_ASSIGN_OR_RETURN(const std::size_t nc, attribute_count(*piece, "NumberOfCells"));

  VolumeMesh mesh;
  PDR_TRY(read_field_data(file.content_begin, piece->start, mesh));
  // Points: the first DataArray inside <Points>.
  PDR_ASSIGN_OR_RETURN(const std::optional<Element> points, find("Points", piece->content_begin, piece->content_end));
  if (!points) return in_.error_at(piece->start, "no <Points>");
  PDR_ASSIGN_OR_RETURN(const std::optional<Element> xyz, find("DataArray", points->content_begin, points->content_end));
  if (!xyz) return in_.error_at(points->start, "<Points> has no DataArray");
  if (attribute(xyz->tag, "NumberOfComponents") != "3")
    return in_.error_at(xyz->start, "points must have NumberOfComponents=\"3\"");
  std::vector<double> coords;
  PDR_TRY(read_array(*xyz, 3 * np, coords, "point coordinate"));
  mesh.points.resize(np);
  for (std::size_t i = 0; i < np; ++i) mesh.points[i] = {coords[3 * i], coords[3 * i + 1], coords[3 * i + 2]};
  coords = {};

  // Cells.
  PDR_ASSIGN_OR_RETURN(const std::optional<Element> cells, find("Cells", piece->content_begin, piece->content_end));
  if (!cells) return in_.error_at(piece->start, "no <Cells>");
  std::vector<std::int64_t> connectivity, offsets;
  std::vector<std::uint8_t> types;
  PDR_ASSIGN_OR_RETURN(const std::optional<Element> types_el, named_array(*cells, "types"));
  PDR_ASSIGN_OR_RETURN(const std::optional<Element> offsets_el, named_array(*cells, "offsets"));
  PDR_ASSIGN_OR_RETURN(const std::optional<Element> conn_el, named_array(*cells, "connectivity"));
  if (!types_el || !offsets_el || !conn_el)
    return in_.error_at(cells->start, "<Cells> needs DataArrays named connectivity, offsets and types");
  PDR_TRY(read_array(*types_el, nc, types, "cell type"));
  PDR_TRY(read_array(*offsets_el, nc, offsets, "cell offset"));
  std::int64_t previous = 0;
  for (std::size_t c = 0; c < nc; ++c) {
    const std::int64_t size = corners(types[c]);
    if (size < 0)
      return unsupported(fmt::format("{}:{}: cell {} has VTK type {}; tetrahedra (10), wedges (13), pyramids (14) "
                                     "and triangles (5) are read",
                                     in_.name(), in_.line_at(types_el->start), c, types[c]));
    if (offsets[c] != previous + size)
      return in_.error_at(offsets_el->start, fmt::format("cell {} (type {}) has offset {}, expected {}", c, types[c],
                                                         offsets[c], previous + size));
    previous = offsets[c];
  }
  PDR_TRY(read_array(*conn_el, static_cast<std::size_t>(previous), connectivity, "cell connectivity"));
  for (std::size_t k = 0; k < connectivity.size(); ++k)
    if (connectivity[k] < 0 || connectivity[k] >= static_cast<std::int64_t>(np))
      return in_.error_at(conn_el->start, fmt::format("connectivity entry {} is {}, out of range for {} points", k,
                                                      connectivity[k], np));

  // Cell data (optional).
  std::vector<std::int32_t> surface_id, region;
  bool have_region = false;
  PDR_ASSIGN_OR_RETURN(const std::optional<Element> cell_data,
                       find("CellData", piece->content_begin, piece->content_end));
  if (cell_data) {
    PDR_ASSIGN_OR_RETURN(const std::optional<Element> ids_el, named_array(*cell_data, "surface_id"));
    if (ids_el) PDR_TRY(read_array(*ids_el, nc, surface_id, "surface_id"));
    PDR_ASSIGN_OR_RETURN(const std::optional<Element> region_el, named_array(*cell_data, "region"));
    if (region_el) {
      PDR_TRY(read_array(*region_el, nc, region, "region"));
      have_region = true;
    }
  }

  // Cells in VTK's vertex order, which is ours (mixed_cells.hpp).
  std::size_t k = 0;
  const auto take = [&](auto& list) {
    auto& cell = list.emplace_back();
    for (Index& v : cell) v = static_cast<Index>(connectivity[k++]);
  };
  for (std::size_t c = 0; c < nc; ++c) {
    switch (types[c]) {
      case kVtkTetra:
        take(mesh.tets);
        if (have_region) mesh.tet_regions.push_back(region[c]);
        break;
      case kVtkWedge:
        take(mesh.prisms);
        if (have_region) mesh.prism_regions.push_back(region[c]);
        break;
      case kVtkPyramid:
        take(mesh.pyramids);
        if (have_region) mesh.pyramid_regions.push_back(region[c]);
        break;
      default:
        take(mesh.boundary);
        mesh.boundary_ids.push_back(surface_id.empty() ? 1 : surface_id[c]);
    }
  }
  return mesh;
}

}  // namespace

Result<VolumeMesh> read_vtu(std::string_view text, const std::string& name) { return VtuReader(text, name).read(); }

}  // namespace pdrmesh::volio
