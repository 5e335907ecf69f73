#include "contact/handle_moves.h"

#include <Eigen/Geometry>

#include "arap/rotation_fit.h"
#include "union_find.h"

namespace arap::contact {

void HandleMoves::bind(const std::vector<int>& constrained, int slots, const Triangles& triangles, int vertex_count) {
  constrained_.assign(constrained.begin(), constrained.begin() + slots);
  std::vector<int> slot_of(vertex_count, -1);
  for (int s = 0; s < slots; ++s) slot_of[constrained_[s]] = s;
  edges_.clear();
  for (Eigen::Index f = 0; f < triangles.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = slot_of[triangles(f, k)], b = slot_of[triangles(f, (k + 1) % 3)];
      if (a >= 0 && b >= 0) edges_.push_back(a), edges_.push_back(b);  // an edge of two triangles twice: harmless
    }
}

void HandleMoves::toward(const Points& state, const Points& targets, double share, Points& goal) const {
  const int slots = static_cast<int>(constrained_.size());
  UnionFind joined(slots);
  for (size_t e = 0; e < edges_.size(); e += 2) {
    const int a = edges_[e], b = edges_[e + 1];
    const Eigen::RowVector3d xa = state.row(constrained_[a]), xb = state.row(constrained_[b]);
    if (((targets.row(a) - xa) - (targets.row(b) - xb)).norm() <= 2 * (xa - xb).norm()) joined.join(a, b);
  }
  std::vector<int> part_of;
  std::vector<std::vector<int>> parts(joined.label(std::vector<char>(slots, 1), part_of));
  for (int s = 0; s < slots; ++s) parts[part_of[s]].push_back(s);
  for (const std::vector<int>& part : parts) {
    // A part with no move to make (a fixed group) stays exactly: its fit below is the identity only to rounding.
    bool there = true;
    for (int s : part) there = there && state.row(constrained_[s]) == targets.row(s);
    if (there) {
      for (int s : part) goal.row(s) = targets.row(s);
      continue;
    }
    Eigen::Vector3d from = Eigen::Vector3d::Zero(), to = Eigen::Vector3d::Zero();
    for (int s : part) from += state.row(constrained_[s]).transpose(), to += targets.row(s).transpose();
    from /= static_cast<double>(part.size());
    to /= static_cast<double>(part.size());
    // The rotation that best carries the part's offsets from its centre onto the targets' (Kabsch):
    // the local step's fit, for A = sum (target offset)(offset)^T.
    Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
    for (int s : part)
      covariance += (targets.row(s).transpose() - to) * (state.row(constrained_[s]).transpose() - from).transpose();
    Eigen::Matrix3d turn = Eigen::Matrix3d::Identity();
    if (part.size() >= 3 && covariance.norm() > 0) fit_rotation(covariance, turn);
    // share of the turn about the same axis, share of the shift, share of what the fit leaves over.
    const Eigen::AngleAxisd whole(turn);
    const Eigen::Matrix3d partial = Eigen::AngleAxisd(share * whole.angle(), whole.axis()).toRotationMatrix();
    for (int s : part) {
      const Eigen::Vector3d offset = state.row(constrained_[s]).transpose() - from;
      const Eigen::Vector3d left_over = targets.row(s).transpose() - (turn * offset + to);
      goal.row(s) = (partial * offset + from + share * (to - from) + share * left_over).transpose();
    }
    if (share >= 1)
      for (int s : part) goal.row(s) = targets.row(s);
  }
}

}  // namespace arap::contact
