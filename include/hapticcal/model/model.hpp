// The device model: a value holding the kinematic parameters, joint limits and
// transmissions of a serial chain.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <random>
#include <string>
#include <string_view>
#include <vector>

#include "hapticcal/model/transmission.hpp"

namespace hapticcal {

constexpr int kMaxDof = 32;
// The magnitudes of a coupling coefficient (DeviceModel::coupling): 0 (the
// reading unused) or within [kMinCouplingCoefficient, kMaxCouplingCoefficient]
// (gear ratios and cable drives lie far inside; 1e-300 is a typing error).
constexpr double kMinCouplingCoefficient = 1e-6;
constexpr double kMaxCouplingCoefficient = 100.0;
// Bounds of a link's mass [kg], its centre's distance from the link frame [m],
// a joint compliance [rad/N m; m/N] and gravity [m/s^2] (device files, URDF).
constexpr double kMaxLinkMass = 1e4;
constexpr double kMaxComDistance = 100.0;
constexpr double kMaxCompliance = 1.0;
constexpr double kMaxGravity = 100.0;
// The largest magnitude of a backlash [rad; m] (Link::backlash).
constexpr double kMaxBacklash = 0.1;

// How a joint's constant geometry is given.
// Standard DH with the Hayati beta (paper eq. 3):
//   A_i = Rz(theta_i) * T(a_i, 0, d_i) * Rx(alpha_i) * Ry(beta_i)
// Modified DH (Craig 1989, eq. 3.6), with a Hayati beta about the y axis at the
// foot of the new joint axis (zero: Craig's transform):
//   A_i = Rx(alpha_i) * Tx(a_i) * Ry(beta_i) * Rz(theta_i) * Tz(d_i)
// beta is what a small tilt of a joint axis parallel to its neighbour needs: the
// four DH parameters cannot express it (Hayati 1983).
// URDF origin + axis:
//   A_i = Trans(x, y, z) * Rz(yaw) Ry(pitch) Rx(roll) * motion(axis, q_i + offset_i)
// (over-parametrised: the identifiability analysis holds what is redundant).
enum class Geometry { kDh, kMdh, kOrigin };
// revolute and continuous turn about the joint axis (DH, MDH: z) by q; prismatic
// translate along it by q (DH, MDH: d + q). Fixed joints only as base and tool.
enum class JointType { kRevolute, kContinuous, kPrismatic };
// The base transform B: a DH transform without joint (paper's frame "w") or a pose.
enum class BaseKind { kDh, kPose };

// What a joint geometry is, for everything that is not its transform (which
// kinematics.hpp writes once, templated on the scalar).
struct GeometryTraits {
  const char* name;    // in device files: "dh", "mdh", "urdf"
  bool dh_parameters;  // a, alpha, d, theta, beta; else an origin pose, an axis and an offset
  // The neighbour whose axis this joint's twist alpha turns into (or from):
  // +1 (DH: A_i twists joint i's axis into joint i+1's), -1 (MDH: joint i-1's
  // into joint i's), 0 none; and the word for it ("after", "before").
  int twist_partner;
  const char* partner_word;
};
const GeometryTraits& traits(Geometry geometry);
// The geometry named `name` (traits(g).name), or none.
std::optional<Geometry> geometry_named(const std::string& name);
// "revolute", "continuous", "prismatic" (device files, URDF).
const char* to_string(JointType type);
std::optional<JointType> joint_type_named(const std::string& name);

struct Link {
  std::string name;
  Geometry geometry = Geometry::kDh;
  JointType type = JointType::kRevolute;
  // DH and MDH. theta is the joint offset of a revolute joint (d of a prismatic one).
  double a = 0.0, alpha = 0.0, d = 0.0;
  double theta = 0.0;  // rad
  double beta = 0.0;   // Hayati parameter [rad]
  // URDF origin: x, y, z, roll, pitch, yaw; the unit joint axis in the joint
  // frame; the joint offset added to q [rad or m].
  std::array<double, 6> origin{};
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
  double offset = 0.0;
  double lower = 0.0, upper = 0.0;  // joint limits on q [rad; m for prismatic joints]
  // A coupled joint's own stops, on its coupled value (C q)_i [rad; m]: a
  // parallelogram's elbow turns by q3 - q2, and its stops are not a box in the
  // readings. Unbounded (the readings' limits are the joint's) unless a device
  // file's `range` (a URDF's <hapticcal_range>) gives them.
  double range_lower = -std::numeric_limits<double>::infinity();
  double range_upper = std::numeric_limits<double>::infinity();
  Transmission transmission;
  // Joint compliance (issue 25): the mass of the body the joint moves up to the
  // next joint [kg] and its centre in the link's frame (the frame after A_i)
  // [m], from which the gravity torques tau are formed; the joint's compliance
  // k [rad/N m; m/N for a prismatic joint]: the joint value v the kinematics
  // turn by becomes v + k tau(v), tau from the undeflected chain.
  double mass = 0.0;
  Eigen::Vector3d com = Eigen::Vector3d::Zero();
  double compliance = 0.0;
  // Backlash (issue 25): the joint value v becomes v + backlash s, s the side
  // the joint approached the pose from (+1 moving up in q, -1 down, 0 not
  // known: a log's dir<i> column); half the dead band [rad; m]. Applied where
  // the direction is known (evaluate, calibrate, simulate: apply_backlash);
  // compensate, the runtime and Python have no direction and leave it out.
  double backlash = 0.0;
  // Lateral compliance c [rad/N m]: the joint bends about its x axis under the
  // gravity torque about that axis (of the links it carries), turning the
  // link's twist by c tau_x: DH and MDH the alpha of this link (about the x
  // axis of the frame after, DH, or before, MDH, the joint's turn), URDF the
  // origin's roll (the origin frame's x axis; for a joint whose axis is along
  // that x the bend is the joint's own turn, which `compliance` already is).
  // tau_x is formed on the chain at the joint values, before the bend
  // (GravityModel::pose_constants).
  double lateral_compliance = 0.0;
  // The joint effects a program registered (model/joint_effect.hpp) on this
  // joint, by name: c of the term c f(q) in the joint's value.
  std::map<std::string, double> effects;

