// The field's batches (src/core/field/batch.cpp): every row equals the one-pose field's value (evaluate.hpp) bit for
// bit, whatever the batch size (partial blocks of lanes and chunks), the thread count or the orientation rows, among
// spheres (side by side, a point at a centre) and boxes (lane by lane); the first invalid row is found. Run under
// AddressSanitizer and UBSan by make core-test, which also watches the lanes' padding and the threads' scratch.
#include <cmath>
#include <cstdint>
#include <algorithm>
#include <cstring>
#include <limits>
#include <vector>

#include "field/batch.hpp"
#include "field/evaluate.hpp"
#include "geometry/packed.hpp"
#include "harness.hpp"

namespace {

using namespace pfield::field;
using pfield::math::Quat;

// A small deterministic generator (64-bit LCG, top 53 bits): the same poses on every build.
struct Random {
  std::uint64_t state;
  double uniform(double low, double high) {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return low + (high - low) * static_cast<double>(state >> 11) * 0x1.0p-53;
  }
};

// Four spheres (two of them 0.1 m apart: their dampers bind together) and two boxes, one of them rotated.
struct Scene {
  std::vector<std::int64_t> kinds{0, 0, 1, 0, 1, 0};
  std::vector<double> rows;
  std::vector<ObstacleAux> aux;
  FieldParams params{1.5, 0.5, 0.3, 0.4, 0.8, 1.0, 0.5, 0.35, 0.6, 0.05, 10.0, 0.03, 1.0, 1.0, 10.0, 0.001};
  pfield::geometry::PackedView packed;
  Field field{};

  Scene() {
    const double c = std::cos(0.4), s = std::sin(0.4);
    const double identity[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, turned[9] = {c, -s, 0, s, c, 0, 0, 0, 1};
    add({0.4, 0.5, 0.5}, identity, {0.08, 0.0, 0.0}, 0.08);
    add({0.6, 0.5, 0.5}, identity, {0.08, 0.0, 0.0}, 0.08);
    add({0.3, 0.2, 0.6}, identity, {0.05, 0.1, 0.04}, std::sqrt(0.05 * 0.05 + 0.1 * 0.1 + 0.04 * 0.04));
    add({0.7, 0.8, 0.3}, identity, {0.12, 0.0, 0.0}, 0.12);
    add({0.8, 0.3, 0.7}, turned, {0.1, 0.05, 0.08}, std::sqrt(0.1 * 0.1 + 0.05 * 0.05 + 0.08 * 0.08));
    add({0.2, 0.8, 0.2}, identity, {0.03, 0.0, 0.0}, 0.03);
    packed.kinds = kinds.data();
    packed.rows = rows.data();
    packed.obstacle_count = kinds.size();
    field = {&packed, aux.data(), aux.size(), {0.9, 0.9, 0.9}, {0.0, 0.0, 0.0, 1.0}, &params};
  }

  void add(Vec3 centre, const double* rotation, Vec3 sizes, double radius) {
    rows.insert(rows.end(), {centre.x, centre.y, centre.z});
    rows.insert(rows.end(), rotation, rotation + 9);
    rows.insert(rows.end(), {sizes.x, sizes.y, sizes.z, -1.0});
    const bool sphere = kinds[aux.size()] == 0;
    aux.push_back({{0.0, 0.0, 1.0}, radius, centre, sphere ? 1.0 : 0.0});
  }
};

// n poses: random points, the sphere centres and the midpoint between the close spheres among them; quaternions
// not normalised, repeated in runs of three (the batch reuses their rotation term).
struct PoseRows {
  std::vector<double> positions, orientations;
  PoseRows(std::size_t n, std::uint64_t seed) {
    Random random{seed};
    for (std::size_t k = 0; k < n; ++k) {
      const double special[4][3] = {{0.4, 0.5, 0.5}, {0.5, 0.5, 0.5}, {0.2, 0.8, 0.2}, {0.55, 0.52, 0.5}};
      if (k % 37 < 4) {
        positions.insert(positions.end(), special[k % 37], special[k % 37] + 3);
      } else {
        for (int a = 0; a < 3; ++a) positions.push_back(random.uniform(0.0, 1.0));
      }
      if (k % 3 != 0) {
        const double previous[4] = {orientations[4 * k - 4], orientations[4 * k - 3], orientations[4 * k - 2],
                                    orientations[4 * k - 1]};
        orientations.insert(orientations.end(), previous, previous + 4);
      } else {
        for (int a = 0; a < 4; ++a) orientations.push_back(random.uniform(-3.0, 3.0));
      }
    }
  }
  Poses poses() const { return {positions.data(), orientations.data(), positions.size() / 3, false}; }
};

Quat unit(const double* o) {
  const double inverse = 1.0 / std::sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2] + o[3] * o[3]);
  return {o[0] * inverse, o[1] * inverse, o[2] * inverse, o[3] * inverse};
}

