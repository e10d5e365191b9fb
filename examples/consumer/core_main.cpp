// A controller's view: hapticcal::core alone (model, transmissions, prepared
// kinematics), no Ceres, yaml-cpp or JSON in the link.
#include <cstdio>
#include <hapticcal/kinematics/kinematics.hpp>

int main() {
  hapticcal::DeviceModel model;
  model.name = "two-link";
  for (const char* name : {"j1", "j2"}) {
    hapticcal::Link link;
    link.name = name;
    link.a = 0.2;
    link.lower = -3;
    link.upper = 3;
    model.links.push_back(link);
  }
  const hapticcal::PreparedModel prepared(model);
  const double q[2] = {0, 0};
  const auto tool = prepared.forward(q);
  std::printf("core: tool point at home: %.3f %.3f %.3f\n", tool.p[0], tool.p[1], tool.p[2]);
  return tool.p[0] > 0.399 && tool.p[0] < 0.401 ? 0 : 1;
}
