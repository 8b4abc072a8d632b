// SPDX-License-Identifier: AGPL-3.0-or-later
// Test certificates made with the openssl command line (tests skip where it is
// missing): a CA and one certificate it signs.
#pragma once

#include <fmt/format.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

namespace pdrmesh::server {

/// A CA and one certificate it signs for `names` (localhost and 127.0.0.1 by
/// default; openssl CLI); false when openssl fails.
inline bool make_certificates(const std::filesystem::path& dir, const std::string& name,
                              const std::string& names = "DNS:localhost,IP:127.0.0.1") {
  const std::string d = dir.string();
  std::ofstream(dir / "san.ext") << "subjectAltName=" << names << "\n";
  const std::string cmd = fmt::format(
      "cd '{0}' && openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes -keyout {1}-ca.key "
      "-out {1}-ca.pem -days 2 -subj /CN={1}-ca && "
      "openssl req -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes -keyout {1}.key -out {1}.csr "
      "-subj /CN=localhost && "
      "openssl x509 -req -in {1}.csr -CA {1}-ca.pem -CAkey {1}-ca.key -CAcreateserial -out {1}.pem -days 2 "
      "-extfile san.ext) >/dev/null 2>&1",
      d, name);
  return std::system(("(" + cmd).c_str()) == 0;
}

}  // namespace pdrmesh::server
