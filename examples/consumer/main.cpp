// Loads a device file and prints the tool point and Jacobian at home: what a
// controller linking hapticcal does at start-up.
#include <hapticcal/kinematics/kinematics.hpp>
#include <hapticcal/model_io/device.hpp>
#include <iostream>

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: consumer DEVICE.yaml\n";
    return 2;
  }
  const hapticcal::DeviceModel model = hapticcal::load_device(argv[1]);
  const hapticcal::PreparedModel prepared(model);
  const Eigen::VectorXd q = Eigen::VectorXd::Zero(model.dof());
  hapticcal::Jacobian6<double> J;
  const auto T = prepared.forward_jacobian(q.data(), hapticcal::JacobianFrame::kTool, J);
  std::cout << "tool point at home: " << T.p.transpose() << " m\n";
  std::cout << "geometric Jacobian (tool frame):\n" << J << "\n";
  return 0;
}
