// The runtime's hot calls allocate nothing: every allocation of the process is
// counted (operator new / delete replaced, malloc, calloc, realloc and
// aligned_alloc interposed over glibc's __libc_* functions), and 10^5 calls of
// compensate + forward + jacobian + joint_torques (and 10^4 of inverse) must leave
// the count unchanged.
// Not run under AddressSanitizer, which replaces malloc itself.
#include <cstdio>
#include <cstdlib>
#include <new>
#include <vector>

#include "hapticcal/runtime.h"

extern "C" {
void* __libc_malloc(size_t size);
void* __libc_calloc(size_t count, size_t size);
void* __libc_realloc(void* p, size_t size);
void* __libc_memalign(size_t alignment, size_t size);
void __libc_free(void* p);
}

namespace {
// Plain counters: the test is single-threaded while it counts.
volatile unsigned long g_allocations = 0;
}  // namespace

extern "C" {
void* malloc(size_t size) {
  g_allocations = g_allocations + 1;
  return __libc_malloc(size);
}
void* calloc(size_t count, size_t size) {
  g_allocations = g_allocations + 1;
  return __libc_calloc(count, size);
}
void* realloc(void* p, size_t size) {
  g_allocations = g_allocations + 1;
  return __libc_realloc(p, size);
}
void* aligned_alloc(size_t alignment, size_t size) {
  g_allocations = g_allocations + 1;
  return __libc_memalign(alignment, size);
}
int posix_memalign(void** out, size_t alignment, size_t size) {
  g_allocations = g_allocations + 1;
  *out = __libc_memalign(alignment, size);
  return *out ? 0 : 12;  // ENOMEM
}
void free(void* p) { __libc_free(p); }
}

void* operator new(size_t size) {
  g_allocations = g_allocations + 1;
  if (void* p = __libc_malloc(size ? size : 1)) return p;
  throw std::bad_alloc();
}
void* operator new[](size_t size) { return operator new(size); }
void operator delete(void* p) noexcept { __libc_free(p); }
void operator delete[](void* p) noexcept { __libc_free(p); }
void operator delete(void* p, size_t) noexcept { __libc_free(p); }
void operator delete[](void* p, size_t) noexcept { __libc_free(p); }

int main(int argc, char** argv) {
  if (argc != 2 && argc != 3) {
    std::fprintf(stderr, "usage: runtime_alloc_test MODEL_FILE [URDF_TIP]\n");
    return 2;
  }
  char message[256];
  hapticcal_model* model = nullptr;
  const unsigned long before_load = g_allocations;
  if (hapticcal_load(argv[1], argc == 3 ? argv[2] : nullptr, nullptr, &model, message,
                     sizeof message) != HAPTICCAL_OK) {
    std::fprintf(stderr, "load failed: %s\n", message);
    return 1;
  }
  // The counter works: loading a model allocates.
  if (g_allocations == before_load) {
    std::fprintf(stderr, "FAIL: the allocation counter saw nothing during load\n");
    return 1;
  }
  const int n = hapticcal_dof(model);
  std::vector<double> q(n), joint(n), J(6 * n), tau(n), start(n), back(n);
  long inverse_calls = 0, inverse_converged = 0;
  double T[16];
  const double F[6] = {1, -2, 3, 0.1, 0.2, -0.3};
  int failures = 0;
  auto cycle = [&](long k) {
    for (int i = 0; i < n; ++i) q[i] = 0.5 * ((k * (i + 3)) % 101) / 101.0 - 0.25;
    failures += hapticcal_compensate(model, q.data(), joint.data()) != HAPTICCAL_OK;
    failures += hapticcal_forward(model, q.data(), T) != HAPTICCAL_OK;
    failures += hapticcal_jacobian(model, q.data(), HAPTICCAL_FRAME_MEASUREMENT, J.data(), T) !=
                HAPTICCAL_OK;
    failures += hapticcal_jacobian(model, q.data(), HAPTICCAL_FRAME_TOOL, J.data(), nullptr) !=
                HAPTICCAL_OK;
    failures += hapticcal_joint_torques(model, q.data(), F, HAPTICCAL_FRAME_MEASUREMENT,
                                        tau.data()) != HAPTICCAL_OK;
    failures += hapticcal_joint_torques(model, q.data(), F, HAPTICCAL_FRAME_TOOL, tau.data()) !=
                HAPTICCAL_OK;
    // Inverse kinematics back to the pose at q, from readings 0.01 rad away:
    // every tenth cycle (it evaluates the model many times).
    if (k % 10 == 0) {
      for (int i = 0; i < n; ++i) start[i] = q[i] + 0.01;
      hapticcal_inverse_result found;
      failures +=
          hapticcal_inverse(model, T, 1, start.data(), 0, back.data(), &found) != HAPTICCAL_OK;
      inverse_converged += found.status != HAPTICCAL_INVERSE_NOT_CONVERGED;
      ++inverse_calls;
    }
  };
  cycle(0);  // anything lazily set up on a first call is not the loop's
  const unsigned long before = g_allocations;
  for (long k = 1; k <= 100000; ++k) cycle(k);
  const unsigned long during = g_allocations - before;
  hapticcal_free(model);
  std::printf(
      "allocations in 10^5 cycles: %lu; failed calls: %d; inverse kinematics reached %ld of %ld; "
      "check value %.6f\n",
      during, failures, inverse_converged, inverse_calls, T[3] + J[0] + tau[0] + joint[0]);
  if (during != 0 || failures != 0 || inverse_converged < inverse_calls * 9 / 10) {
    std::fprintf(stderr, "FAIL\n");
    return 1;
  }
  return 0;
}