  bool prismatic() const { return type == JointType::kPrismatic; }
  bool has_range() const { return std::isfinite(range_lower) || std::isfinite(range_upper); }
  // Turns without limits (a URDF continuous joint).
  bool continuous() const { return type == JointType::kContinuous; }
  // DH or MDH parameters (else an origin pose, an axis and an offset).
  bool dh_parameters() const { return traits(geometry).dh_parameters; }
};

// The flat kinematic parameter vector is a sequence of named blocks:
//   base: DH a, alpha, d, theta (4) | pose x, y, z, roll, pitch, yaw (6)
//   each joint: DH/MDH a, alpha, d, theta, beta (5) |
//               origin x, y, z, roll, pitch, yaw, offset (7)
//   tool: x, y, z, roll, pitch, yaw (6)
//   instrument: zero (1), only while step 2 estimates a distance instrument's
//     zero with the device (DeviceModel::instrument_zero)
//   joint errors: the step-2 parameters of the joint-error families fitted
//     with the geometry (DeviceModel::fitted), block after block, only while
//     step 2 estimates them
constexpr int kLinkA = 0, kLinkAlpha = 1, kLinkD = 2, kLinkTheta = 3, kLinkBeta = 4;
constexpr int kLinkSlots = 5;
constexpr int kOriginX = 0, kOriginRoll = 3, kOriginPitch = 4, kOriginYaw = 5, kOriginOffset = 6;
constexpr int kOriginSlots = 7;
constexpr int kPoseSlots = 6;

// What the kinematics need of a joint besides its parameter values.
struct JointStructure {
  Geometry geometry = Geometry::kDh;
  JointType type = JointType::kRevolute;
  std::array<double, 3> axis{0, 0, 1};  // kOrigin only
  int slot = 0;                         // first slot of its block
  bool prismatic() const { return type == JointType::kPrismatic; }
};

// What the generic kinematics need besides the parameter values.
struct ChainStructure {
  BaseKind base_kind = BaseKind::kPose;
  int dof = 0;
  std::array<JointStructure, kMaxDof> joints{};
  int tool = 0;        // first slot of the tool block
  int instrument = 0;  // slots of the instrument block after the tool (0 or 1)
  int errors = 0;      // slots of the joint-error families' blocks after the instrument
  // A tree's: the slot after the last tip's tool block (0: this tool's is the
  // last). A tip's structure (DeviceModel::structure(tip)) is the chain root ->
  // tip whose slots are the tree's: its joints those of the path, its tool the
  // tip's, its vector the whole tree's.
  int tools_end = 0;
  // A tree's tips (1: a chain), each link's parent (-1: the base) and each tip's
  // last link, for tip(k).
  int tips = 1;
  std::array<int, kMaxDof> parent{};
  std::array<int, kMaxDof> tip_link{};

