// The field over many poses (batch.hpp). Poses go kLanes at a time through the one-pose steps (steps.hpp):
//
// * Lanes. Obstacle by obstacle, its signed distance and normal at the block's poses (a sphere's side by side, another
//   shape's exact distance lane by lane), then sweep 0's step at every lane at once: the damper allowance, the
//   nearest-obstacle bookkeeping and the previous twist's projection (or the wrench's repulsion sum) are straight-line
//   arithmetic, taken in SIMD instructions (`#pragma omp simd` loops over the lanes, calling the same functions as a
//   pose alone: forces.hpp's laws are written with selects so that GCC vectorises them). deflect, whose square roots
//   and divisions a pose needs only where the twist approaches faster than the damper allows (a few per cent of a
//   grid), runs at those lanes alone. The later sweeps run lane by lane on sweep 0's geometry, kept per obstacle
//   (kCachedObstacles) instead of recomputed. Each lane takes the same operations in the same order as the one-pose
//   field, so the bits are equal (tests/core/test_field_batch.cpp, tests/field/test_core_batch.py); this file is
//   compiled without fused multiply-adds (CMakeLists.txt).
// * Rows are checked here (a finite position, a finite quaternion of norm >= kMinQuaternionNorm), not by a pass of
//   NumPy before the call; a pose whose quaternion repeats the previous row's bits (a grid at one orientation)
//   reuses its rotation term.
// * Threads (std::thread, from kParallelFrom poses) draw chunks of kChunk poses; each has its own scratch. A value
//   does not depend on the thread count: every pose is computed alone.
#include "field/batch.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <system_error>
#include <thread>
#include <vector>

#include "field/forces.hpp"
#include "field/steps.hpp"

namespace pfield::field {
namespace {

constexpr std::size_t kLanes = 8;  // poses side by side: two AVX2 registers of doubles, one of AVX-512
// Sweep 0's geometry of each obstacle (kRows rows of kLanes values) is kept for the later sweeps up to this many
// obstacles (320 bytes each); beyond, one obstacle's rows are reused and the later sweeps recompute.
constexpr std::size_t kCachedObstacles = 4096;
enum GeometryRow : std::size_t { kDistance, kNormalX, kNormalY, kNormalZ, kAllowance, kRows };
// One obstacle's geometry rows (kRows x kLanes values, five cache lines): aligned, so that one thread's rows never
// share a cache line with another's (the threads write theirs for every obstacle of every block).
struct alignas(64) ObstacleRows {
  double values[kRows * kLanes];
};

// q / |q| (computed as q * (1 / |q|)) when q is finite with |q| >= kMinQuaternionNorm; false otherwise. Components
// whose squares would overflow are scaled by the largest first, as pfield.spatial.normalize_quaternion does, so a
// quaternion a Pose accepts is accepted here too.
bool unit_quaternion(const double* o, Quat& q) {
  double c[4] = {o[0], o[1], o[2], o[3]};
  const double largest = std::max(std::max(std::abs(c[0]), std::abs(c[1])), std::max(std::abs(c[2]), std::abs(c[3])));
  if (largest > 1e150 && std::isfinite(largest))
    for (double& value : c) value /= largest;
  const double norm = std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2] + c[3] * c[3]);
  if (!(std::isfinite(norm) && norm >= kMinQuaternionNorm)) return false;
  const double inverse = 1.0 / norm;
  q = {c[0] * inverse, c[1] * inverse, c[2] * inverse, c[3] * inverse};
  return true;
}

// Reads the rows of a batch: a row's position, and a term of its unit quaternion (the twist's omega, the wrench's
// torque) that is reused while the rows repeat the quaternion as given, bit for bit (so never a NaN).
class RowReader {
 public:
  explicit RowReader(const Poses& poses) : poses_(poses) {}

  // false when row k is not valid
  template <class TermOf>
  bool read(std::size_t k, Vec3& position, Vec3& term, const TermOf& term_of) {
    const double* p = poses_.positions + 3 * k;
    if (!(std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]))) return false;
    const double* o = poses_.orientations + (poses_.one_orientation ? 0 : 4 * k);
    if (!filled_ || std::memcmp(o, given_, sizeof given_) != 0) {
      Quat q;
      if (!unit_quaternion(o, q)) return false;
      std::memcpy(given_, o, sizeof given_);
      term_ = term_of(q);
      filled_ = true;
    }
    position = {p[0], p[1], p[2]};
    term = term_;
    return true;
  }

 private:
  const Poses& poses_;
  double given_[4] = {};
  Vec3 term_;
  bool filled_ = false;
};

