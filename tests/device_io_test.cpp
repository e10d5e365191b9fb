// Device files: the built-ins load, saved models load back bit-identical.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <limits>
#include <random>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/identification/tree.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model_io/device.hpp"
#include "run_cli.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

void expect_bit_identical(const DeviceModel& a, const DeviceModel& b) {
  EXPECT_EQ(a.name, b.name);
  EXPECT_EQ(a.base_kind, b.base_kind);
  const Eigen::VectorXd pa = a.kinematic_parameters(), pb = b.kinematic_parameters();
  ASSERT_EQ(pa.size(), pb.size());
  for (int k = 0; k < pa.size(); ++k) EXPECT_TRUE(same_bits(pa[k], pb[k])) << "slot " << k;
  ASSERT_EQ(a.dof(), b.dof());
  for (int i = 0; i < a.dof(); ++i) {
    const Link &la = a.links[i], &lb = b.links[i];
    EXPECT_EQ(la.name, lb.name);
    EXPECT_EQ(la.geometry, lb.geometry);
    EXPECT_EQ(la.type, lb.type);
    for (int k = 0; k < 3; ++k) EXPECT_TRUE(same_bits(la.axis[k], lb.axis[k]));
    EXPECT_TRUE(same_bits(la.lower, lb.lower) && same_bits(la.upper, lb.upper));
    EXPECT_EQ(la.transmission.type_name(), lb.transmission.type_name());
    const Eigen::VectorXd ta = la.transmission.parameters(), tb = lb.transmission.parameters();
    ASSERT_EQ(ta.size(), tb.size());
    for (int k = 0; k < ta.size(); ++k) EXPECT_TRUE(same_bits(ta[k], tb[k]));
    // Constants outside the parameter vector too.
    EXPECT_EQ(device_to_yaml(a), device_to_yaml(b));
  }
}

TEST(DeviceIo, BuiltinDevicesLoadAndPassTheirChecks) {
  for (const char* name : {"baser-7dof", "phantom-premium-1.5", "geomagic-touch", "dvrk-mtm"}) {
    const DeviceModel m = testing::builtin(name);
    EXPECT_EQ(check_device(m), "") << name;
  }
  const DeviceModel baser = testing::builtin("baser-7dof");
  EXPECT_EQ(baser.dof(), 7);
  EXPECT_EQ(baser.base_kind, BaseKind::kDh);
  EXPECT_EQ(baser.links[3].transmission.type_name(), "polynomial");
  EXPECT_EQ(std::get<Polynomial>(baser.links[3].transmission.model()).order(), 10);
  EXPECT_EQ(baser.parameter_info().size(), 4u + 7u * 5u + 6u);
  EXPECT_EQ(testing::builtin("phantom-premium-1.5").dof(), 6);
}

TEST(DeviceIo, SavedModelLoadsBackBitIdentical) {
  std::mt19937_64 rng(9);
  std::vector<DeviceModel> models = {testing::builtin("baser-7dof"),
                                     testing::builtin("phantom-premium-1.5"), testing::meca500()};
  // Values with full 17-digit mantissas, tiny and large magnitudes, and negative zero.
  for (int i = 0; i < 3; ++i) models.push_back(testing::perturbed(models[i], rng, 1e-3));
  DeviceModel odd = models[0];
  odd.links[0].a = 1e-300;
  odd.links[1].d = -0.0;
  odd.links[2].alpha = 1.0 / 3.0;
  odd.name = "odd \"name\" with \\ and: colon";
  std::get<Capstan>(odd.links[0].transmission.model()).r_out = 4.999999999999999e-3;
  std::get<Polynomial>(odd.links[3].transmission.model()).coefficients[5] =
      -2.2250738585072014e-308;
  models.push_back(odd);
  DeviceModel chain = models[0];
  chain.links[3].transmission =
      Transmission(Chain{{Transmission(Capstan{10, 0.005, 0.1, 0.02, 1e-4, -0.7, 2e-6, -2.1}),
                          Transmission(Parallelogram{0.0495, 0.2093, 0.05, 0.21})}});
  models.push_back(chain);

  const std::string dir = ::testing::TempDir() + "/device_io_roundtrip";
  for (size_t k = 0; k < models.size(); ++k) {
    SCOPED_TRACE(k);
    const std::string path = dir + "/model" + std::to_string(k) + ".yaml";
    save_device(models[k], path);
    const DeviceModel back = load_device(path);
    expect_bit_identical(models[k], back);
    EXPECT_EQ(read_file(path), device_to_yaml(back));
  }
  std::filesystem::remove_all(dir);
}

