// The C ABI of include/hapticcal/runtime.h over PreparedModel. Every entry point
// catches: no exception crosses the ABI. Only hapticcal_load parses and allocates.
#include "hapticcal/runtime.h"

#include <array>
#include <cstring>
#include <exception>
#include <new>
#include <string>

#include "hapticcal/core/error.hpp"
#include "hapticcal/kinematics/inverse.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model_io/model_source.hpp"

struct hapticcal_model {
  explicit hapticcal_model(const hapticcal::DeviceModel& model) : prepared(model) {
    hapticcal::reading_limits(model, lower.data(), upper.data());
  }
  const hapticcal::PreparedModel prepared;                  // const: concurrent readers share it
  std::array<double, hapticcal::kMaxDof> lower{}, upper{};  // the readings' limits
};

namespace {

constexpr int kMaxInverseIterations = 100000;  // hapticcal_inverse's bound (runtime.h)

using hapticcal::Frame;
using hapticcal::JacobianFrame;
using hapticcal::kMaxDof;

void write_message(char* message, size_t size, const char* text) {
  if (!message || size == 0) return;
  const size_t n = std::min(std::strlen(text), size - 1);
  std::memcpy(message, text, n);
  message[n] = '\0';
}

bool to_frame(hapticcal_frame frame, JacobianFrame& out) {
  if (frame == HAPTICCAL_FRAME_MEASUREMENT) {
    out = JacobianFrame::kMeasurement;
  } else if (frame == HAPTICCAL_FRAME_TOOL) {
    out = JacobianFrame::kTool;
  } else {
    return false;
  }
  return true;
}

// T_meas_tool as 16 row-major doubles.
void write_pose(const Frame<double>& T, double* out) {
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out[4 * r + c] = T.R(r, c);
    out[4 * r + 3] = T.p[r];
  }
  out[12] = out[13] = out[14] = 0.0;
  out[15] = 1.0;
}

}  // namespace

