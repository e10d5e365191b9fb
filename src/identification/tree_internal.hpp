// Internal: a tree's stacked residuals and Jacobian, its Ceres cost and the
// synthetic readings of its rank test (tree.cpp), for tree_fit.cpp.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "hapticcal/identification/tree.hpp"
#include "identification/measurement_cost.hpp"

namespace ceres {
class CostFunction;
}

namespace hapticcal::detail {

// Each chain's structure, its poses' joint values, measured points and weights.
struct TreeData {
  std::vector<ChainStructure> s;
  std::vector<std::vector<Eigen::VectorXd>> joints;
  std::vector<RowMatrix> measured;
  std::vector<Eigen::VectorXd> weights;  // empty: all 1
};

// Every chain's residuals in chain order, the Jacobian's columns in the tree's
// slots, and each chain's sum of squared residuals.
struct TreeStack {
  Eigen::VectorXd r;
  Eigen::MatrixXd J;  // empty unless asked for
  std::vector<double> rss;
};

// The rows of a tip's point.
inline RowsOf tree_rows() { return {MeasurementType::kPosition, 1, nullptr, nullptr}; }

TreeStack tree_stack(const DeviceTree& tree, const TreeData& data, const Eigen::VectorXd& values,
                     bool jacobian = true);
// The cost Levenberg-Marquardt minimises: one block, the tree's vector.
ceres::CostFunction* tree_cost(const DeviceTree& tree, const TreeData& data);
// Seeded random tree readings over the joint limits: each chain's joint values.
std::vector<std::vector<Eigen::VectorXd>> tree_synthetic_joints(const DeviceTree& tree);

// Per tree slot, what its Jacobian column is divided by: `length` [m] for an
// angle, 1 for a length.
Eigen::VectorXd tree_column_scale(const DeviceTree& tree, double length);
// The base a free pose the model leaves at zero (a URDF's root): the
// measurement frame is the tracker's, unknown to the model.
bool tree_base_unset(const DeviceTree& tree);

// The candidates (tree slots, less `fix`: tree names; InputError for an
// unknown one) in the rank test's order: base -> tools -> joints where the
// measurement frame is unknown, joints -> tools -> base otherwise.
std::vector<int> tree_candidates(const DeviceTree& tree, const std::vector<std::string>& fix,
                                 bool frame_unknown);

}  // namespace hapticcal::detail