// A block of kLanes poses, one value per lane in each array (structure of arrays, what SIMD loads take). The twist
// keeps a steps::DamperState per lane; the wrench keeps its force in v.
struct Block {
  alignas(64) double px[kLanes], py[kLanes], pz[kLanes];
  alignas(64) double vx[kLanes], vy[kLanes], vz[kLanes];
  alignas(64) double sx[kLanes], sy[kLanes], sz[kLanes];
  alignas(64) double clearance[kLanes], mx[kLanes], my[kLanes], mz[kLanes];
  alignas(64) double bound[kLanes], excess[kLanes];
  alignas(64) std::int64_t nearest[kLanes];
  alignas(64) int active[kLanes], active_previous[kLanes];

  Vec3 position(std::size_t j) const { return {px[j], py[j], pz[j]}; }
  Vec3 v(std::size_t j) const { return {vx[j], vy[j], vz[j]}; }
  void set_v(std::size_t j, const Vec3& value) { vx[j] = value.x, vy[j] = value.y, vz[j] = value.z; }

  // Lane j's sweep state seen in place (the members steps::first_sweep_track reads and writes).
  struct Vec3Ref {
    double& x;
    double& y;
    double& z;
  };
  struct LaneState {
    Vec3Ref v, s, m;
    double& clearance;
    std::int64_t& nearest;
    int& active_previous;
  };
  LaneState lane(std::size_t j) {
    return {{vx[j], vy[j], vz[j]}, {sx[j], sy[j], sz[j]}, {mx[j], my[j], mz[j]},
            clearance[j], nearest[j], active_previous[j]};
  }

  steps::DamperState state(std::size_t j) const {
    steps::DamperState st;
    st.v = v(j);
    st.s = {sx[j], sy[j], sz[j]};
    st.active = active[j];
    st.active_previous = active_previous[j];
    st.clearance = clearance[j];
    st.nearest = nearest[j];
    st.m = {mx[j], my[j], mz[j]};
    return st;
  }

  void set_state(std::size_t j, const steps::DamperState& st) {
    set_v(j, st.v);
    sx[j] = st.s.x, sy[j] = st.s.y, sz[j] = st.s.z;
    active[j] = st.active;
    active_previous[j] = st.active_previous;
    clearance[j] = st.clearance;
    nearest[j] = st.nearest;
    mx[j] = st.m.x, my[j] = st.m.y, mz[j] = st.m.z;
  }

  // Positions of rows [k, k + width) from `read`; the lanes beyond width repeat lane 0 (computed, never written).
  template <class Read>
  std::int64_t load(std::size_t k, std::size_t width, Vec3* terms, const Read& read) {
    for (std::size_t j = 0; j < width; ++j) {
      Vec3 p;
      if (!read(k + j, p, terms[j])) return static_cast<std::int64_t>(k + j);
      px[j] = p.x, py[j] = p.y, pz[j] = p.z;
    }
    for (std::size_t j = width; j < kLanes; ++j) px[j] = px[0], py[j] = py[0], pz[j] = pz[0];
    return -1;
  }
};

// A row of `geometry`'s kRows x kLanes values.
inline double* row(double* geometry, GeometryRow r) { return geometry + r * kLanes; }
inline const double* row(const double* geometry, GeometryRow r) { return geometry + r * kLanes; }

