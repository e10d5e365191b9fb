/* The runtime header as C99 (-std=c99 -pedantic -Werror): load the model given
 * as the first argument, call every function and check a value. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "hapticcal/runtime.h"

#define MAX_DOF 32

int main(int argc, char** argv) {
  hapticcal_model* model = NULL;
  char message[256];
  double q[MAX_DOF] = {0}, joint[MAX_DOF], J[6 * MAX_DOF], tau[MAX_DOF], T[16], T2[16];
  const double F[6] = {0.0, 0.0, -1.0, 0.0, 0.0, 0.0};
  hapticcal_status status;
  int n, i, k;
  double jtf;

  if (argc != 2) {
    fprintf(stderr, "usage: runtime_c99 DEVICE_FILE\n");
    return 2;
  }
  status = hapticcal_load("/no/such/device.yaml", NULL, NULL, &model, message, sizeof message);
  if (status != HAPTICCAL_E_INPUT || model != NULL || strstr(message, "device.yaml") == NULL) {
    fprintf(stderr, "FAIL: a missing file gave %s: %s\n", hapticcal_status_string(status), message);
    return 1;
  }
  status = hapticcal_load(argv[1], NULL, NULL, &model, message, sizeof message);
  if (status != HAPTICCAL_OK) {
    fprintf(stderr, "FAIL: %s: %s\n", hapticcal_status_string(status), message);
    return 1;
  }
  n = hapticcal_dof(model);
  if (n < 1 || n > MAX_DOF) {
    fprintf(stderr, "FAIL: dof %d\n", n);
    return 1;
  }
  for (i = 0; i < n; ++i) q[i] = 0.1 * (i + 1);
  if (hapticcal_compensate(model, q, joint) != HAPTICCAL_OK ||
      hapticcal_forward(model, q, T) != HAPTICCAL_OK ||
      hapticcal_jacobian(model, q, HAPTICCAL_FRAME_MEASUREMENT, J, T2) != HAPTICCAL_OK ||
      hapticcal_joint_torques(model, q, F, HAPTICCAL_FRAME_MEASUREMENT, tau) != HAPTICCAL_OK) {
    fprintf(stderr, "FAIL: a call failed\n");
    return 1;
  }
  /* The pose is homogeneous and equals the Jacobian call's; with ideal
   * transmissions (the built-in device) tau = J^T F. */
  if (T[15] != 1.0 || T[12] != 0.0 || memcmp(T, T2, sizeof T) != 0) {
    fprintf(stderr, "FAIL: pose\n");
    return 1;
  }
  for (i = 0; i < n; ++i) {
    jtf = 0.0;
    for (k = 0; k < 6; ++k) jtf += J[6 * i + k] * F[k];
    if (fabs(tau[i] - jtf) > 1e-12) {
      fprintf(stderr, "FAIL: torque %d: %g vs J^T F %g\n", i, tau[i], jtf);
      return 1;
    }
  }
  if (hapticcal_forward(NULL, q, T) != HAPTICCAL_E_ARGUMENT) {
    fprintf(stderr, "FAIL: NULL model accepted\n");
    return 1;
  }
  printf("C99: %d joints, tool point %.4f %.4f %.4f m, tau_1 %.4f N m\n", n, T[3], T[7], T[11],
         tau[0]);
  hapticcal_free(model);
  return 0;
}
