/* A 1 kHz haptic controller on the hapticcal C runtime: the handle, driven by
 * simulated encoder readings, moves into a virtual wall (the paper's: a plane,
 * stiffness K = 100 N/m, F = K * penetration along the wall's normal), and each
 * cycle computes the motor torques that render the wall.
 *
 *   realtime_controller [MODEL_FILE] [--seconds S]
 *
 * MODEL_FILE is a calibrated device file (default: the built-in 7-DOF). The
 * loop wakes on an absolute 1 ms grid (clock_nanosleep, TIMER_ABSTIME,
 * CLOCK_MONOTONIC); at the end it prints the period, the wake-up lateness, the
 * compute time and the missed deadlines. Only the model load allocates; a real
 * controller would also lock its memory and run under SCHED_FIFO. */
#define _POSIX_C_SOURCE 200809L

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "hapticcal/runtime.h"

#ifndef HAPTICCAL_DEFAULT_DEVICE
#define HAPTICCAL_DEFAULT_DEVICE "data/devices/baser-7dof.yaml"
#endif

#define MAX_DOF 32
#define PERIOD_NS 1000000L                                    /* 1 kHz */
#define WALL_STIFFNESS 100.0                                  /* K [N/m] */
#define ENCODER_STEP (2.0 * 3.14159265358979323846 / 40960.0) /* rad per count */

static long long to_ns(const struct timespec* t) { return t->tv_sec * 1000000000LL + t->tv_nsec; }

static void add_ns(struct timespec* t, long ns) {
  t->tv_nsec += ns;
  while (t->tv_nsec >= 1000000000L) {
    t->tv_nsec -= 1000000000L;
    ++t->tv_sec;
  }
}

static int compare_ll(const void* a, const void* b) {
  const long long x = *(const long long*)a, y = *(const long long*)b;
  return (x > y) - (x < y);
}

/* The q-quantile (0..1) of n sorted values. */
static long long quantile(const long long* sorted, long n, double q) {
  long k = (long)(q * (double)(n - 1) + 0.5);
  return sorted[k < 0 ? 0 : k >= n ? n - 1 : k];
}

static double mean_of(const long long* v, long n) {
  double s = 0;
  long k;
  for (k = 0; k < n; ++k) s += (double)v[k];
  return s / (double)n;
}

