// A transmission kind is one file and one line: a kind written here, outside
// the library, and registered with one call, is read and written by device
// files, evaluated by the kinematics and the runtime's prepared model, and
// fitted by step 1 from external encoders, with no edit to the library.
//
// The kind, "cam": a follower that adds a once-a-turn error,
//   dtheta(q) = lift (sin(q + phase) - sin(phase)),
// written with its error alone (its derivative and parameter Jacobian are the
// library's central differences, checked here against the closed forms).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <variant>

#include "hapticcal/core/error.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model/transmission.hpp"
#include "hapticcal/model_io/device.hpp"
#include "hapticcal/study/evaluate.hpp"
#include "hapticcal/study/simulation.hpp"
#include "support/test_models.hpp"

namespace hapticcal {
namespace {

class Cam : public TransmissionDefinition {
 public:
  std::string_view name() const override { return "cam"; }
  std::vector<std::string> parameter_names() const override { return {"lift", "phase"}; }
  double error(const double* p, double q) const override {
    return p[0] * (std::sin(q + p[1]) - std::sin(p[1]));
  }
  std::string check(const double* p, double, double) const override {
    return std::abs(p[0]) < 0.1 ? "" : "lift must be within 0.1 rad";
  }
};

const Cam kCam;

// The one line.
const bool kRegistered = (register_transmission_kind(&kCam), true);

Transmission cam(double a, double phase) {
  return Transmission::Model{Extension{&kCam, {a, phase}}};
}

TEST(TransmissionKind, ItsErrorDerivativeAndJacobianMatchTheClosedForms) {
  ASSERT_TRUE(kRegistered);
  const double a = 2e-3, phase = 0.7;
  const Transmission t = cam(a, phase);
  EXPECT_EQ(t.type_name(), "cam");
  EXPECT_EQ(t.num_parameters(), 2);
  EXPECT_EQ(t.check(-1, 1), "");
  EXPECT_NE(cam(0.5, 0).check(-1, 1), "");
  const PreparedTransmission prepared(t);
  for (double q : {-2.0, -0.3, 0.0, 0.4, 1.9}) {
    EXPECT_NEAR(t.error(q), a * (std::sin(q + phase) - std::sin(phase)), 1e-15);
    EXPECT_NEAR(t.derivative(q), a * std::cos(q + phase), 1e-9) << q;
    double J[2];
    t.parameter_jacobian(q, J);
    EXPECT_NEAR(J[0], std::sin(q + phase) - std::sin(phase), 1e-8) << q;
    EXPECT_NEAR(J[1], a * (std::cos(q + phase) - std::cos(phase)), 1e-9) << q;
    EXPECT_EQ(prepared.error(q), t.error(q));
    EXPECT_EQ(prepared.derivative(q), t.derivative(q));
  }
  EXPECT_EQ(t.error(0.0), 0.0);
  // Names a built-in kind has, or one already registered, are refused.
  struct Named : Cam {
    explicit Named(std::string_view n) : n_(n) {}
    std::string_view name() const override { return n_; }
    std::string_view n_;
  };
  const Named capstan("capstan"), again("cam"), spaced("two words");
  for (const Named* d : {&capstan, &again, &spaced})
    EXPECT_THROW(register_transmission_kind(d), std::invalid_argument) << d->name();
  struct Typed : Named {
    Typed() : Named("typed") {}
    std::vector<std::string> parameter_names() const override { return {"type", "a"}; }
  };
  const Typed typed;
  EXPECT_THROW(register_transmission_kind(&typed), std::invalid_argument);
  EXPECT_EQ(find_transmission_kind("typed"), nullptr);
  // A parameter named as a geometry slot would share "j1.alpha" with it.
  struct Twisted : Named {
    Twisted() : Named("twisted") {}
    std::vector<std::string> parameter_names() const override { return {"alpha"}; }
  };
  const Twisted twisted;
  EXPECT_THROW(register_transmission_kind(&twisted), std::invalid_argument);
  // Parameters that are not finite over the range, or not referenced to home,
  // are refused by check (the device file's error names the field).
  struct Unhomed : Cam {
    double error(const double* p, double q) const override { return p[0] * std::cos(q); }
  };
  const Unhomed unhomed;
  EXPECT_NE(Transmission(Transmission::Model{Extension{&unhomed, {1e-3, 0}}}).check(-1, 1), "");
  EXPECT_NE(Transmission(Transmission::Model{Extension{&kCam, {1e-3}}}).check(-1, 1), "");
  EXPECT_NE(Transmission(Transmission::Model{Extension{}}).check(-1, 1), "");
}

TEST(TransmissionKind, DeviceFilesReadAndWriteIt) {
  ASSERT_TRUE(kRegistered);
  const std::string yaml = R"(format: hapticcal-device/1
name: cam-arm
convention: dh
base:
  pose: {xyz: [0, 0, 0], rpy: [0, 0, 0]}
links:
  - {name: j1, a: 0.1, alpha: 1.5707963267948966, d: 0.2, theta: 0, limits: [-2, 2],
     transmission: {type: cam, lift: 0.002, phase: 0.5}}
  - {name: j2, a: 0.3, alpha: 0, d: 0, theta: 0, limits: [-2, 2],
     transmission: {type: cam, lift: 0.001}}
)";
  const DeviceModel m = parse_device(yaml, "cam.yaml");
  const auto* e1 = std::get_if<Extension>(&m.links[0].transmission.model());
  const auto* e2 = std::get_if<Extension>(&m.links[1].transmission.model());
  ASSERT_TRUE(e1 && e2);
  EXPECT_EQ(e1->parameters, (std::vector<double>{0.002, 0.5}));
  EXPECT_EQ(e2->parameters, (std::vector<double>{0.001, 0.0}));  // phase absent: 0
  const DeviceModel back = parse_device(device_to_yaml(m), "back.yaml");
  for (int i = 0; i < 2; ++i) {
    EXPECT_EQ(back.links[i].transmission.parameters(), m.links[i].transmission.parameters());
    EXPECT_EQ(back.links[i].transmission.type_name(), "cam");
  }
  // A key it does not have, a value out of its range, and an unknown type are
  // one-line errors naming the field; the unknown type's lists the kind.
  auto refused = [&](const std::string& from, const std::string& to, const std::string& says) {
    std::string bad = yaml;
    bad.replace(bad.find(from), from.size(), to);
    try {
      parse_device(bad, "cam.yaml");
      ADD_FAILURE() << to << " accepted";
    } catch (const InputError& err) {
      EXPECT_NE(std::string(err.what()).find(says), std::string::npos) << err.what();
      EXPECT_EQ(std::string(err.what()).find('\n'), std::string::npos) << err.what();
    }
  };
  refused("phase: 0.5", "rise: 0.5", "links[0].transmission.rise");
  refused("lift: 0.002", "lift: 0.5", "lift must be within 0.1 rad");
  refused("type: cam, lift: 0.001", "type: cams", "cam)");
}

// Step 1 fits it from external encoders: a Panda-like arm with a cam on two
// joints, nominally a = 1 mrad and phase 0, actually 2.5 mrad / 0.6 rad and
// -1.8 mrad / -0.4 rad.
TEST(TransmissionKind, StepOneFitsItAndTheCalibratedModelCarriesIt) {
  ASSERT_TRUE(kRegistered);
  DeviceModel nominal = testing::panda_like();
  nominal.links[1].transmission = cam(1e-3, 0.0);
  nominal.links[3].transmission = cam(1e-3, 0.0);
  DeviceModel actual = nominal;
  actual.links[1].transmission = cam(2.5e-3, 0.6);
  actual.links[3].transmission = cam(-1.8e-3, -0.4);
  SimulationNoise noise;
  noise.sigma_position = 20e-6;
  const std::uint64_t seed = 51;
  const Log cal = simulate_log(actual, 200, noise, seed, false, true);
  const Log val = simulate_log(actual, 200, noise, seed + 1, false, true);
  std::printf("seed %llu, encoder noise %.2g rad\n", static_cast<unsigned long long>(seed),
              noise.sigma_ext);

  const CalibrationResult r = calibrate(nominal, cal, {});
  ASSERT_EQ(r.status, CalibrationStatus::kConverged) << r.status_reason;
  ASSERT_EQ(r.transmissions.size(), 2u);
  for (const TransmissionFit& f : r.transmissions) {
    EXPECT_EQ(f.kind, TransmissionKind::kExtension);
    EXPECT_EQ(f.type, "cam");  // what results.json and the reports print
    EXPECT_TRUE(f.converged) << f.message;
    const Eigen::VectorXd truth = actual.links[f.joint].transmission.parameters();
    for (int k = 0; k < 2; ++k) {
      EXPECT_LT(std::abs(f.value[k] - truth[k]), 3 * f.sd[k])
          << f.names[k] << " " << f.value[k] << " +- " << f.sd[k] << " (truth " << truth[k] << ")";
      EXPECT_LT(f.sd[k], 0.1 * std::abs(truth[k])) << f.names[k];
    }
    // The calibrated transmission: the fitted cam (then any harmonic stage the
    // model search kept on top of it).
    const Transmission kept = without_trailing_harmonic(r.calibrated.links[f.joint].transmission);
    EXPECT_EQ(kept.type_name(), "cam");
    EXPECT_EQ(kept.parameters(), f.value);
  }
  EXPECT_EQ(r.transmissions[0].names[1], "panda_joint2.phase");
  const double floor = evaluate(actual, val).figure("position")->stats.rms;
  const double held_out = evaluate(r.calibrated, val).figure("position")->stats.rms;
  const double before = evaluate(nominal, val).figure("position")->stats.rms;
  std::printf("cam: held-out %.4f mm (nominal %.4f mm, noise floor %.4f mm)\n", held_out * 1e3,
              before * 1e3, floor * 1e3);
  EXPECT_LT(held_out, 1.2 * floor);
  EXPECT_GT(before, 3 * floor);
}

}  // namespace
}  // namespace hapticcal