extern "C" {

const char* hapticcal_status_string(hapticcal_status status) {
  switch (status) {
    case HAPTICCAL_OK:
      return "ok";
    case HAPTICCAL_E_ARGUMENT:
      return "invalid argument";
    case HAPTICCAL_E_INPUT:
      return "the model file cannot be used";
    case HAPTICCAL_E_MEMORY:
      return "out of memory";
    case HAPTICCAL_E_INTERNAL:
      return "internal error";
  }
  return "unknown status";
}

hapticcal_status hapticcal_load(const char* path, const char* tip, const char* root,
                                hapticcal_model** model, char* message, size_t message_size) {
  if (model) *model = nullptr;
  if (!path || !model || (!message && message_size > 0)) {
    write_message(message, message_size, "hapticcal_load: path and model must not be NULL");
    return HAPTICCAL_E_ARGUMENT;
  }
  try {
    const hapticcal::DeviceModel device =
        hapticcal::load_model(path, tip ? tip : "", root ? root : "");
    if (device.tree()) {
      write_message(message, message_size,
                    (std::string(path) +
                     ": a tree of several tips: the runtime holds one chain (a URDF read to one "
                     "tip, or a chain's device file)")
                        .c_str());
      return HAPTICCAL_E_INPUT;
    }
    *model = new hapticcal_model(device);
    write_message(message, message_size, "");
    return HAPTICCAL_OK;
  } catch (const hapticcal::InputError& e) {
    write_message(message, message_size, e.what());
    return HAPTICCAL_E_INPUT;
  } catch (const std::bad_alloc&) {
    write_message(message, message_size, "out of memory");
    return HAPTICCAL_E_MEMORY;
  } catch (const std::exception& e) {
    write_message(message, message_size, e.what());
    return HAPTICCAL_E_INTERNAL;
  } catch (...) {
    write_message(message, message_size, "unknown exception");
    return HAPTICCAL_E_INTERNAL;
  }
}

void hapticcal_free(hapticcal_model* model) { delete model; }

int hapticcal_dof(const hapticcal_model* model) { return model ? model->prepared.dof() : -1; }

hapticcal_status hapticcal_compensate(const hapticcal_model* model, const double* readings,
                                      double* joints) {
  if (!model || !readings || !joints) return HAPTICCAL_E_ARGUMENT;
  try {
    model->prepared.compensate(readings, joints);
    return HAPTICCAL_OK;
  } catch (...) {
    return HAPTICCAL_E_INTERNAL;
  }
}

hapticcal_status hapticcal_forward(const hapticcal_model* model, const double* readings,
                                   double* T_meas_tool) {
  if (!model || !readings || !T_meas_tool) return HAPTICCAL_E_ARGUMENT;
  try {
    write_pose(model->prepared.forward(readings), T_meas_tool);
    return HAPTICCAL_OK;
  } catch (...) {
    return HAPTICCAL_E_INTERNAL;
  }
}

hapticcal_status hapticcal_jacobian(const hapticcal_model* model, const double* readings,
                                    hapticcal_frame frame, double* J, double* T_meas_tool) {
  JacobianFrame expressed_in;
  if (!model || !readings || !J || !to_frame(frame, expressed_in)) return HAPTICCAL_E_ARGUMENT;
  try {
    const Frame<double> T = model->prepared.forward_jacobian(readings, expressed_in, J);
    if (T_meas_tool) write_pose(T, T_meas_tool);
    return HAPTICCAL_OK;
  } catch (...) {
    return HAPTICCAL_E_INTERNAL;
  }
}

hapticcal_status hapticcal_joint_torques(const hapticcal_model* model, const double* readings,
                                         const double* wrench, hapticcal_frame frame,
                                         double* torques) {
  JacobianFrame expressed_in;
  if (!model || !readings || !wrench || !torques || !to_frame(frame, expressed_in)) {
    return HAPTICCAL_E_ARGUMENT;
  }
  try {
    const hapticcal::PreparedModel& m = model->prepared;
    std::array<double, 6 * kMaxDof> J;
    std::array<double, kMaxDof * kMaxDof> J_joint_reading;  // d theta / d r, column-major
    std::array<double, kMaxDof> tau;                        // J^T F
    const int n = m.dof();
    m.forward_jacobian(readings, expressed_in, J.data());
    m.reading_jacobian(readings, J_joint_reading.data());
    for (int i = 0; i < n; ++i) {
      const double* column = J.data() + 6 * i;
      tau[i] = 0;
      for (int k = 0; k < 6; ++k) tau[i] += column[k] * wrench[k];
    }
    for (int r = 0; r < n; ++r) {  // (d theta / d r)^T tau: column r of d theta / d r
      const double* column = J_joint_reading.data() + n * r;
      double sum = 0;
      for (int i = 0; i < n; ++i) sum += column[i] * tau[i];
      torques[r] = sum;
    }
    return HAPTICCAL_OK;
  } catch (...) {
    return HAPTICCAL_E_INTERNAL;
  }
}

hapticcal_status hapticcal_inverse(const hapticcal_model* model, const double* T_target,
                                   int orientation, const double* readings_start,
                                   int max_iterations, double* readings,
                                   hapticcal_inverse_result* result) {
  if (!model || !T_target || !readings_start || !readings || !result || max_iterations < 0 ||
      max_iterations > kMaxInverseIterations)
    return HAPTICCAL_E_ARGUMENT;
  try {
    Frame<double> target;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) target.R(r, c) = T_target[4 * r + c];
      target.p[r] = T_target[4 * r + 3];
    }
    hapticcal::InverseOptions options;
    options.orientation = orientation != 0;
    if (max_iterations > 0) options.max_iterations = max_iterations;
    const hapticcal::InverseResult found =
        hapticcal::inverse_kinematics(model->prepared, target, readings_start, readings, options,
                                      model->lower.data(), model->upper.data());
    result->status = static_cast<hapticcal_inverse_status>(found.status);
    result->iterations = found.iterations;
    result->position_error = found.position_error;
    result->rotation_error = found.rotation_error;
    result->smallest_singular_value = found.smallest_singular_value;
    result->outside_limit = found.outside_limit;
    return HAPTICCAL_OK;
  } catch (...) {
    return HAPTICCAL_E_INTERNAL;
  }
}

}  // extern "C"