int main(int argc, char** argv) {
  const char* path = HAPTICCAL_DEFAULT_DEVICE;
  double seconds = 2.0;
  hapticcal_model* model = NULL;
  char message[512];
  hapticcal_status status;
  int n, i, a;
  long cycles, k, missed = 0;
  double home[MAX_DOF], direction[MAX_DOF], r[MAX_DOF], tau[MAX_DOF], J[6 * MAX_DOF], T[16];
  double normal[3] = {0.0, 0.0, 1.0}, wall_offset, gain = 0, max_force = 0, max_torque = 0;
  long long *period, *lateness, *compute;
  struct timespec next, start, done;
  long long previous_wake;

  for (a = 1; a < argc; ++a) {
    if (strcmp(argv[a], "--seconds") == 0 && a + 1 < argc) {
      seconds = atof(argv[++a]);
    } else if (strcmp(argv[a], "--help") == 0 || strcmp(argv[a], "-h") == 0) {
      printf("usage: %s [MODEL_FILE] [--seconds S]\n", argv[0]);
      return 0;
    } else if (argv[a][0] == '-') {
      fprintf(stderr, "realtime_controller: unknown option %s\n", argv[a]);
      return 2;
    } else {
      path = argv[a];
    }
  }
  if (!(seconds > 0 && seconds < 3600)) {
    fprintf(stderr, "realtime_controller: --seconds must be in (0, 3600)\n");
    return 2;
  }

  status = hapticcal_load(path, NULL, NULL, &model, message, sizeof message);
  if (status != HAPTICCAL_OK) {
    fprintf(stderr, "realtime_controller: %s: %s\n", hapticcal_status_string(status), message);
    return 1;
  }
  n = hapticcal_dof(model);
  if (n > MAX_DOF) {
    fprintf(stderr, "realtime_controller: %d joints, at most %d\n", n, MAX_DOF);
    hapticcal_free(model);
    return 1;
  }

  /* The handle's path: from home readings, along J_p^T n scaled so that the
   * tool point first moves about 1 m against the normal per unit of s. The
   * wall is the plane n . p = c 5 mm below the start; the handle goes 10 mm. */
  for (i = 0; i < n; ++i) home[i] = 0.1;
  hapticcal_jacobian(model, home, HAPTICCAL_FRAME_MEASUREMENT, J, T);
  for (i = 0; i < n; ++i) {
    direction[i] = J[6 * i] * normal[0] + J[6 * i + 1] * normal[1] + J[6 * i + 2] * normal[2];
    gain += direction[i] * direction[i];
  }
  for (i = 0; i < n; ++i) direction[i] = -direction[i] / gain;
  wall_offset = normal[0] * T[3] + normal[1] * T[7] + normal[2] * T[11] - 0.005;
  printf("tool point at the home readings (0.1 each): %.9f %.9f %.9f m\n", T[3], T[7], T[11]);

  cycles = (long)(seconds * 1e9 / PERIOD_NS);
  period = malloc(sizeof *period * cycles);
  lateness = malloc(sizeof *lateness * cycles);
  compute = malloc(sizeof *compute * cycles);
  if (!period || !lateness || !compute) {
    fprintf(stderr, "realtime_controller: out of memory\n");
    return 1;
  }

  clock_gettime(CLOCK_MONOTONIC, &next);
  previous_wake = to_ns(&next);
  for (k = 0; k < cycles; ++k) {
    double t, depth, penetration, force, wrench[6];
    add_ns(&next, PERIOD_NS);
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, NULL) != 0) {
    }
    clock_gettime(CLOCK_MONOTONIC, &start);
    period[k] = to_ns(&start) - previous_wake;
    lateness[k] = to_ns(&start) - to_ns(&next);
    previous_wake = to_ns(&start);

    /* Simulated encoders: the handle's readings, quantized to counts. */
    t = (double)(k + 1) * PERIOD_NS * 1e-9;
    depth = 0.005 * (1.0 - cos(2.0 * 3.14159265358979323846 * t));
    for (i = 0; i < n; ++i)
      r[i] = floor((home[i] + depth * direction[i]) / ENCODER_STEP) * ENCODER_STEP;

    /* The wall: F = K * penetration along n, at the tool point. */
    hapticcal_forward(model, r, T);
    penetration = wall_offset - (normal[0] * T[3] + normal[1] * T[7] + normal[2] * T[11]);
    force = penetration > 0 ? WALL_STIFFNESS * penetration : 0.0;
    for (i = 0; i < 3; ++i) {
      wrench[i] = force * normal[i];
      wrench[i + 3] = 0.0;
    }
    hapticcal_joint_torques(model, r, wrench, HAPTICCAL_FRAME_MEASUREMENT, tau);
    /* Here a controller would send tau (divided by each drive's ratio) to the motors. */

    clock_gettime(CLOCK_MONOTONIC, &done);
    compute[k] = to_ns(&done) - to_ns(&start);
    {
      struct timespec deadline = next;
      add_ns(&deadline, PERIOD_NS);
      if (to_ns(&done) > to_ns(&deadline)) ++missed;
    }
    if (force > max_force) max_force = force;
    for (i = 0; i < n; ++i) {
      if (fabs(tau[i]) > max_torque) max_torque = fabs(tau[i]);
    }
  }

  /* Statistics (after the loop: sorting is not for the 1 ms budget). */
  {
    const double period_mean = mean_of(period, cycles);
    long long max_jitter = 0;
    for (k = 0; k < cycles; ++k) {
      const long long j = llabs(period[k] - PERIOD_NS);
      if (j > max_jitter) max_jitter = j;
    }
    qsort(period, cycles, sizeof *period, compare_ll);
    qsort(lateness, cycles, sizeof *lateness, compare_ll);
    qsort(compute, cycles, sizeof *compute, compare_ll);
    printf("model %s: %d joints; wall K = %.0f N/m; peak force %.3f N; peak |torque| %.4f N m\n",
           path, n, WALL_STIFFNESS, max_force, max_torque);
    printf("cycles: %ld at 1 kHz (%.2f s)\n", cycles, seconds);
    printf("period [us]: mean %.2f, median %.2f, p99 %.2f, max %.2f; max jitter %.2f\n",
           period_mean / 1e3, quantile(period, cycles, 0.5) / 1e3,
           quantile(period, cycles, 0.99) / 1e3, period[cycles - 1] / 1e3, max_jitter / 1e3);
    printf("wake-up lateness [us]: median %.2f, p99 %.2f, max %.2f\n",
           quantile(lateness, cycles, 0.5) / 1e3, quantile(lateness, cycles, 0.99) / 1e3,
           lateness[cycles - 1] / 1e3);
    printf("compute [us]: median %.3f, max %.3f\n", quantile(compute, cycles, 0.5) / 1e3,
           compute[cycles - 1] / 1e3);
    printf("missed deadlines: %ld of %ld\n", missed, cycles);
  }
  free(period);
  free(lateness);
  free(compute);
  hapticcal_free(model);
  return max_force > 0 ? 0 : 1; /* the handle must have met the wall */
}