  // Tip k's chain: the joints on its path, its tool, the tree's vector (a
  // chain's only tip: itself).
  ChainStructure tip(int k) const;
  // The links on tip k's path, root first, into `links`; their count.
  int path(int k, int* links) const;

  // Link i's parent link (-1: the base), and the index of its frame in the
  // frames of forward_kinematics (frame 0 is the base, frame i + 1 link i's).
  int parent_of(int i) const { return tips > 1 ? parent[i] : i - 1; }
  int before(int i) const { return parent_of(i) + 1; }
  // The frame a tip's tool hangs from: the last link's (a tree's first tip's).
  int last_frame() const { return tips > 1 ? tip_link[0] + 1 : dof; }

  int base_slots() const { return base_kind == BaseKind::kDh ? 4 : kPoseSlots; }
  int num_slots() const { return errors_slot() + errors; }
  int instrument_slot() const { return tools_end ? tools_end : tool + kPoseSlots; }
  int errors_slot() const { return instrument_slot() + instrument; }
  int link_slot(int i) const { return joints[i].slot; }  // i zero-based
  int tool_slot() const { return tool; }
};

enum class ParameterUnit { kLength, kAngle };

// One kinematic parameter: its stable dotted name ("base.a", "j3.alpha",
// "tool.x", "panda_joint2.roll", "instrument.zero", "j2.sin1"), its slot in the
// flat vector, and its place: joint -1 is the base, dof the tool, dof + 1 the
// instrument, dof + 2 a joint-error family's; element is its index in the
// block (a link's, a joint error's own: DeviceModel::FittedParameter).
// What a parameter belongs to: the base (the measurement frame), a joint's
// geometry (joint: the link), the tool, an instrument's zero, or a joint-error
// family's (family: "harmonic", "compliance", "coupling", "backlash", ...). Code
// asks this, not the block number in `joint`.
enum class ParameterBlock { kBase, kLink, kTool, kInstrument, kJointError };
struct ParameterInfo {
  std::string name;
  int slot = 0;
  ParameterUnit unit = ParameterUnit::kLength;
  int joint = 0;
  int element = 0;
  ParameterBlock block = ParameterBlock::kLink;
  const char* family = "";
  // The set-up's (base, tool, an instrument's zero) rather than the device's
  // links and joint errors.
  bool setup() const {
    return block == ParameterBlock::kBase || block == ParameterBlock::kTool ||
           block == ParameterBlock::kInstrument;
  }
};

struct DeviceModel {
  std::string name;
  BaseKind base_kind = BaseKind::kPose;
  std::array<double, 6> base{};  // DH: a, alpha, d, theta, 0, 0; pose: x, y, z, roll, pitch, yaw
  std::vector<Link> links;
  std::array<double, 6> tool{};  // x, y, z, roll, pitch, yaw
  // A tree (a URDF's chains to several tips, --tip A,B): each link's parent
  // link (-1: the base; empty: a chain, link i's parent is i - 1) and the tips
  // after the first, each a link ending a path from the base and its own tool.
  // The first tip is `tip` at link `tip_link` (-1: the last link) with `tool`.
  // The vector's tool blocks are the tips', in tip order; a tree's parameter
  // names carry the tip ("left_hand.tool.x"). A log's q1..qN are the links'.
  struct Branch {
    std::string tip;
    int link = 0;
    std::array<double, 6> tool{};
  };
  std::vector<int> parents;
  std::string tip;
  int tip_link = -1;
  std::vector<Branch> branches;
  // A distance instrument's own zero d0 [m]: a cable encoder that reads
  // |p| + d0. Present (the slot "instrument.zero" after the tool) only in the
  // problems of step 2 that estimate it with the device (calibrate, for
  // distance logs); it is the instrument's, not the device's: device files and
  // a calibrated model have none.
  std::optional<double> instrument_zero;
  // Step 2's joint-error stages of the harmonic family, one a link (none: no
  // stage; a Harmonic): errors of the joint angle the geometry cannot express,
  // fitted with it from the measurements (no external encoder). Present only in
  // the problems of step 2 that estimate them; calibrate folds them into the
  // links' transmissions (the angle v the kinematics turn by becomes
  // v + stage(v)), so device files and calibrated models have none.
  std::vector<Transmission> joint_errors;
  // Coupled joints: the joint values are a linear map of the readings, each
  // first through its own link's transmission,
  //   theta_i = sum_k C_ik (q_k + dtheta_k(q_k)) (+ the joint offset, as always):
  // a passive joint driven by others (its own reading unused: column k of C is
  // zero), J2/J3 drive coupling, a parallelogram's relative reading, an
  // actuator-to-joint matrix. dof x dof; empty means C = I (each joint its own
  // reading), which is every uncoupled model.
  Eigen::MatrixXd coupling;
  // Gravity in the base frame (frame 0, after the base transform) [m/s^2]: what
  // the links' masses weigh for joint compliance.
  Eigen::Vector3d gravity{0.0, 0.0, -9.81};

