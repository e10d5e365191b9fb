/* hapticcal runtime: a calibrated model in a controller's loop, through a C ABI.
 *
 * Load a model once (a device file or a URDF chain; the only call that parses,
 * allocates or may take long), then call compensate, forward, jacobian,
 * joint_torques and inverse at the control rate: they write into the caller's buffers,
 * allocate nothing, take no lock and throw nothing. A loaded model is never
 * modified, so any number of threads may call them on one model at once.
 * Valid C99 and C++.
 *
 * Conventions (SI units and radians throughout):
 * - readings r: the device's joint readings referred to the joint side (the
 *   values a device file's transmissions take as q), n = hapticcal_dof values.
 * - joint values theta = r + dtheta(r): the compensated readings, without the
 *   joint offsets (DeviceModel::compensate). The transmission of joint i
 *   depends on reading i alone, so d theta / d r is diagonal, unless the model
 *   couples its joints (a device file's `coupling`, a URDF <mimic>): then
 *   theta = C (r + dtheta(r)) and d theta / d r = C diag(1 + dtheta'(r)); a
 *   passive joint's own reading is unused (its torque is 0).
 * - T_meas_tool: the tool frame in the measurement frame, a 4 x 4 homogeneous
 *   transform, 16 doubles row-major: T[4 * row + col]; T[3], T[7], T[11] are
 *   the tool point p_meas [m]; the last row is 0 0 0 1.
 * - Jacobian: the geometric Jacobian of the tool point with respect to the
 *   joint values theta (not the readings), 6 x n column-major: J[6 * j + k] is
 *   row k of joint j's column; rows are vx vy vz (linear velocity of the tool
 *   point) then wx wy wz (angular velocity), expressed in the measurement or
 *   the tool frame. The reference point is the tool point in both frames.
 * - wrench F: fx fy fz [N] applied at the tool point, then mx my mz [N m],
 *   expressed in the frame passed alongside it.
 * - joint torques: tau_r = (d theta / d r)^T J^T F, the generalized forces
 *   conjugate to the readings [N m per rad of reading; N for a prismatic
 *   joint]. A motor that turns R times per reading radian applies tau_r / R.
 */
#ifndef HAPTICCAL_RUNTIME_H_
#define HAPTICCAL_RUNTIME_H_

#include <stddef.h>

#if defined(__GNUC__) || defined(__clang__)
#define HAPTICCAL_RUNTIME_API __attribute__((visibility("default")))
#else
#define HAPTICCAL_RUNTIME_API
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* A loaded, calibrated model: opaque, immutable after hapticcal_load. */
typedef struct hapticcal_model hapticcal_model;

typedef enum hapticcal_status {
  HAPTICCAL_OK = 0,
  HAPTICCAL_E_ARGUMENT = 1, /* a null pointer or an invalid enum value */
  HAPTICCAL_E_INPUT = 2,    /* the model file cannot be read or used */
  HAPTICCAL_E_MEMORY = 3,   /* out of memory (load only) */
  HAPTICCAL_E_INTERNAL = 4  /* anything else: a bug; the message says what */
} hapticcal_status;

/* In which frame a Jacobian or a wrench is expressed. */
typedef enum hapticcal_frame {
  HAPTICCAL_FRAME_MEASUREMENT = 0,
  HAPTICCAL_FRAME_TOOL = 1
} hapticcal_frame;

/* A static, one-line description of a status ("invalid argument", ...). */
HAPTICCAL_RUNTIME_API const char* hapticcal_status_string(hapticcal_status status);

/* Loads the calibrated model in `path`: a URDF if the name ends in .urdf (any
 * case), the chain from `root` (NULL: the URDF's root link) to `tip`; otherwise
 * a device file (YAML), for which tip and root must be NULL or "". On success
 * *model is the new model (free it with hapticcal_free) and message, if not
 * NULL, is "". On failure *model is NULL and message receives one line naming
 * the file, line and key where known, as the command line prints it
 * ("FILE:LINE: KEY: what is wrong"), cut to message_size - 1 characters.
 * message may be NULL when message_size is 0. */
HAPTICCAL_RUNTIME_API hapticcal_status hapticcal_load(const char* path, const char* tip,
                                                      const char* root, hapticcal_model** model,
                                                      char* message, size_t message_size);