TEST(DeviceIo, SaveRefusesAnUnusableModelAndLeavesNoFile) {
  DeviceModel m = testing::builtin("baser-7dof");
  m.links[2].lower = 1;
  m.links[2].upper = -1;
  const std::string path = ::testing::TempDir() + "/refused.yaml";
  std::filesystem::remove(path);
  EXPECT_THROW(save_device(m, path), InputError);
  EXPECT_FALSE(std::filesystem::exists(path));
}

TEST(DeviceIo, ShippedMeca500FileIsWhatTheConverterMakesFromTheRealData) {
  const std::string source = testing::real_data_path("meca500");
  ASSERT_TRUE(std::filesystem::exists(source)) << "missing from the repository: " << source;
  const std::string out = ::testing::TempDir() + "/meca500_convert";
  std::filesystem::remove_all(out);
  const testing::CliResult r =
      testing::run_program(HAPTICCAL_CONVERT_MECA500, std::vector<std::string>{source, out});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(read_file(out + "/meca500.yaml"),
            read_file(testing::source_path("examples/meca500/meca500.yaml")));
  for (const auto& e : std::filesystem::directory_iterator(out)) {
    const std::string name = e.path().filename().string();
    EXPECT_EQ(read_file(e.path().string()),
              read_file(testing::source_path("examples/meca500/" + name)))
        << name;
  }
  std::filesystem::remove_all(out);
}

// A tree (the humanoid's two arms on a torso, with a passive coupled joint,
// masses and compliances) in one device file: its parents, tips and tools
// read back bit-identical, every tip's pose at random readings equal to the
// URDF's tree to 1e-12 m.
TEST(DeviceIo, TreeLoadsBackWithItsTipsAndParents) {
  DeviceModel tree = tree_model(load_tree(testing::source_path("examples/humanoid/upper_body.urdf"),
                                          {"left_hand", "right_hand"}));
  std::mt19937_64 rng(58);
  tree = testing::perturbed(tree, rng, 1e-3);
  tree.links[3].compliance = 4e-4;
  tree.links[5].lateral_compliance = -2e-4;
  const std::string path = testing::fresh_folder("device_io_tree") + "/tree.yaml";
  save_device(tree, path);
  const DeviceModel back = load_device(path);
  expect_bit_identical(tree, back);
  EXPECT_EQ(back.parents, tree.parents);
  ASSERT_EQ(back.tips(), 2);
  EXPECT_EQ(back.tip_name(0), "left_hand");
  EXPECT_EQ(back.tip_link_of(1), tree.tip_link_of(1));
  const PreparedModel a(tree), b(back);
  for (int k = 0; k < 20; ++k) {
    const Eigen::VectorXd q = testing::random_readings(tree, rng);
    for (int t = 0; t < 2; ++t) {
      EXPECT_LT((a.forward(q.data(), t).p - b.forward(q.data(), t).p).norm(), 1e-12);
      EXPECT_LT((a.forward(q.data(), t).R - b.forward(q.data(), t).R).norm(), 1e-12);
    }
  }
}

