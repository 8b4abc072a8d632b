// SPDX-License-Identifier: AGPL-3.0-or-later
// Tests of the boundary names file (--names): its lines, its errors with
// file:line, and a round trip through format_boundary_names.
#include "pdrmesh/boundary_names_io.hpp"

#include <gtest/gtest.h>

namespace pdrmesh {
namespace {

TEST(BoundaryNamesFile, ReadsIdNameLinesWithCommentsAndBlankLines) {
  const auto r = parse_boundary_names("# id name\n1 inlet\n\n  2\toutlet   # the back\n-3 wing.upper\r\n", "n.txt");
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  const std::map<int, std::string> want{{1, "inlet"}, {2, "outlet"}, {-3, "wing.upper"}};
  EXPECT_EQ(*r, want);
  const auto back = parse_boundary_names(format_boundary_names(want), "again");
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(*back, want);
  EXPECT_TRUE(parse_boundary_names("", "empty")->empty());
}

TEST(BoundaryNamesFile, ErrorsNameTheFileAndLine) {
  const std::pair<const char*, const char*> bad[] = {
      {"1 a\nx b\n", "n.txt:2: expected 'ID NAME' with an integer id, got 'x'"},
      {"1 a\n\n2\n", "n.txt:3: id 2 has no name"},
      {"1 front wall\n", "n.txt:1: unexpected 'wall' after the name 'front'"},
      {"1 a\n2 3d\n", "n.txt:2: '3d' starts with '3'"},
      {"1 a\n2 b\n1 c\n", "n.txt:3: id 1 is named again (first on line 1)"},
      {"1 a\n2 b\n3 a\n", "n.txt:3: 'a' names id 3 here and id 1 on line 1"},
      {"1 surface_2\n", "n.txt:1: 'surface_2' is the name of the unnamed surface id 2, not of id 1"},
      {"99999999999 a\n", "n.txt:1: expected 'ID NAME' with an integer id"}};
  for (const auto& [text, why] : bad) {
    const auto r = parse_boundary_names(text, "n.txt");
    ASSERT_FALSE(r.ok()) << text;
    EXPECT_EQ(r.status().code(), StatusCode::kInvalidInput);
    EXPECT_NE(r.status().message().find(why), std::string::npos) << r.status().to_string();
  }
  EXPECT_EQ(read_boundary_names("/nonexistent/names.txt").status().code(), StatusCode::kNotFound);
}

}  // namespace
}  // namespace pdrmesh