  // One step-2 parameter of a joint-error family: where its value lives (a
  // field of the model, read and written by get and set: a link's compliance,
  // a coupling coefficient; or, with neither, `value` here), its name's suffix
  // after its link's ("k": "j2.k"), its unit and its element (the family's own
  // index: a link, a coupling entry).
  struct FittedParameter {
    std::string name;
    ParameterUnit unit = ParameterUnit::kAngle;
    int link = 0;     // the link its name starts with
    int element = 0;  // the family's own index (its link unless it says otherwise)
    double (*get)(const DeviceModel&, const FittedParameter&) = nullptr;
    void (*set)(DeviceModel&, const FittedParameter&, double value) = nullptr;
    double value = 0;
  };
  // A family's parameters, one block of the vector (after the instrument's, in
  // the order of `fitted`). `family` is the family's --joint-errors name
  // (add_block keeps it in storage that outlives the model).
  struct FittedBlock {
    const char* family = "";
    std::vector<FittedParameter> parameters;
  };
  // The joint-error families' blocks step 2 estimates (identification/families/):
  // present only in the problems of step 2; calibrate folds them into the model.
  std::vector<FittedBlock> fitted;
  // The block of this family, or null.
  const FittedBlock* fitted_block(std::string_view family) const;
  FittedBlock* fitted_block(std::string_view family);
  // The first slot of this family's block (the end of the blocks if none).
  int fitted_slot(std::string_view family) const;
  // Whether this family fits a parameter of this element.
  bool fitted_element(std::string_view family, int element) const;

  bool base_is_pose() const { return base_kind == BaseKind::kPose; }
  int dof() const { return static_cast<int>(links.size()); }
  // The layout of the whole vector (a tree's: every link, the first tip's tool).
  ChainStructure structure() const;
  // Tip k's chain in the tree's vector (a chain's only tip: structure()).
  ChainStructure structure(int tip) const;

  // Trees (a chain is a tree with one tip).
  bool tree() const { return !branches.empty(); }
  int tips() const { return 1 + static_cast<int>(branches.size()); }
  int parent(int link) const { return parents.empty() ? link - 1 : parents[link]; }
  int tip_link_of(int tip) const;
  const std::array<double, 6>& tip_tool(int tip) const;
  std::array<double, 6>& tip_tool(int tip);
  const std::string& tip_name(int tip) const;
  // The links root -> tip (a chain's: every link).
  std::vector<int> path(int tip) const;
  // The first slot of tip k's tool block.
  int tool_slot(int tip) const;

  // The flat kinematic parameter vector and its inverse.
  Eigen::VectorXd kinematic_parameters() const;
  void set_kinematic_parameters(const Eigen::VectorXd& params);
  // Every slot, in slot order, with its dotted name.
  std::vector<ParameterInfo> parameter_info() const;