// Obstacle i's signed distance and unit normal at every lane, into geometry's rows, and its bound into block.bound.
// A sphere's are taken side by side (its bound is its distance: steps::lower_bound and steps::sphere_normal; at a
// lane whose point is the centre, where it has no normal, the exact distance, steps::signed_distance's rule); another
// shape's lane by lane (steps::signed_distance). Where `skipped(j, bound)` (a pose alone would not look at the
// obstacle there) and at the padding lanes, the rows hold distance +inf and a zero normal, with which the steps change
// nothing, as skipping does.
template <class Skipped>
void obstacle_lanes(const Field& field, std::size_t i, std::size_t width, Block& block, double* geometry,
                    const Skipped& skipped) {
  const ObstacleAux& aux = field.aux[i];
  double* distance = row(geometry, kDistance);
  double* nx = row(geometry, kNormalX);
  double* ny = row(geometry, kNormalY);
  double* nz = row(geometry, kNormalZ);
  if (aux.sphere == 0.0) {
    for (std::size_t j = 0; j < kLanes; ++j) {
      const Vec3 p = block.position(j);
      const steps::Bound b = steps::lower_bound(aux, p);
      block.bound[j] = j < width ? b.bound : steps::kInfinity;
      if (j >= width || skipped(j, b.bound)) {
        distance[j] = steps::kInfinity;
        nx[j] = ny[j] = nz[j] = 0.0;
        continue;
      }
      const geometry::SignedDistance sd = steps::signed_distance(field, i, p, b);
      distance[j] = sd.distance;
      nx[j] = sd.normal.x, ny[j] = sd.normal.y, nz[j] = sd.normal.z;
    }
    return;
  }
  int centres = 0;
#pragma omp simd reduction(+ : centres)
  for (std::size_t j = 0; j < kLanes; ++j) {
    const steps::Bound b = steps::lower_bound(aux, block.position(j));
    const Vec3 n = steps::sphere_normal(b);
    block.bound[j] = b.bound;
    distance[j] = b.bound;
    nx[j] = n.x, ny[j] = n.y, nz[j] = n.z;
    centres += b.norm == 0.0;
  }
  if (centres == 0) return;
  for (std::size_t j = 0; j < kLanes; ++j) {
    const steps::Bound b = steps::lower_bound(aux, block.position(j));
    if (b.norm != 0.0) continue;
    const geometry::SignedDistance sd = steps::signed_distance(field, i, block.position(j), b);
    distance[j] = sd.distance;
    nx[j] = sd.normal.x, ny[j] = sd.normal.y, nz[j] = sd.normal.z;
  }
}

// Sweep 0 of obstacle i at every lane (steps::damper_sweeps' first sweep side by side) from obstacle_lanes'
// geometry: the tracking in SIMD instructions, deflect at the lanes where it binds. The allowance goes into geometry's
// last row for the later sweeps, which skip the obstacle where its bound is beyond Q, as a pose alone does (its
// distance row becomes +inf there; a sphere's bound is its distance already).
void obstacle_sweep(const Field& field, std::size_t i, std::size_t width, Block& block, double* geometry) {
  const FieldParams params = *field.params;  // a copy: no store in the loop can change it
  double* distance = row(geometry, kDistance);
  const double* nx = row(geometry, kNormalX);
  const double* ny = row(geometry, kNormalY);
  const double* nz = row(geometry, kNormalZ);
  double* allowance = row(geometry, kAllowance);
  int blocked = 0;
#pragma omp simd reduction(+ : blocked)
  for (std::size_t j = 0; j < kLanes; ++j) {
    const double allowed = steps::allowance_within(distance[j], params);
    allowance[j] = allowed;
    Block::LaneState st = block.lane(j);
    const double excess = steps::first_sweep_track(st, i, distance[j], {nx[j], ny[j], nz[j]}, allowed);
    block.excess[j] = excess;
    blocked += excess > 0.0;
  }
  if (blocked > 0) {
    for (std::size_t j = 0; j < width; ++j) {
      if (!(block.excess[j] > 0.0)) continue;
      steps::DamperState st = block.state(j);
      steps::first_sweep_deflect(st, field, i, {nx[j], ny[j], nz[j]}, allowance[j]);
      block.set_state(j, st);
    }
  }
  if (field.aux[i].sphere != 0.0) return;
  for (std::size_t j = 0; j < kLanes; ++j)
    if (block.bound[j] >= params.influence_distance) distance[j] = steps::kInfinity;
}

// Obstacle i's repulsion added to the force (kept in block.v) at every lane (steps::add_repulsion side by side) from
// obstacle_lanes' geometry; where its bound is beyond Q a pose alone skips it, so the force stays as it is there.
void obstacle_repulsion(const Field& field, Block& block, const double* geometry) {
  const FieldParams params = *field.params;
  const double* distance = row(geometry, kDistance);
  const double* nx = row(geometry, kNormalX);
  const double* ny = row(geometry, kNormalY);
  const double* nz = row(geometry, kNormalZ);
  int within = 0;  // (a reduction keeps GCC from unrolling the loop before it vectorises it)
#pragma omp simd reduction(+ : within)
  for (std::size_t j = 0; j < kLanes; ++j) {
    const Vec3 f = block.v(j);
    const Vec3 added = steps::add_repulsion(f, distance[j], {nx[j], ny[j], nz[j]}, params);
    const bool inside = block.bound[j] < params.influence_distance;
    block.set_v(j, {inside ? added.x : f.x, inside ? added.y : f.y, inside ? added.z : f.z});
    within += inside;
  }
}