/* Frees a model from hapticcal_load; NULL is ignored. */
HAPTICCAL_RUNTIME_API void hapticcal_free(hapticcal_model* model);

/* The number of joints n, or -1 if model is NULL. */
HAPTICCAL_RUNTIME_API int hapticcal_dof(const hapticcal_model* model);

/* joints[i] = theta_i = r_i + dtheta_i(r_i) for the n readings (coupled:
 * sum_k C_ik (r_k + dtheta_k(r_k))). joints may be readings (in place). */
HAPTICCAL_RUNTIME_API hapticcal_status hapticcal_compensate(const hapticcal_model* model,
                                                            const double* readings, double* joints);

/* T_meas_tool (16 doubles, row-major) for the n readings. */
HAPTICCAL_RUNTIME_API hapticcal_status hapticcal_forward(const hapticcal_model* model,
                                                         const double* readings,
                                                         double* T_meas_tool);

/* The 6 x n geometric Jacobian (column-major, see above) w.r.t. the joint values
 * at the n readings, expressed in `frame`; T_meas_tool, if not NULL, receives the
 * tool pose of the same evaluation (saves a hapticcal_forward). */
HAPTICCAL_RUNTIME_API hapticcal_status hapticcal_jacobian(const hapticcal_model* model,
                                                          const double* readings,
                                                          hapticcal_frame frame, double* J,
                                                          double* T_meas_tool);

/* The n generalized forces on the readings that render the wrench F (6
 * doubles: force at the tool point, then moment) expressed in `frame`:
 * tau_r = (d theta / d r)^T J^T F, J expressed in the same frame. */
HAPTICCAL_RUNTIME_API hapticcal_status hapticcal_joint_torques(const hapticcal_model* model,
                                                               const double* readings,
                                                               const double* wrench,
                                                               hapticcal_frame frame,
                                                               double* torques);

/* What hapticcal_inverse found. */
typedef enum hapticcal_inverse_status {
  HAPTICCAL_INVERSE_CONVERGED = 0,        /* at the target, the readings within their limits */
  HAPTICCAL_INVERSE_NEAR_SINGULARITY = 1, /* at the target, near a singularity */
  HAPTICCAL_INVERSE_OUTSIDE_LIMITS = 2,   /* at the target, a reading outside its limits */
  HAPTICCAL_INVERSE_NOT_CONVERGED = 3     /* not at the target: unreachable from the start */
} hapticcal_inverse_status;

typedef struct hapticcal_inverse_result {
  hapticcal_inverse_status status;
  int iterations;                 /* Jacobians evaluated */
  double position_error;          /* [m] at the readings returned */
  double rotation_error;          /* [rad]; 0 without orientation */
  double smallest_singular_value; /* of d pose / d readings, rotation rows x 0.1 m [m/rad] */
  int outside_limit;              /* the first reading outside its limits, or -1 */
} hapticcal_inverse_result;

/* The n readings at which the model's tool is at T_target (16 doubles,
 * row-major; its rotation ignored when orientation is 0): damped least squares
 * (Levenberg-Marquardt) from readings_start, at most max_iterations Jacobians
 * (0: 100), to 1e-9 m and 1e-9 rad. Every effect the model holds is in it
 * (transmissions, couplings, compliance under the links' weights). A solution
 * outside the readings' limits is returned and said, never clipped; below a
 * smallest singular value of 1e-3 m/rad it is near a singularity. readings may
 * be readings_start. HAPTICCAL_OK when it ran (result->status says whether it
 * reached the target); HAPTICCAL_E_ARGUMENT for a null pointer or a
 * max_iterations outside [0, 100000]. A continuous joint's reading has no
 * limits. Allocates nothing; uses about 40 KB of stack. */
HAPTICCAL_RUNTIME_API hapticcal_status hapticcal_inverse(const hapticcal_model* model,
                                                         const double* T_target, int orientation,
                                                         const double* readings_start,
                                                         int max_iterations, double* readings,
                                                         hapticcal_inverse_result* result);

#ifdef __cplusplus
} /* extern "C" */
#endif

#endif /* HAPTICCAL_RUNTIME_H_ */
