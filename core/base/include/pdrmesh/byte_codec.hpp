// SPDX-License-Identifier: AGPL-3.0-or-later
// Explicit little-endian byte codec for the kernel's binary exchange formats
// (sizing field, leaf tasks): bit-exact doubles, counts checked against the
// bytes that are left, so a lying header is refused before anything is reserved.
#pragma once

#include <algorithm>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <utility>

namespace pdrmesh::codec {

class Writer {
 public:
  void bytes(const char* p, std::size_t n) { s_.append(p, n); }
  /// Writes an unsigned integer as sizeof(U) bytes, little-endian.
  template <class U>
  void uint(U v) {
    for (std::size_t i = 0; i < sizeof(U); ++i) s_.push_back(static_cast<char>((v >> (8 * i)) & 0xffu));
  }
  void u32(std::uint32_t v) { uint(v); }
  void u64(std::uint64_t v) { uint(v); }
  void f64(double v) { u64(std::bit_cast<std::uint64_t>(v)); }
  std::string take() { return std::move(s_); }

 private:
  std::string s_;
};

class Reader {
 public:
  explicit Reader(std::string_view s) : s_(s) {}
  std::size_t left() const { return s_.size() - pos_; }
  bool bytes(char* out, std::size_t n) {
    if (left() < n) return false;
    std::copy_n(s_.data() + pos_, n, out);
    pos_ += n;
    return true;
  }
  /// Reads an unsigned integer of sizeof(U) bytes, little-endian.
  template <class U>
  bool uint(U& v) {
    if (left() < sizeof(U)) return false;
    v = 0;
    for (std::size_t i = 0; i < sizeof(U); ++i) v |= U(static_cast<unsigned char>(s_[pos_ + i])) << (8 * i);
    pos_ += sizeof(U);
    return true;
  }
  bool u64(std::uint64_t& v) { return uint(v); }
  bool u32(std::uint32_t& v) { return uint(v); }
  bool f64(double& v) {
    std::uint64_t u = 0;
    if (!u64(u)) return false;
    v = std::bit_cast<double>(u);
    return true;
  }
  /// Reads a count of items of `item_bytes` each, refusing counts the rest of
  /// the buffer cannot hold.
  bool count(std::size_t item_bytes, std::size_t& n) {
    std::uint64_t v = 0;
    if (!u64(v) || v > left() / item_bytes) return false;
    n = static_cast<std::size_t>(v);
    return true;
  }

 private:
  std::string_view s_;
  std::size_t pos_ = 0;
};

}  // namespace pdrmesh::codec