class Evaluator {
 public:
  explicit Evaluator(const Field& field)
      : field_(field),
        caching_(field.obstacle_count <= kCachedObstacles),
        geometry_(std::max<std::size_t>(caching_ ? field.obstacle_count : 1, 1)) {}

  // Constrained twists of rows [begin, end) into out, each then through `finish` (when given); the first invalid
  // row, or -1.
  std::int64_t twists(const Poses& poses, std::size_t begin, std::size_t end, double* out, TwistRule finish) {
    const FieldParams params = *field_.params;
    RowReader reader(poses);
    const auto omega = [&](const Quat& q) { return steps::rotation_twist(field_, q); };
    const auto read = [&](std::size_t k, Vec3& p, Vec3& w) { return reader.read(k, p, w, omega); };
    // sweep 0 of a pose alone skips an obstacle whose bound is beyond Q and no nearer than the nearest so far
    const auto skipped = [&](std::size_t j, double bound) {
      return bound >= params.influence_distance && bound >= block_.clearance[j];
    };
    Vec3 w[kLanes];
    for (std::size_t k = begin; k < end; k += kLanes) {
      const std::size_t width = std::min(kLanes, end - k);
      const std::int64_t invalid = block_.load(k, width, w, read);
      if (invalid >= 0) return invalid;
      start_sweeps(width);
      for (std::size_t i = 0; i < field_.obstacle_count; ++i) {
        double* geometry = geometry_of(i);
        obstacle_lanes(field_, i, width, block_, geometry, skipped);
        obstacle_sweep(field_, i, width, block_, geometry);
      }
      for (std::size_t j = 0; j < width; ++j) {
        steps::DamperState st = block_.state(j);
        finish_sweeps(st, j);
        double* twist = out + 6 * (k + j);
        const Vec3 v = steps::cap_speed(st.v, params.max_linear_velocity);
        twist[0] = v.x, twist[1] = v.y, twist[2] = v.z;
        twist[3] = w[j].x, twist[4] = w[j].y, twist[5] = w[j].z;
        if (finish != nullptr) finish(twist, params);
      }
    }
    return -1;
  }

  // Raw wrenches of rows [begin, end) into out; the first invalid row, or -1.
  std::int64_t wrenches(const Poses& poses, std::size_t begin, std::size_t end, double* out) {
    const FieldParams params = *field_.params;
    RowReader reader(poses);
    const auto torque = [&](const Quat& q) { return steps::goal_torque(field_, q); };
    const auto read = [&](std::size_t k, Vec3& p, Vec3& t) { return reader.read(k, p, t, torque); };
    const auto skipped = [&](std::size_t, double bound) { return bound >= params.influence_distance; };
    const Vec3 g = field_.goal_position;
    double* geometry = geometry_[0].values;  // one obstacle's rows at a time
    Vec3 t[kLanes];
    for (std::size_t k = begin; k < end; k += kLanes) {
      const std::size_t width = std::min(kLanes, end - k);
      const std::int64_t invalid = block_.load(k, width, t, read);
      if (invalid >= 0) return invalid;
      Block& b = block_;
#pragma omp simd
      for (std::size_t j = 0; j < kLanes; ++j)
        b.set_v(j, attraction({g.x - b.px[j], g.y - b.py[j], g.z - b.pz[j]}, params.attractive_gain,
                              params.attractive_threshold));
      for (std::size_t i = 0; i < field_.obstacle_count; ++i) {
        obstacle_lanes(field_, i, width, b, geometry, skipped);
        obstacle_repulsion(field_, b, geometry);
      }
      for (std::size_t j = 0; j < width; ++j) {
        double* wrench = out + 6 * (k + j);
        wrench[0] = b.vx[j], wrench[1] = b.vy[j], wrench[2] = b.vz[j];
        wrench[3] = t[j].x, wrench[4] = t[j].y, wrench[5] = t[j].z;
      }
    }
    return -1;
  }

 private:
  double* geometry_of(std::size_t i) { return geometry_[caching_ ? i : 0].values; }

  // The block's sweeps start from the attraction twist, the previous twist zero and no obstacle seen.
  void start_sweeps(std::size_t width) {
    Block& b = block_;
    for (std::size_t j = 0; j < width; ++j) b.set_v(j, steps::attraction_twist(field_, b.position(j)));  // tanh
    for (std::size_t j = width; j < kLanes; ++j) b.set_v(j, b.v(0));
    for (std::size_t j = 0; j < kLanes; ++j) {
      b.sx[j] = b.sy[j] = b.sz[j] = 0.0;
      b.clearance[j] = steps::kInfinity;
      b.nearest[j] = -1;
      b.mx[j] = b.my[j] = b.mz[j] = 0.0;
      b.active[j] = b.active_previous[j] = 0;
    }
  }

