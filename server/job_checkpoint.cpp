// SPDX-License-Identifier: AGPL-3.0-or-later
// JobCheckpoint: a job's round checkpoint on disk.
#include "job_checkpoint.hpp"

#include <spdlog/spdlog.h>

#include <array>
#include <cstring>
#include <fstream>
#include <iterator>
#include <system_error>
#include <utility>

#include "job_runner.hpp"
#include "pdrmesh/digest.hpp"

namespace pdrmesh::server {
namespace {

constexpr std::array<char, 8> kMagic = {'P', 'D', 'R', 'J', 'O', 'B', 'C', 'K'};
constexpr std::size_t kHeaderBytes = kMagic.size() + 8;

std::array<char, 8> little_endian(std::uint64_t v) {
  std::array<char, 8> b{};
  for (std::size_t i = 0; i < 8; ++i) b[i] = static_cast<char>((v >> (8 * i)) & 0xffu);
  return b;
}

}  // namespace

std::uint64_t executable_digest() {
  static const std::uint64_t digest = [] {
    std::ifstream in("/proc/self/exe", std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (!in || bytes.empty()) {
      spdlog::warn("cannot read this executable: job checkpoints are keyed by the version alone");
      return std::uint64_t{0};
    }
    return content_digest(bytes);
  }();
  return digest;
}

JobCheckpoint::JobCheckpoint(std::filesystem::path file, std::string_view key)
    : file_(std::move(file)), key_digest_(content_digest(key)) {}

std::optional<PdrCheckpoint> JobCheckpoint::load() const {
  std::ifstream in(file_, std::ios::binary);
  if (!in) return std::nullopt;
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::array<char, 8> key = little_endian(key_digest_);
  std::string why;
  if (in.bad()) {
    why = "it cannot be read";
  } else if (bytes.size() < kHeaderBytes || std::memcmp(bytes.data(), kMagic.data(), kMagic.size()) != 0) {
    why = "it is not a job checkpoint";
  } else if (std::memcmp(bytes.data() + kMagic.size(), key.data(), key.size()) != 0) {
    why = "it was written for another version, options or input";
  } else {
    Result<PdrCheckpoint> c = PdrCheckpoint::decode(std::string_view(bytes).substr(kHeaderBytes));
    if (c.ok()) return std::move(c).value();
    why = c.status().message();
  }
  spdlog::warn("{}: not used, the job runs from the start: {}", file_.string(), why);
  remove();
  return std::nullopt;
}

Status JobCheckpoint::store(const PdrCheckpoint& checkpoint) const {
  const std::array<char, 8> key = little_endian(key_digest_);
  return write_file_atomically(file_, {std::string_view(kMagic.data(), kMagic.size()),
                                       std::string_view(key.data(), key.size()), checkpoint.encode()});
}

void JobCheckpoint::remove() const {
  std::error_code ec;
  std::filesystem::remove(file_, ec);
  if (ec) spdlog::warn("{}: cannot remove: {}", file_.string(), ec.message());
}

}  // namespace pdrmesh::server