// A tree's keys refused with the file's line and key.
TEST(DeviceIo, MalformedTreesAreRefusedNamingTheKey) {
  const std::string links =
      "format: hapticcal-device/2\nname: t\nconvention: urdf\n"
      "base: {pose: {xyz: [0, 0, 0], rpy: [0, 0, 0]}}\nlinks:\n"
      "  - {name: a, origin: {xyz: [0, 0, 0], rpy: [0, 0, 0]}, axis: [0, 0, 1], limits: [-1, 1]}\n"
      "  - {name: b, PARENT_B origin: {xyz: [0, 0, 0.1], rpy: [0, 0, 0]}, axis: [0, 1, 0], "
      "limits: [-1, 1]}\n"
      "  - {name: c, PARENT_C origin: {xyz: [0, 0, 0.1], rpy: [0, 0, 0]}, axis: [0, 1, 0], "
      "limits: [-1, 1]}\n";
  const auto file = [&](const std::string& b, const std::string& c, const std::string& rest) {
    std::string text = links;
    text.replace(text.find("PARENT_B "), 9, b);
    text.replace(text.find("PARENT_C "), 9, c);
    return text + rest;
  };
  const std::string tips =
      "tips:\n  - {name: one, link: b, pose: {xyz: [0, 0, 0], rpy: [0, 0, 0]}}\n"
      "  - {name: two, link: c, pose: {xyz: [0, 0, 0.1], rpy: [0, 0, 0]}}\n";
  // The good one: b and c both on a.
  const DeviceModel good = parse_device(file("parent: a, ", "parent: a, ", tips), "t.yaml");
  EXPECT_EQ(good.parents, (std::vector<int>{-1, 0, 0}));
  EXPECT_EQ(good.tip_name(1), "two");
  const std::vector<std::tuple<std::string, std::string>> bad = {
      {file("parent: z, ", "parent: a, ", tips),
       "t.yaml:7: links[1].parent: 'z' is not a link or base"},
      {file("parent: c, ", "parent: a, ", tips),
       "links[1].parent: the parent must be a link before"},
      {file("parent: a, ", "", tips),
       "tip one ends at link b, which another tip ends at or passes"},
      {file("parent: a, ", "parent: a, ", ""),
       "links[1].parent: a link's parent belongs to a tree"},
      {file("parent: a, ", "parent: a, ",
            "tips:\n  - {name: one, link: b, pose: {xyz: [0, 0, 0], rpy: [0, 0, 0]}}\n"),
       "tips: expected a list of 2 to"},
      {file("parent: a, ", "parent: a, ",
            tips + "tool: {pose: {xyz: [0, 0, 0], rpy: [0, 0, 0]}}\n"),
       "tool: a tree's tools are its tips'"},
      {file("parent: a, ", "parent: a, ",
            "tips:\n  - {name: one, link: b, pose: {xyz: [0, 0, 0], rpy: [0, 0, 0]}}\n"
            "  - {name: one, link: c, pose: {xyz: [0, 0, 0], rpy: [0, 0, 0]}}\n"),
       "tips[1].name: 'one' repeats tips[0]"},
      {file("parent: a, ", "parent: a, ",
            "tips:\n  - {name: one, link: b, pose: {xyz: [0, 0, 0], rpy: [0, 0, 0]}}\n"
            "  - {name: two, link: q, pose: {xyz: [0, 0, 0], rpy: [0, 0, 0]}}\n"),
       "tips[1].link: 'q' is not a link"},
  };
  for (const auto& [text, says] : bad) {
    try {
      parse_device(text, "t.yaml");
      ADD_FAILURE() << "accepted:\n" << text;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
    }
  }
}

// A joint axis that is not a unit vector is normalised once: the file written
// from the model reads back to the same model and writes the same text (the
// fuzzer's finding: [0, 5, -1] normalised again moved a last bit).
TEST(DeviceIo, AnAxisNormalisedOnceRoundTrips) {
  for (const char* axis : {"[0, 5, -1]", "[-1, 0, 1]", "[0.3, 0.4, 1e-3]", "[1e-100, 0, 3e-100]"}) {
    SCOPED_TRACE(axis);
    const std::string text = fmt::format(
        "format: hapticcal-device/2\nname: a\nconvention: urdf\n"
        "base: {{pose: {{xyz: [0, 0, 0], rpy: [0, 0, 0]}}}}\nlinks:\n"
        "  - {{name: j1, origin: {{xyz: [0, 0, 0.1], rpy: [0, 0, 0]}}, axis: {},\n"
        "     limits: [-1, 1]}}\n"
        "tool: {{pose: {{xyz: [0.1, 0, 0], rpy: [0, 0, 0]}}}}\n",
        axis);
    const DeviceModel model = parse_device(text, "axis.yaml");
    EXPECT_NEAR(model.links[0].axis.norm(), 1.0, 4 * std::numeric_limits<double>::epsilon());
    const std::string yaml = device_to_yaml(model);
    const DeviceModel again = parse_device(yaml, "again.yaml");
    EXPECT_EQ(again.links[0].axis, model.links[0].axis);
    EXPECT_EQ(device_to_yaml(again), yaml);
  }
}

}  // namespace
}  // namespace hapticcal