  // Lane j's later sweeps (steps::damper_sweeps from sweep 1) on sweep 0's geometry when it is kept, else recomputed
  // as for a pose alone (beyond kCachedObstacles obstacles).
  void finish_sweeps(steps::DamperState& st, std::size_t j) {
    const Vec3 p = block_.position(j);
    steps::damper_sweeps(st, field_, 1, [&](std::size_t i, int sweep, double clearance, steps::Sighting& seen) {
      if (!caching_) return steps::sighting_at(field_, i, p, sweep, clearance, seen);
      const double* geometry = geometry_of(i);
      seen = {geometry[kDistance * kLanes + j],
              {geometry[kNormalX * kLanes + j], geometry[kNormalY * kLanes + j], geometry[kNormalZ * kLanes + j]},
              geometry[kAllowance * kLanes + j]};
      return true;  // beyond Q (its distance, or +inf where its bound is) the sweep skips it
    });
  }

  const Field& field_;
  bool caching_;
  std::vector<ObstacleRows> geometry_;  // per obstacle (see kCachedObstacles)
  Block block_{};
};

// Runs evaluate(evaluator, begin, end) (-> the first invalid row of [begin, end) or -1) over [0, n) on `threads`
// threads drawing chunks of kChunk rows; the calling thread is one of them. Returns the first invalid row overall.
BatchResult run(const Field& field, std::size_t n, BatchOptions options,
                const std::function<std::int64_t(Evaluator&, std::size_t, std::size_t)>& evaluate) {
  unsigned threads = options.threads;
  if (threads == 0) threads = n < kParallelFrom ? 1u : std::max(1u, std::thread::hardware_concurrency());
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  threads = static_cast<unsigned>(std::min<std::size_t>(threads, std::max<std::size_t>(chunks, 1)));
  std::vector<Evaluator> evaluators(threads, Evaluator(field));  // the scratch, allocated where a failure can throw
  if (threads == 1) return {evaluate(evaluators[0], 0, n)};
  constexpr std::int64_t kNone = std::numeric_limits<std::int64_t>::max();
  std::atomic<std::size_t> next{0};
  std::atomic<std::int64_t> first_invalid{kNone};
  const auto work = [&](Evaluator& evaluator) {
    for (;;) {
      const std::size_t chunk = next.fetch_add(1, std::memory_order_relaxed);
      if (chunk >= chunks) return;
      const std::size_t begin = chunk * kChunk;
      // an earlier row is already invalid: the batch's answer is known
      if (static_cast<std::int64_t>(begin) > first_invalid.load(std::memory_order_relaxed)) return;
      const std::int64_t invalid = evaluate(evaluator, begin, std::min(n, begin + kChunk));
      if (invalid < 0) continue;
      std::int64_t seen = first_invalid.load(std::memory_order_relaxed);
      while (invalid < seen && !first_invalid.compare_exchange_weak(seen, invalid, std::memory_order_relaxed)) {
      }
    }
  };
  std::vector<std::thread> workers;
  workers.reserve(threads - 1);
  for (unsigned t = 1; t < threads; ++t) {
    try {
      workers.emplace_back(work, std::ref(evaluators[t]));
    } catch (const std::system_error&) {  // no more threads to be had: the ones running share the chunks
      break;
    }
  }
  work(evaluators[0]);
  for (std::thread& worker : workers) worker.join();
  const std::int64_t invalid = first_invalid.load();
  return {invalid == kNone ? -1 : invalid};
}

}  // namespace

BatchResult batch_twists(const Field& field, const Poses& poses, double* out, BatchOptions options) {
  return run(field, poses.count, options, [&](Evaluator& evaluator, std::size_t begin, std::size_t end) {
    return evaluator.twists(poses, begin, end, out, options.finish_twist);
  });
}

BatchResult batch_wrenches(const Field& field, const Poses& poses, double* out, BatchOptions options) {
  return run(field, poses.count, options, [&](Evaluator& evaluator, std::size_t begin, std::size_t end) {
    return evaluator.wrenches(poses, begin, end, out);
  });
}

}  // namespace pfield::field
