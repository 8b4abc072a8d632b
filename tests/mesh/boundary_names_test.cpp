// SPDX-License-Identifier: AGPL-3.0-or-later
// Tests of the boundary name rules: what a name may be, how a foreign name is
// made one, and the checks of a name map against a mesh's ids.
#include "pdrmesh/boundary_names.hpp"

#include <gtest/gtest.h>

#include "pdrmesh/volume_mesh.hpp"

namespace pdrmesh {
namespace {

TEST(BoundaryName, UnnamedIdsAreSurfaceAndTheirId) {
  const std::map<int, std::string> names{{2, "inlet"}};
  EXPECT_EQ(boundary_name(names, 2), "inlet");
  EXPECT_EQ(boundary_name(names, 3), "surface_3");
  EXPECT_EQ(boundary_name(names, -4), "surface_-4");
}

TEST(BoundaryName, AcceptsIdentifiersEveryFormatTakes) {
  for (const char* ok : {"inlet", "_x", "Wing.upper-2", "a", "surface_7", "surface_x"})
    EXPECT_TRUE(check_boundary_name(7, ok).ok()) << ok << ": " << check_boundary_name(7, ok).to_string();
  const std::pair<std::string, std::string> bad[] = {
      {"", "empty"},
      {"two words", "has the character ' '"},
      {"a/b", "has the character '/'"},
      {"3d", "starts with '3'"},
      {"-x", "starts with '-'"},
      {std::string(33, 'a'), "33 characters long; a boundary name has at most 32"},
      {"surface_4", "is the name of the unnamed surface id 4, not of id 7"}};
  for (const auto& [name, why] : bad) {
    const Status s = check_boundary_name(7, name);
    ASSERT_FALSE(s.ok()) << name;
    EXPECT_NE(s.message().find(why), std::string::npos) << s.to_string();
  }
  EXPECT_TRUE(is_default_boundary_name(4, "surface_4"));
  EXPECT_FALSE(is_default_boundary_name(4, "surface_04"));
  EXPECT_FALSE(is_default_boundary_name(4, "surface_5"));
}

TEST(BoundaryName, SanitizeMakesAnyTextAName) {
  EXPECT_EQ(sanitize_boundary_name("  front wall\t"), "front_wall");
  EXPECT_EQ(sanitize_boundary_name("1st"), "_1st");
  EXPECT_EQ(sanitize_boundary_name(".hidden"), "_.hidden");
  EXPECT_EQ(sanitize_boundary_name("caf\xc3\xa9"), "caf__");
  EXPECT_EQ(sanitize_boundary_name(std::string(50, 'z')), std::string(32, 'z'));
  EXPECT_EQ(sanitize_boundary_name(" \t "), "");
  for (const char* raw : {"a b", "9", "x/y:z", "\x01"}) {
    const std::string name = sanitize_boundary_name(raw);
    EXPECT_TRUE(check_boundary_name(1, name).ok()) << raw << " -> " << name;
  }
}

TEST(BoundaryName, MergeChecksIdsAndNamesAgainstTheMesh) {
  const std::vector<int> ids{1, 1, 2, 5, 5};
  std::map<int, std::string> names{{1, "wall"}};
  ASSERT_TRUE(merge_boundary_names(names, ids, {{2, "inlet"}, {5, "outlet"}}, "n.txt").ok());
  EXPECT_EQ(names, (std::map<int, std::string>{{1, "wall"}, {2, "inlet"}, {5, "outlet"}}));
  // A given name replaces the id's name; the id's default name removes it.
  ASSERT_TRUE(merge_boundary_names(names, ids, {{1, "body"}, {5, "surface_5"}}, "n.txt").ok());
  EXPECT_EQ(names, (std::map<int, std::string>{{1, "body"}, {2, "inlet"}}));

  const Status unknown = merge_boundary_names(names, ids, {{3, "x"}}, "n.txt");
  EXPECT_NE(unknown.message().find("n.txt: id 3 ('x') is not a surface id here (the ids are 1, 2, 5)"),
            std::string::npos)
      << unknown.to_string();
  const Status twice = merge_boundary_names(names, ids, {{5, "inlet"}}, "n.txt");
  EXPECT_NE(twice.message().find("ids 2 and 5 are both named 'inlet'"), std::string::npos) << twice.to_string();
  EXPECT_EQ(names, (std::map<int, std::string>{{1, "body"}, {2, "inlet"}})) << "unchanged after an error";
  const Status bad = merge_boundary_names(names, ids, {{5, "no good"}}, "n.txt");
  EXPECT_NE(bad.message().find("n.txt: id 5: 'no good' has the character ' '"), std::string::npos) << bad.to_string();
}

}  // namespace
}  // namespace pdrmesh
