// Rigid transforms and elementary rotations, templated on the scalar so that the
// same code runs with double and with ceres::Jet.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <limits>

namespace hapticcal {

template <typename T>
using Vec3 = Eigen::Matrix<T, 3, 1>;
template <typename T>
using Mat3 = Eigen::Matrix<T, 3, 3>;

// T_a_b: maps coordinates expressed in frame b into frame a (p_a = R * p_b + p).
// Like an Eigen matrix, a default-constructed Frame is uninitialised (scratch
// arrays of frames cost nothing); Frame::Identity() is the identity.
template <typename T>
struct Frame {
  Mat3<T> R;
  Vec3<T> p;

  static Frame Identity() { return {Mat3<T>::Identity(), Vec3<T>::Zero()}; }
  Frame operator*(const Frame& b) const { return {R * b.R, R * b.p + p}; }
  Vec3<T> operator*(const Vec3<T>& v) const { return R * v + p; }
  Frame inverse() const {
    Mat3<T> Rt = R.transpose();
    return {Rt, -(Rt * p)};
  }
  template <typename U>
  Frame<U> cast() const {
    return {R.template cast<U>(), p.template cast<U>()};
  }
};

template <typename T>
Mat3<T> rot_x(const T& c, const T& s) {
  Mat3<T> R;
  R << T(1), T(0), T(0), T(0), c, -s, T(0), s, c;
  return R;
}
template <typename T>
Mat3<T> rot_y(const T& c, const T& s) {
  Mat3<T> R;
  R << c, T(0), s, T(0), T(1), T(0), -s, T(0), c;
  return R;
}
template <typename T>
Mat3<T> rot_z(const T& c, const T& s) {
  Mat3<T> R;
  R << c, -s, T(0), s, c, T(0), T(0), T(0), T(1);
  return R;
}

// URDF's roll-pitch-yaw: R = Rz(yaw) * Ry(pitch) * Rx(roll).
template <typename T>
Mat3<T> rpy_matrix(const T& roll, const T& pitch, const T& yaw) {
  using std::cos;
  using std::sin;
  return rot_z<T>(cos(yaw), sin(yaw)) * rot_y<T>(cos(pitch), sin(pitch)) *
         rot_x<T>(cos(roll), sin(roll));
}

// Pose from translation and URDF roll-pitch-yaw.
template <typename T>
Frame<T> pose_frame(const T& x, const T& y, const T& z, const T& roll, const T& pitch,
                    const T& yaw) {
  return {rpy_matrix(roll, pitch, yaw), Vec3<T>(x, y, z)};
}

// The same from a pose array {x, y, z, roll, pitch, yaw} (a device file's base,
// tool or URDF origin).
inline Frame<double> pose_frame(const std::array<double, 6>& v) {
  return pose_frame(v[0], v[1], v[2], v[3], v[4], v[5]);
}

// A joint's axis as a unit vector, idempotently: one already unit to a few
// rounding errors is kept bit for bit, so that a file written from a model
// reads back to the same model (normalising v / |v| again may move a last bit).
inline Eigen::Vector3d unit_axis(const Eigen::Vector3d& v) {
  const double norm = v.norm();
  return std::abs(norm - 1) <= 4 * std::numeric_limits<double>::epsilon() ? v : v / norm;
}

// Inverse of rpy_matrix for a proper rotation; pitch in [-pi/2, pi/2].
Eigen::Vector3d matrix_rpy(const Eigen::Matrix3d& R);

}  // namespace hapticcal
