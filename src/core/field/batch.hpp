// The field over many poses: the constrained twists (without a previous twist) and the raw wrenches of N poses, on
// every core from kParallelFrom poses. Each pose's values are those of the one-pose field (evaluate.hpp) to the
// bit, whatever the batch size or the thread count: the batch takes the same steps (steps.hpp) in the same order,
// only several poses side by side (see batch.cpp).
#pragma once

#include <cstddef>
#include <cstdint>

#include "field/evaluate.hpp"

namespace pfield::field {

// Below this many poses the calling thread works alone: a second thread cost up to ~35 us to start and join (2-core
// machine under load), which 4096 poses repay (measured: 10 spheres, 4096 twists 610 us on one thread, 340 us on
// two; wrenches 220 / 160 us; without obstacles, where a wrench costs 8 ns, two threads win only from ~16 000 poses).
constexpr std::size_t kParallelFrom = 4096;
// Poses a thread takes at a time: the threads draw chunks until none is left, so a slow region (meshes, crowded
// spheres) or a thread that starts late leaves no thread idle.
constexpr std::size_t kChunk = 256;

// N poses as given: positions (N, 3) and orientations (N, 4), or one orientation (4) for every position. A row is
// valid when its position is finite and its quaternion finite with a norm of at least kMinQuaternionNorm; the batch
// normalises it (q / |q|, computed as q * (1 / |q|)).
struct Poses {
  const double* positions = nullptr;
  const double* orientations = nullptr;
  std::size_t count = 0;
  bool one_orientation = false;
};

constexpr double kMinQuaternionNorm = 1e-9;  // pfield.spatial.MIN_QUATERNION_NORM

// A rule the batch applies to each twist row (6: linear, angular) in the thread that computed it, e.g. the output
// contract (safety/limits.hpp) as the caller applies it to one pose.
using TwistRule = void (*)(double* twist, const FieldParams& params);

// threads: 0 picks one below kParallelFrom poses, else std::thread::hardware_concurrency().
struct BatchOptions {
  unsigned threads = 0;
  TwistRule finish_twist = nullptr;
};

// What a batch did: the first row that is not valid (-1: none). Rows after it may be left unwritten.
struct BatchResult {
  std::int64_t invalid_row = -1;
};

// The constrained twists (N, 6: linear, angular) without a previous twist into `out`: constrained_twist's values,
// then options.finish_twist's (when given) on each row.
BatchResult batch_twists(const Field& field, const Poses& poses, double* out, BatchOptions options = {});

// The raw wrenches (N, 6: force, torque) into `out`.
BatchResult batch_wrenches(const Field& field, const Poses& poses, double* out, BatchOptions options = {});

}  // namespace pfield::field
