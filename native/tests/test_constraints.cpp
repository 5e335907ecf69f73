// The constraint rules of arap/constraints.h, shared by the command line,
// the Python module and the Blender add-on: fixed wins, the first handle
// wins, and each warning names the group that took the vertices.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "arap/constraints.h"
#include "arap/errors.h"

namespace {

using arap::ConstraintGroup;

arap::ErrorCode error_of(int n, const ConstraintGroup& fixed, const std::vector<ConstraintGroup>& handles) {
  try {
    arap::make_constraint_set(n, fixed, handles);
  } catch (const arap::Error& e) {
    return e.code();
  }
  ADD_FAILURE() << "no error";
  return arap::ErrorCode::InvalidInput;
}

TEST(Constraints, FixedFirstThenEachHandleRepeatsCountOnce) {
  const auto set = arap::make_constraint_set(10, {"the fixed group 'F'", {4, 2, 4}},
                                             {{"handle 'A'", {7, 8, 7}}, {"handle 'B'", {0}}});
  EXPECT_EQ(set.constrained, (std::vector<int>{4, 2, 7, 8, 0}));
  EXPECT_EQ(set.fixed_count, 2);
  ASSERT_EQ(set.handles.size(), 2u);
  EXPECT_EQ(set.handles[0].handle, 0);
  EXPECT_EQ(set.handles[0].start, 2);
  EXPECT_EQ(set.handles[0].stop, 4);
  EXPECT_EQ(set.handles[1].handle, 1);
  EXPECT_EQ(set.handles[1].start, 4);
  EXPECT_EQ(set.handles[1].stop, 5);
  EXPECT_TRUE(set.warnings.empty());
}

TEST(Constraints, AVertexFixedAndInAHandleStaysFixed) {
  const auto set =
      arap::make_constraint_set(6, {"the fixed group 'Feet'", {0, 1}}, {{"handle 'Hand'", {1, 2, 3}}});
  EXPECT_EQ(set.constrained, (std::vector<int>{0, 1, 2, 3}));
  EXPECT_EQ(set.fixed_count, 2);
  ASSERT_EQ(set.warnings.size(), 1u);
  EXPECT_EQ(set.warnings[0], "Handle 'Hand': 1 of its vertices are also in the fixed group 'Feet' and stay fixed");
}

TEST(Constraints, AVertexInTwoHandlesFollowsTheFirstAndTheWarningNamesIt) {
  const auto set = arap::make_constraint_set(
      8, {"the fixed group 'F'", {0}},
      {{"handle 'A'", {1, 2}}, {"handle 'B'", {2, 3}}, {"handle 'C'", {0, 1, 3, 4, 5}}});
  EXPECT_EQ(set.constrained, (std::vector<int>{0, 1, 2, 3, 4, 5}));
  ASSERT_EQ(set.handles.size(), 3u);
  EXPECT_EQ(set.handles[1].start, 3);  // B keeps only vertex 3
  EXPECT_EQ(set.handles[1].stop, 4);
  EXPECT_EQ(set.handles[2].start, 4);  // C keeps 4 and 5
  // One warning per group that took vertices, naming it (never "the fixed group" for a handle's).
  EXPECT_EQ(set.warnings, (std::vector<std::string>{
                              "Handle 'B': 1 of its vertices are also in handle 'A' and follow that one",
                              "Handle 'C': 1 of its vertices are also in the fixed group 'F' and stay fixed",
                              "Handle 'C': 1 of its vertices are also in handle 'A' and follow that one",
                              "Handle 'C': 1 of its vertices are also in handle 'B' and follow that one",
                          }));
}

TEST(Constraints, AHandleWithNoVertexOfItsOwnIsIgnored) {
  const auto set = arap::make_constraint_set(4, {"the fixed list", {}}, {{"handle 0", {1, 2}}, {"handle 1", {2, 1}}});
  EXPECT_EQ(set.constrained, (std::vector<int>{1, 2}));
  ASSERT_EQ(set.handles.size(), 1u);
  EXPECT_EQ(set.handles[0].handle, 0);
  EXPECT_EQ(set.warnings, (std::vector<std::string>{
                              "Handle 1: 2 of its vertices are also in handle 0 and follow that one",
                              "Handle 1 has no vertices of its own: ignored",
                          }));
}

TEST(Constraints, BadIndicesAndNothingConstrainedAreTypedErrors) {
  EXPECT_EQ(error_of(3, {"the fixed list", {3}}, {}), arap::ErrorCode::IndexOutOfRange);
  EXPECT_EQ(error_of(3, {"the fixed list", {}}, {{"handle 0", {-1}}}), arap::ErrorCode::IndexOutOfRange);
  EXPECT_EQ(error_of(3, {"the fixed list", {}}, {}), arap::ErrorCode::NoConstraints);
  EXPECT_EQ(error_of(3, {"the fixed list", {}}, {{"handle 0", {}}}), arap::ErrorCode::NoConstraints);
  EXPECT_EQ(error_of(-1, {"the fixed list", {}}, {}), arap::ErrorCode::InvalidInput);
  try {
    arap::make_constraint_set(3, {"the fixed list", {}}, {{"handle 'Arm'", {5}}});
  } catch (const arap::Error& e) {
    EXPECT_STREQ(e.what(), "Handle 'Arm' refers to vertex 5, outside [0, 3)");
  }
}

TEST(Constraints, TargetsAreRestForFixedAndTheHandlesTransformOtherwise) {
  arap::Points rest(4, 3);
  rest << 0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 1;
  const auto set = arap::make_constraint_set(4, {"the fixed list", {0}}, {{"handle 0", {3, 1}}, {"handle 1", {1}}});
  Eigen::Affine3d turn(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()));
  turn.translation() << 0, 0, 2;
  const arap::Points t = arap::constraint_targets(set, rest, {turn.matrix(), Eigen::Matrix4d::Identity()});
  ASSERT_EQ(t.rows(), 3);
  EXPECT_EQ(t.row(0), rest.row(0));
  EXPECT_TRUE(t.row(1).isApprox(Eigen::RowVector3d(-1, 1, 3)));
  EXPECT_TRUE(t.row(2).isApprox(Eigen::RowVector3d(0, 1, 2)));  // vertex 1 follows handle 0
  Eigen::Matrix4d bad = Eigen::Matrix4d::Identity();
  bad(0, 3) = std::numeric_limits<double>::infinity();
  try {
    arap::constraint_targets(set, rest, {bad, Eigen::Matrix4d::Identity()});
    FAIL();
  } catch (const arap::Error& e) {
    EXPECT_EQ(e.code(), arap::ErrorCode::NonFinite);
    EXPECT_NE(std::string(e.what()).find("Handle 0 moves vertex 3"), std::string::npos) << e.what();
  }
  EXPECT_THROW(arap::constraint_targets(set, rest, {}), arap::Error);  // no transform for handle 0
}

}  // namespace
