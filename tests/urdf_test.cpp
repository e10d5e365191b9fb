// URDF models: the chains read from URDFs against orocos KDL
// chains built by an independent walk of urdfdom's tree; device files through
// URDF and back; calibrated URDFs read back to the calibrated kinematics with the
// rest of the document kept; malformed input; the command line.
#include "hapticcal/model_io/urdf.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <functional>
#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/chainjnttojacsolver.hpp>
#include <nlohmann/json.hpp>
#include <numbers>
#include <optional>
#include <random>
#include <sstream>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model_io/device.hpp"
#include "hapticcal/model_io/model_source.hpp"
#include "kdl_chain.hpp"
#include "kdl_urdf.hpp"
#include "run_cli.hpp"
#include "test_models.hpp"

// urdfdom 3.0 leaks the links of a URDF whose joints form a loop (shared_ptr
// cycles; MalformedInputGivesOneLineErrors reads one): not a leak of hapticcal.
extern "C" const char* __lsan_default_suppressions() { return "leak:liburdfdom_model\n"; }

namespace hapticcal {
namespace {

namespace fs = std::filesystem;
using testing::builtin;
using testing::meca500;
using testing::random_readings;
using testing::real_data_path;
using testing::source_path;

// Fewer configurations under AddressSanitizer, whose build runs this test too.
#if defined(__SANITIZE_ADDRESS__)
constexpr int kConfigurations = 100;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr int kConfigurations = 100;
#else
constexpr int kConfigurations = 1000;
#endif
#else
constexpr int kConfigurations = 1000;
#endif

std::string panda_path() { return real_data_path("mukca/panda.urdf"); }
std::string arm_path() { return source_path("tests/data/urdf/arm.urdf"); }

fs::path scratch(const std::string& name) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("urdf_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// Every joint kind device_to_urdf has to split: a DH base; DH and MDH joints,
// revolute and prismatic, with beta and theta; origin joints with offsets and
// axes that are not z; a continuous joint; a tool pose.
DeviceModel mixed_model() {
  DeviceModel m;
  m.name = "mixed & <odd> \"name\"";
  m.base_kind = BaseKind::kDh;
  m.base = {0.1, -0.4, 0.05, 0.3, 0, 0};
  auto dh = [](const std::string& name, Geometry g, JointType type, double a, double alpha,
               double d, double theta, double beta) {
    Link l;
    l.name = name;
    l.geometry = g;
    l.type = type;
    l.a = a, l.alpha = alpha, l.d = d, l.theta = theta, l.beta = beta;
    l.lower = type == JointType::kPrismatic ? -0.1 : -2.0;
    l.upper = type == JointType::kPrismatic ? 0.2 : 2.0;
    return l;
  };
  m.links.push_back(dh("d1", Geometry::kDh, JointType::kRevolute, 0.05, 1.2, 0.1, 0.4, 0.02));
  m.links.push_back(dh("d2", Geometry::kDh, JointType::kPrismatic, 0.03, -0.7, 0.15, -0.5, 0.01));
  m.links.push_back(dh("m3", Geometry::kMdh, JointType::kRevolute, 0.2, -1.5, 0.02, 0.3, -0.03));
  m.links.push_back(dh("m4", Geometry::kMdh, JointType::kPrismatic, 0.04, 0.9, 0.1, 1.1, 0.02));
  auto origin = [](const std::string& name, JointType type, std::array<double, 6> o,
                   Eigen::Vector3d axis, double offset) {
    Link l;
    l.name = name;
    l.geometry = Geometry::kOrigin;
    l.type = type;
    l.origin = o;
    l.axis = axis.normalized();
    l.offset = offset;
    l.lower = type == JointType::kPrismatic ? -0.05 : -1.5;
    l.upper = type == JointType::kPrismatic ? 0.1 : 1.5;
    return l;
  };
  m.links.push_back(origin("o5", JointType::kRevolute, {0.1, 0.02, -0.03, 0.2, -0.4, 0.7},
                           {0.2, -0.9, 0.3}, 0.25));
  m.links.push_back(
      origin("o6", JointType::kPrismatic, {0.0, 0.05, 0.1, -0.3, 0.1, 0.2}, {1, 1, 0}, 0.03));
  Link c = origin("o7", JointType::kContinuous, {0.02, 0, 0.04, 0, 0.3, 0}, {0, 0, 1}, -0.4);
  c.lower = -std::numbers::pi;
  c.upper = std::numbers::pi;
  m.links.push_back(c);
  m.tool = {0.01, -0.02, 0.08, 0.1, -0.2, 0.3};
  return m;
}

// A URDF chain, and the device model it was written from (if any).
struct Case {
  std::string label, text, root, tip;
  std::optional<DeviceModel> source;
};

std::vector<Case> cases() {
  std::vector<Case> out;
  out.push_back({"panda.urdf", read_file(panda_path()), "panda_link0", "ball_link", {}});
  out.push_back({"arm.urdf", read_file(arm_path()), "world", "tcp", {}});
  const std::vector<std::pair<std::string, DeviceModel>> devices = {
      {"baser-7dof", builtin("baser-7dof")},
      {"phantom-premium-1.5", builtin("phantom-premium-1.5")},
      {"meca500", meca500()},
      {"mixed", mixed_model()}};
  for (const auto& [label, model] : devices) {
    out.push_back({"device_to_urdf(" + label + ")", device_to_urdf(model), "hapticcal_measurement",
                   "tool", model});
  }
  return out;
}

struct Differences {
  double p = 0, R = 0, J = 0;
};

Differences difference(const Frame<double>& a, const Frame<double>& b) {
  return {(a.p - b.p).cwiseAbs().maxCoeff(), (a.R - b.R).cwiseAbs().maxCoeff(), 0};
}

void keep_worst(Differences& worst, const Differences& d) {
  worst.p = std::max(worst.p, d.p);
  worst.R = std::max(worst.R, d.R);
  worst.J = std::max(worst.J, d.J);
}

// Largest FK difference between two models of the same chain over random
// readings of `a` (b takes a's joint values q + dtheta(q)).
Differences fk_difference(const DeviceModel& a, const DeviceModel& b, int n = kConfigurations) {
  const PreparedModel pa(a), pb(b);
  std::mt19937_64 rng(5);
  Differences worst;
  for (int k = 0; k < n; ++k) {
    const Eigen::VectorXd q = random_readings(a, rng);
    const Eigen::VectorXd joint = a.compensate(q);
    keep_worst(worst, difference(pa.forward(q.data()), pb.forward(joint.data())));
  }
  return worst;
}

// The model with its base (the measurement frame, not written to a URDF) at identity.
DeviceModel without_base(DeviceModel m) {
  m.base_kind = BaseKind::kPose;
  m.base = {};
  return m;
}

TEST(Urdf, ForwardKinematicsAndJacobianMatchKdlOn1000Configurations) {
  for (const Case& c : cases()) {
    SCOPED_TRACE(c.label);
    const DeviceModel model = parse_urdf(c.text, c.label, c.tip, c.root);
    const DeviceModel& source = c.source ? *c.source : model;
    ASSERT_EQ(model.dof(), source.dof());
    const KDL::Chain chain = testing::kdl_chain_from_urdf(c.text, c.root, c.tip);
    ASSERT_EQ(static_cast<int>(chain.getNrOfJoints()), model.dof());
    KDL::ChainFkSolverPos_recursive fk(chain);
    KDL::ChainJntToJacSolver jac_solver(chain);
    const PreparedModel prepared(model), prepared_source(source);
    const ChainStructure s = model.structure();
    const Eigen::VectorXd params = model.kinematic_parameters();
    std::mt19937_64 rng(11);
    Differences kdl, written;
    for (int trial = 0; trial < kConfigurations; ++trial) {
      // Readings of the source model; the URDF (no transmissions) takes its joint values.
      const Eigen::VectorXd q = random_readings(source, rng);
      const Eigen::VectorXd joint = source.compensate(q);
      const testing::KdlSolution solved = testing::kdl_solve(fk, jac_solver, joint);
      const Frame<double>& ref = solved.T;
      const Jacobian6<double>& Jref = solved.J;

      std::array<Frame<double>, kMaxDof + 1> frames;
      const Frame<double> generic =
          forward_kinematics(s, params.data(), joint.data(), frames.data());
      Jacobian6<double> Jg, Jp;
      geometric_jacobian(s, frames.data(), generic, JacobianFrame::kMeasurement, Jg);
      const Frame<double> fast =
          prepared.forward_jacobian(joint.data(), JacobianFrame::kMeasurement, Jp);

      Differences d = difference(generic, ref);
      keep_worst(d, difference(fast, ref));
      d.J = std::max((Jg - Jref).cwiseAbs().maxCoeff(), (Jp - Jref).cwiseAbs().maxCoeff());
      keep_worst(kdl, d);
      keep_worst(written, difference(prepared_source.forward(q.data()), fast));
    }
    std::printf("[ figures  ] %s (%d joints): vs KDL max |dp| %.3g m, |dR| %.3g, |dJ| %.3g",
                c.label.c_str(), model.dof(), kdl.p, kdl.R, kdl.J);
    if (c.source) std::printf("; vs the device model |dp| %.3g m, |dR| %.3g", written.p, written.R);
    std::printf(" (%d configurations)\n", kConfigurations);
    EXPECT_LT(kdl.p, 1e-12);
    EXPECT_LT(kdl.R, 1e-12);
    EXPECT_LT(kdl.J, 1e-12);
    EXPECT_LT(written.p, 1e-12);
    EXPECT_LT(written.R, 1e-12);
  }
}

TEST(Urdf, ReadsTheChainAsWritten) {
  const DeviceModel panda = load_urdf(panda_path(), "ball_link");
  EXPECT_EQ(panda.name, "panda");
  ASSERT_EQ(panda.dof(), 7);
  for (int i = 0; i < 7; ++i) {
    EXPECT_EQ(panda.links[i].name, fmt::format("panda_joint{}", i + 1));
    EXPECT_EQ(panda.links[i].geometry, Geometry::kOrigin);
  }
  // Origins exactly as the text gives them; limits from <limit>.
  EXPECT_EQ(panda.links[2].origin, (std::array<double, 6>{0, -0.316, 0, 1.5707963267948966, 0, 0}));
  EXPECT_EQ(panda.links[3].lower, -3.0718);
  EXPECT_EQ(panda.links[3].upper, -0.0698);
  // Fixed joints after joint 7 (flange, hand, tcp, ball) are the tool.
  EXPECT_NEAR(panda.tool[2], 0.107 + 0.1034 + 0.030128297908475325, 1e-15);
  EXPECT_NEAR(panda.tool[5], -std::numbers::pi / 4, 1e-15);
  EXPECT_EQ(panda.base, (std::array<double, 6>{}));

  const DeviceModel arm = load_urdf(arm_path(), "tcp");
  ASSERT_EQ(arm.dof(), 5);
  EXPECT_EQ(arm.links[2].type, JointType::kPrismatic);
  EXPECT_NEAR(arm.links[2].axis.norm(), 1.0, 1e-15);
  EXPECT_NEAR(arm.links[2].axis.x(), std::sqrt(0.5), 1e-15);
  EXPECT_EQ(arm.links[3].type, JointType::kContinuous);
  EXPECT_EQ(arm.links[3].lower, -std::numbers::pi);
  EXPECT_EQ(arm.links[3].upper, std::numbers::pi);
  // A root and tip inside the tree: the chain link2 -> link5 has slide, wrist, roll.
  const DeviceModel part = load_urdf(arm_path(), "link5", "link2");
  ASSERT_EQ(part.dof(), 3);
  EXPECT_EQ(part.links[0].name, "slide");
  // The only leaf below the root needs no tip.
  EXPECT_EQ(load_urdf(source_path("tests/data/urdf/floating-in-chain.urdf"), "", "body").dof(), 1);
}

TEST(Urdf, DeviceFileToUrdfAndBackKeepsTheKinematics) {
  const std::vector<std::pair<std::string, DeviceModel>> devices = {
      {"baser-7dof", builtin("baser-7dof")},
      {"phantom-premium-1.5", builtin("phantom-premium-1.5")},
      {"meca500", meca500()},
      {"mixed", mixed_model()}};
  for (const auto& [label, model] : devices) {
    SCOPED_TRACE(label);
    const std::string urdf = device_to_urdf(model);
    const DeviceModel back = parse_urdf(urdf, label + ".urdf", "tool");
    const DeviceModel again = parse_device(device_to_yaml(back), label + ".yaml");
    EXPECT_EQ(again.name, model.name);
    ASSERT_EQ(again.dof(), model.dof());
    for (int i = 0; i < model.dof(); ++i) {
      EXPECT_EQ(again.links[i].name, model.links[i].name);
      EXPECT_EQ(again.links[i].type, model.links[i].type);
      EXPECT_EQ(again.links[i].lower, model.links[i].lower);
      EXPECT_EQ(again.links[i].upper, model.links[i].upper);
      EXPECT_EQ(again.links[i].offset, 0.0);
    }
    const Differences d = fk_difference(model, again);
    std::printf("[ figures  ] %s -> URDF -> YAML: max |dp| %.3g m, |dR| %.3g\n", label.c_str(), d.p,
                d.R);
    EXPECT_LT(d.p, 1e-12);
    EXPECT_LT(d.R, 1e-12);
    // Transmissions are comments.
    const size_t transmissions =
        std::count_if(model.links.begin(), model.links.end(),
                      [](const Link& l) { return !l.transmission.is_none(); });
    size_t comments = 0;
    for (size_t k = 0; (k = urdf.find("has a transmission", k)) != std::string::npos; ++k) {
      ++comments;
    }
    EXPECT_EQ(comments, transmissions);
  }
}

// Every origin parameter, offset and the tool moved by up to +-scale (m, rad).
DeviceModel corrected(DeviceModel m, std::mt19937_64& rng, double scale) {
  std::uniform_real_distribution<double> u(-scale, scale);
  for (Link& l : m.links) {
    for (double& v : l.origin) v += u(rng);
    l.offset += u(rng);
  }
  for (double& v : m.tool) v += u(rng);
  return m;
}

size_t count(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t k = 0; (k = text.find(what, k)) != std::string::npos; k += what.size()) ++n;
  return n;
}

// The text of the joint element `name`.
std::string joint_text(const std::string& text, const std::string& name) {
  const size_t begin = text.find("<joint name=\"" + name + "\"");
  if (begin == std::string::npos) return {};
  return text.substr(begin, text.find("</joint>", begin) - begin);
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

// The output without the comment calibrated_urdf adds after <robot>.
std::string without_note(std::string text) {
  const size_t at = text.find("\n  <!-- hapticcal: calibrated joint origins");
  if (at == std::string::npos) return text;
  text.erase(at, text.find("-->", at) + 3 - at);
  return text;
}

struct UrdfFile {
  std::string label, path, root, tip;
};
const std::vector<UrdfFile> kCalibrated = {{"panda", panda_path(), "panda_link0", "ball_link"},
                                           {"arm", arm_path(), "world", "tcp"}};

TEST(Urdf, CalibratedUrdfWithoutCorrectionsIsTheInput) {
  for (const UrdfFile& f : kCalibrated) {
    SCOPED_TRACE(f.label);
    const std::string text = read_file(f.path);
    const DeviceModel nominal = parse_urdf(text, f.path, f.tip, f.root);
    const std::string out = calibrated_urdf(text, f.path, f.tip, f.root, nominal);
    EXPECT_EQ(without_note(out), text);
    EXPECT_NE(out, text);  // the note says what was done
    const DeviceModel back = parse_urdf(out, "out.urdf", f.tip, f.root);
    const Differences d = fk_difference(nominal, back);
    EXPECT_LT(d.p, 1e-12);
    EXPECT_LT(d.R, 1e-12);
    // Corrections of 1e-300 rewrite every joint origin (through the unfolding)
    // and still give the input's kinematics.
    std::mt19937_64 rng(3);
    const DeviceModel tiny = corrected(nominal, rng, 1e-300);
    const std::string rewritten = calibrated_urdf(text, f.path, f.tip, f.root, tiny);
    EXPECT_NE(without_note(rewritten), text);
    const Differences t = fk_difference(nominal, parse_urdf(rewritten, "out.urdf", f.tip, f.root));
    EXPECT_LT(t.p, 1e-12);
    EXPECT_LT(t.R, 1e-12);
  }
}

TEST(Urdf, CalibratedUrdfReadsBackToTheCalibratedKinematicsAndKeepsTheRest) {
  for (const UrdfFile& f : kCalibrated) {
    SCOPED_TRACE(f.label);
    const std::string text = read_file(f.path);
    const DeviceModel nominal = parse_urdf(text, f.path, f.tip, f.root);
    std::mt19937_64 rng(17);
    DeviceModel calibrated = corrected(nominal, rng, 2e-3);
    // The base (the measurement frame) is left out here: measurement_frame_test
    // checks the hapticcal_measurement link it adds.
    std::vector<std::string> notes;
    const std::string out = calibrated_urdf(text, f.path, f.tip, f.root, calibrated, &notes);
    EXPECT_TRUE(notes.empty());
    const DeviceModel back = parse_urdf(out, "calibrated.urdf", f.tip, f.root);
    const Differences d = fk_difference(without_base(calibrated), back);
    std::printf("[ figures  ] %s calibrated.urdf read back: max |dp| %.3g m, |dR| %.3g\n",
                f.label.c_str(), d.p, d.R);
    EXPECT_LT(d.p, 1e-12);
    EXPECT_LT(d.R, 1e-12);
    for (const Link& l : back.links) EXPECT_EQ(l.offset, 0.0);
    // Everything but the joint origins is kept.
    for (const char* element :
         {"<link", "<joint", "<visual", "<inertial", "<collision", "<limit", "<mimic", "<axis",
          "<geometry", "<mesh", "<material", "<parent", "<child", "<safety_controller", "<dynamics",
          "<calibration", "<transmission", "<gazebo"}) {
      EXPECT_EQ(count(out, element), count(text, element)) << element;
    }
    EXPECT_EQ(count(out, "<!--"), count(text, "<!--") + 1);
    // One <origin> added: the arm's wrist joint had none.
    EXPECT_EQ(count(out, "<origin"), count(text, "<origin") + (f.label == "arm" ? 1 : 0));
    for (const char* off_chain : {"panda_finger_joint1", "panda_finger_joint2", "finger_left_joint",
                                  "finger_right_joint", "camera_joint", "object_joint", "mount",
                                  "bracket_joint", "elbow_fixed_a", "flange_joint"}) {
      EXPECT_EQ(joint_text(out, off_chain), joint_text(text, off_chain)) << off_chain;
    }
    if (f.label == "panda") {
      // Line for line, only the origins of the 7 joints and of ball_joint differ.
      const std::vector<std::string> a = lines_of(text), b = lines_of(without_note(out));
      ASSERT_EQ(a.size(), b.size());
      int changed = 0;
      for (size_t k = 0; k < a.size(); ++k) {
        if (a[k] == b[k]) continue;
        ++changed;
        EXPECT_NE(a[k].find("<origin"), std::string::npos) << a[k];
      }
      EXPECT_EQ(changed, 8);
    }
  }
}

TEST(Urdf, ToolCorrectionUnderAMovableJointGoesOnAnAddedLink) {
  const std::string text = read_file(arm_path());
  const DeviceModel nominal = parse_urdf(text, "arm.urdf", "link5", "world");
  EXPECT_EQ(nominal.tool, (std::array<double, 6>{}));
  std::mt19937_64 rng(23);
  const DeviceModel calibrated = corrected(nominal, rng, 2e-3);
  std::vector<std::string> notes;
  const std::string out = calibrated_urdf(text, "arm.urdf", "link5", "world", calibrated, &notes);
  ASSERT_EQ(notes.size(), 1u);
  EXPECT_NE(notes[0].find("hapticcal_tool"), std::string::npos);
  EXPECT_EQ(count(out, "<link name=\"hapticcal_tool\"/>"), 1u);
  const Differences d =
      fk_difference(calibrated, parse_urdf(out, "out", "hapticcal_tool", "world"));
  EXPECT_LT(d.p, 1e-12);
  EXPECT_LT(d.R, 1e-12);
  // Without the added link: the joints' calibration alone.
  DeviceModel joints_only = calibrated;
  joints_only.tool = {};
  const Differences j = fk_difference(joints_only, parse_urdf(out, "out", "link5", "world"));
  EXPECT_LT(j.p, 1e-12);
}

TEST(Urdf, CalibratedModelOfAnotherChainIsRefused) {
  const std::string text = read_file(arm_path());
  DeviceModel other = parse_urdf(text, "arm.urdf", "tcp");
  other.links[1].name = "elsewhere";
  EXPECT_THROW(calibrated_urdf(text, "arm.urdf", "tcp", "", other), InputError);
  EXPECT_THROW(calibrated_urdf(text, "arm.urdf", "tcp", "", builtin("baser-7dof")), InputError);
}

// One line naming the file (and the joint or link where there is one).
void expect_input_error(const std::function<void()>& f, const std::vector<std::string>& says) {
  try {
    f();
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
    for (const std::string& s : says) EXPECT_NE(what.find(s), std::string::npos) << what;
  }
}

std::string one_joint(const std::string& joint) {
  return "<robot name=\"r\"><link name=\"a\"/><link name=\"b\"/>" + joint + "</robot>";
}

TEST(Urdf, MalformedInputGivesOneLineErrors) {
  const std::string dir = source_path("tests/data/urdf/");
  const std::string arm = read_file(arm_path());
  expect_input_error([&] { load_urdf(dir + "bad-xml.urdf", "b"); }, {"bad-xml.urdf:11:", "XML"});
  expect_input_error([&] { load_urdf(arm_path(), "nope"); }, {"arm.urdf", "tip", "'nope'"});
  expect_input_error([&] { load_urdf(arm_path(), "tcp", "nope"); }, {"arm.urdf", "root", "'nope'"});
  expect_input_error([&] { load_urdf(arm_path(), ""); }, {"arm.urdf", "tip", "5 leaf links"});
  expect_input_error([&] { load_urdf(arm_path(), "camera", "link3"); },
                     {"arm.urdf:58:", "'camera'", "not below", "'link3'"});
  expect_input_error([&] { load_urdf(arm_path(), "base"); }, {"no movable joint"});
  expect_input_error([&] { load_urdf(dir + "floating-in-chain.urdf", "tip"); },
                     {"floating-in-chain.urdf:7:", "'free_flyer'", "floating"});
  expect_input_error([&] { load_urdf(dir + "mimic-in-chain.urdf", "l2"); },
                     {"mimic-in-chain.urdf:13:", "'j2'", "mimic", "'j0'", "not a movable joint"});
  // A mimic joint on the chain is a passive coupled joint (coupling_test.cpp);
  // one off the chain is ignored.
  EXPECT_EQ(load_urdf(dir + "mimic-in-chain.urdf", "l1").dof(), 1);
  const std::string limit = "<limit lower=\"-1\" upper=\"1\" effort=\"1\" velocity=\"1\"/>";
  auto joint = [&](const std::string& name, const std::string& inside) {
    return "<joint name=\"" + name +
           "\" type=\"revolute\"><parent link=\"a\"/><child link=\"b\"/>" + inside + "</joint>";
  };
  expect_input_error([&] { parse_urdf(one_joint(joint("bad-name", limit)), "x.urdf", "b"); },
                     {"x.urdf:1:", "'bad-name'", "usable link name"});
  expect_input_error([&] { parse_urdf(one_joint(joint("tool", limit)), "x.urdf", "b"); },
                     {"'tool'"});
  expect_input_error(
      [&] {
        parse_urdf(
            one_joint(joint("j", "<limit lower=\"1\" upper=\"1\" effort=\"1\" velocity=\"1\"/>")),
            "x.urdf", "b");
      },
      {"'j'", "limits"});
  expect_input_error(
      [&] { parse_urdf(one_joint(joint("j", "<axis xyz=\"0 0 0\"/>" + limit)), "x.urdf", "b"); },
      {"'j'", "axis"});
  expect_input_error([&] { parse_urdf(one_joint(joint("j", "")), "x.urdf", "b"); },
                     {"x.urdf:1:", "URDF", "[j]"});
  expect_input_error([&] { parse_urdf("", "empty.urdf", "b"); }, {"empty.urdf", "XML"});
  expect_input_error([&] { parse_urdf(std::string("<robot\0", 7), "nul.urdf", "b"); },
                     {"nul.urdf:1:", "NUL"});
  expect_input_error([&] { parse_urdf("<robot name=\"r\"><link name=\"a\"/></robot>", "x", "a"); },
                     {"no movable joint"});
  std::string long_chain = "<robot name=\"long\"><link name=\"l0\"/>";
  for (int k = 1; k <= kMaxDof + 1; ++k) {
    long_chain += fmt::format(
        "<link name=\"l{0}\"/><joint name=\"j{0}\" type=\"continuous\"><parent link=\"l{1}\"/>"
        "<child link=\"l{0}\"/></joint>",
        k, k - 1);
  }
  expect_input_error([&] { parse_urdf(long_chain + "</robot>", "long.urdf", ""); },
                     {"long.urdf", "33 movable joints", "at most 32"});
  std::string long_name = one_joint(joint("j", limit));
  long_name.replace(long_name.find("\"r\""), 3, "\"" + std::string(300, 'r') + "\"");
  expect_input_error([&] { parse_urdf(long_name, "x.urdf", "b"); },
                     {"x.urdf:1:", "robot name", "longer than"});
  // Joints in a loop below the root (b -> c -> b), which urdfdom accepts: the walk
  // up from the tip and the search for the leaf ran on until memory ran out
  // (std::bad_alloc; found while fuzzing with fuzz_urdf).
  const std::string loop =
      "<robot name=\"loop\"><link name=\"a\"/><link name=\"b\"/><link name=\"c\"/>" +
      joint("j1", limit) +
      "<joint name=\"j2\" type=\"revolute\"><parent link=\"b\"/><child link=\"c\"/>" + limit +
      "</joint><joint name=\"j3\" type=\"revolute\"><parent link=\"c\"/><child link=\"b\"/>" +
      limit + "</joint></robot>";
  // Refused before urdfdom reads it (which leaked the loop's links), whatever the tip.
  for (const char* tip : {"c", "b", ""}) {
    expect_input_error([&] { parse_urdf(loop, "loop.urdf", tip); },
                       {"loop.urdf:1:", "link 'b'", "child of two joints, 'j1' and 'j3'", "loop"});
  }
  // A text that ends in a cut UTF-8 sequence: tinyxml read past its end
  // (stack-buffer-overflow; found by fuzz_urdf).
  expect_input_error([&] { parse_urdf("<origin xyz=\"<\xc8", "cut.urdf", "b"); },
                     {"cut.urdf", "XML"});
  // A tip or root with a device file.
  expect_input_error([&] { load_model(source_path("data/devices/baser-7dof.yaml"), "tool"); },
                     {"baser-7dof.yaml", "--tip"});
}

TEST(Urdf, ModelSourceChoosesTheReaderByExtension) {
  EXPECT_TRUE(is_urdf_path("a/b.URDF"));
  EXPECT_FALSE(is_urdf_path("a.urdf.yaml"));
  EXPECT_TRUE(is_yaml_path("x.yml"));
  EXPECT_EQ(load_model(panda_path(), "ball_link").dof(), 7);
  EXPECT_EQ(load_model(source_path("data/devices/baser-7dof.yaml")).name, "baser-7dof");
  EXPECT_TRUE(fs::exists(builtin_device_path()));
}

// ---------------------------------------------------------------------------
// The command line.

TEST(UrdfCli, ConvertsDeviceFilesToUrdfAndBack) {
  const fs::path dir = scratch("convert");
  const std::string yaml = source_path("data/devices/baser-7dof.yaml");
  const std::string urdf = (dir / "baser.urdf").string(), back = (dir / "back.yaml").string();
  const testing::CliResult to = testing::run_cli(std::vector<std::string>{"convert", yaml, urdf});
  EXPECT_EQ(to.exit_code, 0) << to.err;
  EXPECT_NE(to.err.find("warning: URDF cannot express transmissions"), std::string::npos) << to.err;
  EXPECT_EQ(std::count(to.err.begin(), to.err.end(), '\n'), 1);
  const testing::CliResult from =
      testing::run_cli(std::vector<std::string>{"convert", urdf, back, "--tip", "tool"});
  EXPECT_EQ(from.exit_code, 0) << from.err;
  const Differences d = fk_difference(load_device(yaml), load_device(back));
  EXPECT_LT(d.p, 1e-12);
  EXPECT_LT(d.R, 1e-12);
  // URDF -> YAML of a real robot.
  const std::string panda_yaml = (dir / "panda.yaml").string();
  const testing::CliResult panda = testing::run_cli(
      std::vector<std::string>{"convert", panda_path(), panda_yaml, "--tip", "ball_link"});
  EXPECT_EQ(panda.exit_code, 0) << panda.err;
  EXPECT_TRUE(panda.err.empty()) << panda.err;
  const Differences p =
      fk_difference(load_urdf(panda_path(), "ball_link"), load_device(panda_yaml));
  EXPECT_EQ(p.p, 0.0);
  EXPECT_EQ(p.R, 0.0);

  // Usage errors: exit 2, one line, nothing written.
  for (const std::vector<std::string>& args : std::vector<std::vector<std::string>>{
           {"convert", yaml, (dir / "same.yaml").string()},
           {"convert", urdf, (dir / "same.urdf").string(), "--tip", "tool"},
           {"convert", yaml, (dir / "what.txt").string()},
           {"convert", yaml, (dir / "x.urdf").string(), "--tip", "tool"},
           {"convert", arm_path(), (dir / "x.yaml").string()},  // 5 leaves: which tip?
           {"convert", urdf, (dir / "x.yaml").string(), "--tip", "nope"}}) {
    const testing::CliResult r = testing::run_cli(args);
    EXPECT_EQ(r.exit_code, 2) << args[1] << " " << args[2] << ": " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  }
  EXPECT_FALSE(fs::exists(dir / "same.yaml"));
  EXPECT_FALSE(fs::exists(dir / "x.urdf"));
  EXPECT_FALSE(fs::exists(dir / "x.yaml"));
}

TEST(UrdfCli, MalformedUrdfsExitWith2AndOneLine) {
  const std::string dir = source_path("tests/data/urdf/");
  const fs::path out = scratch("malformed") / "out.yaml";
  const std::vector<std::pair<std::vector<std::string>, std::string>> runs = {
      {{"convert", dir + "bad-xml.urdf", out.string(), "--tip", "b"}, "bad-xml.urdf:11:"},
      {{"convert", dir + "floating-in-chain.urdf", out.string(), "--tip", "tip"}, "free_flyer"},
      {{"convert", dir + "mimic-in-chain.urdf", out.string(), "--tip", "l2"}, "'j2'"},
      {{"convert", arm_path(), out.string(), "--tip", "nope"}, "'nope'"},
      {{"convert", arm_path(), out.string(), "--tip", "tcp", "--root", "nowhere"}, "'nowhere'"},
      {{"evaluate", "--model", dir + "mimic-in-chain.urdf", "--tip", "l2", "--log",
        source_path("tests/malformed/good-2dof.csv")},
       "'j2'"},
      {{"evaluate", "--model", source_path("data/devices/baser-7dof.yaml"), "--tip", "tool",
        "--log", source_path("tests/malformed/good-2dof.csv")},
       "--tip"}};
  for (const auto& [args, says] : runs) {
    const testing::CliResult r = testing::run_cli(args);
    EXPECT_EQ(r.exit_code, 2) << args[1] << ": " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_NE(r.err.find(says), std::string::npos) << r.err;
  }
  EXPECT_FALSE(fs::exists(out));
}

// A position log of `truth` at random readings: q1..qn, x, y, z.
std::string position_log(const DeviceModel& truth, int rows, unsigned seed) {
  std::mt19937_64 rng(seed);
  const PreparedModel prepared(truth);
  std::string csv;
  for (int i = 0; i < truth.dof(); ++i) csv += fmt::format("q{},", i + 1);
  csv += "x,y,z\n";
  for (int k = 0; k < rows; ++k) {
    const Eigen::VectorXd q = random_readings(truth, rng);
    const Frame<double> T = prepared.forward(q.data());
    for (int i = 0; i < truth.dof(); ++i) csv += fmt::format("{},", q[i]);
    csv += fmt::format("{},{},{}\n", T.p[0], T.p[1], T.p[2]);
  }
  return csv;
}

TEST(UrdfCli, EvaluatesAUrdfModelOnAPositionLog) {
  const fs::path dir = scratch("evaluate");
  const DeviceModel panda = load_urdf(panda_path(), "ball_link");
  const std::string log = (dir / "positions.csv").string();
  write_file_atomically(log, position_log(panda, 40, 1));
  const testing::CliResult r = testing::run_cli(std::vector<std::string>{
      "evaluate", "--model", panda_path(), "--tip", "ball_link", "--log", log, "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["n"], 40);
  EXPECT_LT(j["rms_position"].get<double>(), 1e-12);
  // The panda has three leaves (the fingers, the ball): the tip is needed.
  const testing::CliResult no_tip =
      testing::run_cli(std::vector<std::string>{"evaluate", "--model", panda_path(), "--log", log});
  EXPECT_EQ(no_tip.exit_code, 2);
  EXPECT_NE(no_tip.err.find("3 leaf links"), std::string::npos) << no_tip.err;
}

TEST(UrdfCli, CalibrateFromAUrdfWritesCalibratedUrdf) {
  const fs::path dir = scratch("calibrate");
  const DeviceModel nominal = load_urdf(panda_path(), "ball_link");
  std::mt19937_64 rng(29);
  const DeviceModel truth = corrected(nominal, rng, 1e-3);
  const std::string log = (dir / "positions.csv").string();
  write_file_atomically(log, position_log(truth, 150, 2));
  const std::string out = (dir / "out").string();
  const testing::CliResult r = testing::run_cli(std::vector<std::string>{
      "calibrate", "--model", panda_path(), "--tip", "ball_link", "--log", log, "--out", out});
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("calibrated.urdf"), std::string::npos) << r.out;
  const DeviceModel yaml = load_device(out + "/calibrated.yaml");
  const DeviceModel urdf = load_urdf(out + "/calibrated.urdf", "ball_link");
  // calibrated.urdf is calibrated.yaml without the measurement frame.
  const Differences d = fk_difference(without_base(yaml), urdf);
  EXPECT_LT(d.p, 1e-12);
  EXPECT_LT(d.R, 1e-12);
  // The calibrated model fits the log.
  const testing::CliResult e = testing::run_cli(std::vector<std::string>{
      "evaluate", "--model", out + "/calibrated.yaml", "--log", log, "--json"});
  ASSERT_EQ(e.exit_code, 0) << e.err;
  EXPECT_LT(nlohmann::json::parse(e.out)["rms_position"].get<double>(), 1e-6);
}

}  // namespace
}  // namespace hapticcal