  // Joint values theta_i = q_i + dtheta_i(q_i) + offset_i are formed by the
  // kinematics; this returns q_i + dtheta_i(q_i), the value without the offset
  // (coupled: C (q + dtheta(q))).
  Eigen::VectorXd compensate(const Eigen::VectorXd& q) const;
  // d theta / d q = C diag(1 + dtheta_k'(q_k)), dof x dof.
  Eigen::MatrixXd reading_jacobian(const Eigen::VectorXd& q) const;

  bool coupled() const { return coupling.size() != 0; }
  // joint_i += backlash_i direction_i (direction: a log row's, dof values or
  // none).
  void apply_backlash(const Eigen::Ref<const Eigen::RowVectorXd>& direction,
                      Eigen::Ref<Eigen::VectorXd> joint) const;
  bool has_backlash() const;
  // Some joint deflects under gravity in compensate (a compliance that is not
  // step 2's parameter).
  bool compliant() const;
  bool compliance_fitted(int i) const { return fitted_element("compliance", i); }
  // Some joint bends laterally in the kinematics (Link::lateral_compliance,
  // not a step-2 parameter): its link constants depend on the pose
  // (GravityModel::pose_constants).
  bool laterally_compliant() const;
  // Whether some joint's value depends on reading k (false: a passive joint's
  // own reading, which nothing uses).
  bool reading_used(int k) const { return !coupled() || coupling.col(k).any(); }

  // The first joint whose coupled value (C q)_i is beyond its range by more
  // than `play` [rad; m], or -1.
  int outside_range(const Eigen::Ref<const Eigen::VectorXd>& q, double play = 0) const;
  // Readings within their limits (a continuous joint's: the turn its limits
  // hold) and every joint within its range: a pose the device can take.
  bool within_limits(const Eigen::Ref<const Eigen::VectorXd>& q) const;
  // The coordinates in which the limits are a box, for motions that sweep
  // them: x = M q, M's row i joint i's coupling row where the joint has a
  // range (x_i its value, within the range), the unit row elsewhere (x_i its
  // reading, within its limits). Without ranges, M is the identity.
  struct LimitCoordinates {
    Eigen::MatrixXd readings_of;                   // M^-1
    Eigen::VectorXd lower, upper;                  // of x
    Eigen::VectorXd reading_lower, reading_upper;  // the readings' limits
    bool ranged = false;                           // some joint has a range (M is not the identity)
    bool determined = true;                        // M is invertible
    // The readings of coordinates x, kept within the readings' limits (x
    // itself without ranges).
    Eigen::VectorXd readings(const Eigen::VectorXd& x) const;
    // The readings at the middle of every coordinate's interval.
    Eigen::VectorXd middle() const { return readings((lower + upper) / 2); }
  };
  LimitCoordinates limit_coordinates() const;
  // Readings drawn uniformly within the limits, drawn again (up to `draws`
  // times) while a joint is outside its range; none if every draw was.
  std::optional<Eigen::VectorXd> try_draw_readings(std::mt19937_64& rng, int draws) const;
  // The same up to kRangeDraws times; throws std::runtime_error when none is found.
  Eigen::VectorXd draw_readings(std::mt19937_64& rng) const;
};

// The draws draw_readings makes before it gives up; a device file whose ranges
// leave fewer than one box draw in a thousand within them is refused.
constexpr int kRangeDraws = 100000;

// Why `coupling` cannot be the coupling of a model with these links, or empty:
// dof x dof, finite, each C_ik 0 or of magnitude in [1e-6, 100], every joint
// using some reading, no transmission on an unused reading. A C equal to the
// identity is refused too (it is written as no coupling).
std::string coupling_problem(const Eigen::MatrixXd& coupling, const std::vector<Link>& links);

// Why a model's tree (parents, tips) is not one, or empty: at most kMaxDof
// links and tips, parents numbered before their children, each tip at a link
// of its own, none below another's (a chain: always empty).
std::string tree_problem(const DeviceModel& model);

// The parameter names of a joint's block, in slot order ("a", ..., "offset").
const std::vector<std::string>& block_names(Geometry geometry);

}  // namespace hapticcal