bool same_bits(const double* a, const double* b) { return std::memcmp(a, b, 6 * sizeof(double)) == 0; }

// Rows of the batch that differ from the one-pose field's value at the same pose.
std::size_t differing_rows(const Field& field, const Poses& poses, const std::vector<double>& twists,
                           const std::vector<double>& wrenches) {
  std::size_t differing = 0;
  for (std::size_t k = 0; k < poses.count; ++k) {
    const double* p = poses.positions + 3 * k;
    const Quat q = unit(poses.orientations + (poses.one_orientation ? 0 : 4 * k));
    const Twist t = constrained_twist(field, {p[0], p[1], p[2]}, q, nullptr, 0.0).twist;
    const Wrench w = field_wrench(field, {p[0], p[1], p[2]}, q);
    const double twist[6] = {t.linear.x, t.linear.y, t.linear.z, t.angular.x, t.angular.y, t.angular.z};
    const double wrench[6] = {w.force.x, w.force.y, w.force.z, w.torque.x, w.torque.y, w.torque.z};
    differing += !same_bits(twist, twists.data() + 6 * k) || !same_bits(wrench, wrenches.data() + 6 * k);
  }
  return differing;
}

}  // namespace

TEST(batch_rows_equal_the_one_pose_field_for_any_size_and_thread_count) {
  const Scene scene;
  for (std::size_t n : {std::size_t{0}, std::size_t{1}, std::size_t{7}, std::size_t{9}, std::size_t{300},
                        kParallelFrom + kChunk + 5}) {
    const PoseRows rows(n, 7 + n);
    for (unsigned threads : {1u, 3u, 0u}) {
      std::vector<double> twists(6 * n + 1), wrenches(6 * n + 1);
      CHECK(batch_twists(scene.field, rows.poses(), twists.data(), {threads}).invalid_row == -1);
      CHECK(batch_wrenches(scene.field, rows.poses(), wrenches.data(), {threads}).invalid_row == -1);
      CHECK(differing_rows(scene.field, rows.poses(), twists, wrenches) == 0);
    }
  }
}

TEST(batch_one_orientation_serves_every_row_and_a_rule_finishes_each_twist) {
  const Scene scene;
  const PoseRows rows(50, 3);
  const double shared[4] = {0.1, -0.7, 0.2, 0.9};
  const Poses poses{rows.positions.data(), shared, 50, true};
  std::vector<double> twists(6 * 50), wrenches(6 * 50);
  batch_twists(scene.field, poses, twists.data());
  batch_wrenches(scene.field, poses, wrenches.data());
  CHECK(differing_rows(scene.field, poses, twists, wrenches) == 0);
  std::vector<double> zeroed(6 * 50, 1.0);
  batch_twists(scene.field, poses, zeroed.data(), {0, [](double* twist, const FieldParams&) { twist[5] = 0.0; }});
  for (std::size_t k = 0; k < 50; ++k) CHECK(zeroed[6 * k + 5] == 0.0 && zeroed[6 * k] == twists[6 * k]);
}

TEST(batch_names_the_first_invalid_row_in_plain_and_threaded_runs) {
  const Scene scene;
  const std::size_t n = 2 * kParallelFrom + 11;
  for (unsigned threads : {1u, 2u}) {
    PoseRows rows(n, 5);
    rows.positions[3 * (n - 2) + 1] = std::numeric_limits<double>::quiet_NaN();
    std::vector<double> out(6 * n);
    CHECK(batch_twists(scene.field, rows.poses(), out.data(), {threads}).invalid_row ==
          static_cast<std::int64_t>(n - 2));
    std::fill(rows.orientations.begin() + 4 * 1000, rows.orientations.begin() + 4 * 1001, 0.0);  // zero quaternion
    CHECK(batch_wrenches(scene.field, rows.poses(), out.data(), {threads}).invalid_row == 1000);
    rows.orientations[4 * 17] = 1e200;  // its squared norm overflows: scaled first, a valid row
    CHECK(batch_twists(scene.field, rows.poses(), out.data(), {threads}).invalid_row == 1000);
    rows.orientations[4 * 17] = std::numeric_limits<double>::infinity();
    CHECK(batch_twists(scene.field, rows.poses(), out.data(), {threads}).invalid_row == 17);
    rows.positions[3 * 4] = std::numeric_limits<double>::infinity();
    CHECK(batch_wrenches(scene.field, rows.poses(), out.data(), {threads}).invalid_row == 4);
  }
}
