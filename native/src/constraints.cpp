#include "arap/constraints.h"

#include <algorithm>
#include <cctype>

#include "arap/errors.h"

namespace arap {

namespace {

// "handle 'A'" -> "Handle 'A'" at the start of a sentence.
std::string capitalised(std::string s) {
  if (!s.empty()) s[0] = static_cast<char>(std::toupper(static_cast<unsigned char>(s[0])));
  return s;
}

constexpr int kFixed = -1;  // owner of a fixed vertex
constexpr int kFree = -2;   // owner of a vertex no group took

}  // namespace

ConstraintSet make_constraint_set(int vertex_count, const ConstraintGroup& fixed,
                                  const std::vector<ConstraintGroup>& handles) {
  auto check = [vertex_count](int v, const ConstraintGroup& group) {
    if (v < 0 || v >= vertex_count)
      throw Error(ErrorCode::IndexOutOfRange, capitalised(group.label) + " refers to vertex " + std::to_string(v) +
                                                  ", outside [0, " + std::to_string(vertex_count) + ")");
  };
  if (vertex_count < 0) throw Error(ErrorCode::InvalidInput, "negative vertex count");
  ConstraintSet set;
  std::vector<int> owner(vertex_count, kFree);
  for (int v : fixed.vertices) {
    check(v, fixed);
    if (owner[v] == kFixed) continue;
    owner[v] = kFixed;
    set.constrained.push_back(v);
  }
  set.fixed_count = static_cast<int>(set.constrained.size());
  const int groups = static_cast<int>(handles.size());
  std::vector<int> lost(groups + 1);  // vertices this handle lost to the fixed group (slot 0) or handle k (slot k + 1)
  for (int h = 0; h < groups; ++h) {
    const ConstraintGroup& group = handles[h];
    std::fill(lost.begin(), lost.end(), 0);
    HandleBlock block{h, static_cast<int>(set.constrained.size()), 0, group.label};
    for (int v : group.vertices) {
      check(v, group);
      if (owner[v] == kFree) {
        owner[v] = h;
        set.constrained.push_back(v);
      } else if (owner[v] != h) {
        ++lost[owner[v] + 1];
      }
    }
    block.stop = static_cast<int>(set.constrained.size());
    const std::string who = capitalised(group.label) + ": ";
    if (lost[0] > 0)
      set.warnings.push_back(who + std::to_string(lost[0]) + " of its vertices are also in " + fixed.label +
                             " and stay fixed");
    for (int k = 0; k < h; ++k)
      if (lost[k + 1] > 0)
        set.warnings.push_back(who + std::to_string(lost[k + 1]) + " of its vertices are also in " +
                               handles[k].label + " and follow that one");
    if (block.stop == block.start)
      set.warnings.push_back(capitalised(group.label) + " has no vertices of its own: ignored");
    else
      set.handles.push_back(block);
  }
  if (set.constrained.empty())
    throw Error(ErrorCode::NoConstraints, "no fixed or handle vertex: nothing holds the mesh");
  return set;
}

Points constraint_targets(const ConstraintSet& set, const Eigen::Ref<const Points>& rest,
                          const std::vector<Eigen::Matrix4d>& handle_transforms) {
  Points targets(static_cast<Eigen::Index>(set.constrained.size()), 3);
  for (int v : set.constrained)
    if (v < 0 || v >= rest.rows()) throw Error(ErrorCode::IndexOutOfRange, "the constraint set is for a larger mesh");
  for (int r = 0; r < set.fixed_count; ++r) targets.row(r) = rest.row(set.constrained[r]);
  for (const HandleBlock& b : set.handles) {
    if (b.handle < 0 || b.handle >= static_cast<int>(handle_transforms.size()))
      throw Error(ErrorCode::InvalidInput, "no transform for handle " + std::to_string(b.handle));
    const Eigen::Matrix4d& m = handle_transforms[b.handle];
    for (int r = b.start; r < b.stop; ++r) {
      const int v = set.constrained[r];
      const Eigen::Vector3d t = m.topLeftCorner<3, 3>() * rest.row(v).transpose() + m.topRightCorner<3, 1>();
      if (!t.allFinite())
        throw Error(ErrorCode::NonFinite,
                    capitalised(b.label) + " moves vertex " + std::to_string(v) + " to a non-finite position");
      targets.row(r) = t.transpose();
    }
  }
  return targets;
}

std::string group_label_of(const ConstraintSet& set, int vertex) {
  const auto at = std::find(set.constrained.begin(), set.constrained.end(), vertex);
  if (at == set.constrained.end()) return "";
  const int slot = static_cast<int>(at - set.constrained.begin());
  if (slot < set.fixed_count) return "the fixed vertices";
  for (const HandleBlock& b : set.handles)
    if (slot >= b.start && slot < b.stop) return b.label;
  return "";
}

}  // namespace arap
