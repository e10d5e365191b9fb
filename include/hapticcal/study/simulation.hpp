// The paper's simulated device and synthetic measurement logs.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "hapticcal/core/log.hpp"
#include "hapticcal/identification/measurement.hpp"
#include "hapticcal/model/model.hpp"
#include "hapticcal/study/paper.hpp"

namespace hapticcal {

struct SimulationNoise {
  double sigma_ext = kPaperSigmaE;            // external encoders [rad]
  double sigma_distance = kPaperSigmaMPaper;  // cable encoder [m]
  double sigma_position = 0;                  // tracker [m]
  double sigma_orientation = 0;               // a pose's rotation, per axis [rad]
  // Motor-encoder counts per motor turn (0: readings not quantised). The reading
  // q is the motor count times 2 pi / (counts * R), R the joint's capstan ratio
  // (1 without one); the truth follows the unquantised angle.
  double motor_counts_per_rev = 0;
  // The instruments' sds, as a measurement kind takes its own.
  InstrumentNoise instrument() const { return {sigma_distance, sigma_position, sigma_orientation}; }
};

// The reading a motor encoder of `counts` per turn gives for joint angle q
// through a drive of ratio R (no quantisation for counts <= 0).
double quantized_reading(double q, double ratio, double counts);

// A log of `poses` readings drawn uniformly within the joint limits, with
// ext<i> = q_i + dtheta_i(q_i) + c_i + noise for the joints with a transmission
// (c_i = encoder zeros: 1, 2, 3 ... mrad), and the distance and/or position of
// the actual device's tool point with noise. Reproducible for a seed. A joint
// with backlash approaches each pose from a random side (its dir<i> column).
Log simulate_log(const DeviceModel& actual, int poses, const SimulationNoise& noise,
                 std::uint64_t seed, bool distance = true, bool position = false);

// The same at the given readings (poses x dof, e.g. a plan's): noise as above,
// quantisation included.
Log simulate_log_at(const DeviceModel& actual, const Eigen::MatrixXd& readings,
                    const SimulationNoise& noise, std::uint64_t seed, bool distance = true,
                    bool position = false);

// A log measuring `type` at `readings` (poses x dof; empty: `poses` random
// readings within the limits, as simulate_log): a distance (noise
// sigma_distance), a position (sigma_position per coordinate) or a pose (the
// position, and the orientation turned by a random rotation vector of
// sigma_orientation per axis). A tree's position is every tip's point
// with that noise, one marker a tip (x1 .. z<tips>; tip_samples turns it into
// one sample a tip). Any kind but a fixture's: a sample's values are its
// MeasurementKind::simulate's (a registered kind's too: its columns).
// For kDistance the same log as simulate_log(_at).
Log simulate_measurement_log(const DeviceModel& actual, MeasurementType type, int poses,
                             const Eigen::MatrixXd& readings, const SimulationNoise& noise,
                             std::uint64_t seed);

// A fixture log (column `point`): for each socket (a name and a point in the
// measurement frame), `per_socket` configurations whose tool point is at the
// socket plus a placement error of sd `placement` [m] per axis: random readings
// within the limits, moved by reach() (kinematics.hpp: damped least squares on
// the actual device's position Jacobian) until the tool point is there (a start that ends outside
// the limits or short of the point is drawn again). Readings exact (the
// error is where the tool point sits); reproducible for a seed. Throws
// InputError if a socket cannot be reached in 1000 starts.
// With `encoders`, joints with a transmission get ext<i> columns as in
// simulate_log (encoder zeros 1, 2, 3 ... mrad, noise sd sigma_ext).
Log simulate_fixture_log(const DeviceModel& actual,
                         const std::vector<std::pair<std::string, Eigen::Vector3d>>& sockets,
                         int per_socket, double placement, std::uint64_t seed,
                         bool encoders = false, double sigma_ext = 0);
// A plane of a plane-contact simulation: a name, a point on it and its unit
// normal, in the measurement frame.
struct SimulatedPlane {
  std::string name;
  Eigen::Vector3d point, normal;
};

// A plane-contact log (column `plane`): for each plane, `per_plane`
// configurations whose tool point touches it, n . p = n . point + e with a
// contact error e of sd `contact_sd` [m] along the normal: random readings
// within the limits moved onto it by reach() (kinematics.hpp), so the contacts
// spread over the plane wherever the device reaches it. Readings exact;
// reproducible for a seed; encoders as simulate_fixture_log. Throws InputError
// if a plane cannot be reached in 1000 starts.
Log simulate_plane_log(const DeviceModel& actual, const std::vector<SimulatedPlane>& planes,
                       int per_plane, double contact_sd, std::uint64_t seed, bool encoders = false,
                       double sigma_ext = 0);

// Three plates, mutually non-parallel, in front of the device: near
// default_sockets' first socket, 5 % of its distance from the origin below
// it (a floor tilted towards the device), beyond it (a wall facing the
// device) and beside it (a side wall), each tilted off the axes.
std::vector<SimulatedPlane> default_planes(const DeviceModel& model);

// Two sockets 50 mm apart where a fixture would stand: the tool point of
// `model` at readings 45 % into each joint's range, and 50 mm from it along
// the first of +x, -x, +y, -y, +z, -z of the base frame that the tool reaches
// from those readings within the limits (+x where none does: simulate then
// says the socket cannot be reached).
std::vector<std::pair<std::string, Eigen::Vector3d>> default_sockets(const DeviceModel& model);

// The experiment analogue of paper Fig. 10: a continuous random motion of
// `seconds` sampled at `rate_hz`, at rest at home at both ends (a joint whose
// limits exclude home: at their middle), each joint a sum of slow sinusoids
// within its limits; columns t, q, distance (with noise).
Log simulate_trajectory(const DeviceModel& actual, double seconds, double rate_hz,
                        const SimulationNoise& noise, std::uint64_t seed);

}  // namespace hapticcal
