// The geometry core (src/core/geometry): exact signed distances and normals of every primitive, their tie rules
// on the medial axis, the ellipsoid on its axes and off them, and a tetrahedron mesh through its BVH (faces, edges,
// vertices, a three-face tie inside, signed and unsigned), placed by an obstacle row; check_packed's refusals.
// Sizes and points are dyadic where the answer is meant to be exact, so most checks compare with ==.
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "geometry/bvh_build.hpp"
#include "geometry/mesh_bvh.hpp"
#include "geometry/packed.hpp"
#include "geometry/sdf.hpp"
#include "harness.hpp"

namespace {

using namespace pfield::geometry;

bool same(const SignedDistance& d, double distance, double nx, double ny, double nz) {
  return d.distance == distance && d.normal.x == nx && d.normal.y == ny && d.normal.z == nz;
}

bool near(const SignedDistance& d, double distance, double nx, double ny, double nz, double tolerance = 1e-15) {
  return std::abs(d.distance - distance) <= tolerance && std::abs(d.normal.x - nx) <= tolerance &&
         std::abs(d.normal.y - ny) <= tolerance && std::abs(d.normal.z - nz) <= tolerance;
}

// One obstacle row: centre c, identity rotation, sizes s, mesh index.
std::array<double, kRowWidth> row_at(Vec3 c, Vec3 s, double mesh = -1.0) {
  return {c.x, c.y, c.z, 1, 0, 0, 0, 1, 0, 0, 0, 1, s.x, s.y, s.z, mesh};
}

// The tetrahedron O X Y Z (unit legs), outward faces, in two BVH leaves of two triangles under one root.
struct Tetrahedron {
  std::vector<double> triangles, pseudo_normals, lower, upper;
  std::vector<std::int64_t> nodes, table;
  std::vector<std::int64_t> kinds{static_cast<std::int64_t>(Kind::Mesh)};
  std::array<double, kRowWidth> row = row_at({1.0, 2.0, 3.0}, {1.0, 1.0, 1.0}, 0.0);

  explicit Tetrahedron(bool watertight) {
    const std::array<Vec3, 4> v{{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
    const std::array<std::array<int, 3>, 4> faces{{{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}}};
    auto sub = [](Vec3 a, Vec3 b) { return Vec3{a.x - b.x, a.y - b.y, a.z - b.z}; };
    auto unit = [](Vec3 a) {
      const double n = std::sqrt(a.x * a.x + a.y * a.y + a.z * a.z);
      return Vec3{a.x / n, a.y / n, a.z / n};
    };
    std::array<Vec3, 4> normal{};
    for (int f = 0; f < 4; ++f) {
      const Vec3 ab = sub(v[faces[f][1]], v[faces[f][0]]), ac = sub(v[faces[f][2]], v[faces[f][0]]);
      normal[f] = unit({ab.y * ac.z - ab.z * ac.y, ab.z * ac.x - ab.x * ac.z, ab.x * ac.y - ab.y * ac.x});
    }
    // Angle-weighted vertex normals and the two-face sums of the edges (Baerentzen & Aanaes 2005).
    auto vertex_normal = [&](int vertex) {
      Vec3 sum{};
      for (int f = 0; f < 4; ++f) {
        for (int k = 0; k < 3; ++k) {
          if (faces[f][k] != vertex) continue;
          const Vec3 u = unit(sub(v[faces[f][(k + 1) % 3]], v[vertex]));
          const Vec3 w = unit(sub(v[faces[f][(k + 2) % 3]], v[vertex]));
          const double angle = std::acos(u.x * w.x + u.y * w.y + u.z * w.z);
          sum = {sum.x + angle * normal[f].x, sum.y + angle * normal[f].y, sum.z + angle * normal[f].z};
        }
      }
      return unit(sum);
    };
    auto edge_normal = [&](int a, int b) {
      Vec3 sum{};
      for (int f = 0; f < 4; ++f) {
        int shared = 0;
        for (int k = 0; k < 3; ++k) shared += faces[f][k] == a || faces[f][k] == b;
        if (shared == 2) sum = {sum.x + normal[f].x, sum.y + normal[f].y, sum.z + normal[f].z};
      }
      return unit(sum);
    };
    for (int f = 0; f < 4; ++f) {
      const auto& [a, b, c] = faces[f];
      for (int corner : {a, b, c}) triangles.insert(triangles.end(), {v[corner].x, v[corner].y, v[corner].z});
      for (Vec3 n : {normal[f], edge_normal(a, b), edge_normal(b, c), edge_normal(c, a), vertex_normal(a),
                     vertex_normal(b), vertex_normal(c)})
        pseudo_normals.insert(pseudo_normals.end(), {n.x, n.y, n.z});
    }
    nodes = {1, 2, 0, /*leaf*/ 0, 2, 1, /*leaf*/ 2, 2, 1};
    lower = {0, 0, 0, 0, 0, 0, 0, 0, 0};
    upper = {1, 1, 1, 1, 1, 1, 1, 1, 1};  // each pair of faces spans the whole unit cube
    table = {0, 3, 0, 4, watertight ? 1 : 0};
  }

  PackedView view() const {
    return {kinds.data(), row.data(), 1, triangles.data(), pseudo_normals.data(), 4, lower.data(), upper.data(),
            nodes.data(), 3, table.data(), 1};
  }
};

}  // namespace

TEST(sphere_distance_normal_and_centre) {
  CHECK(same(sphere_local({0.75, 0.0, 0.0}, 0.25), 0.5, 1.0, 0.0, 0.0));
  CHECK(same(sphere_local({0.0, -0.125, 0.0}, 0.25), -0.125, 0.0, -1.0, 0.0));
  CHECK(same(sphere_local({0.0, 0.0, 0.0}, 0.25), -0.25, 0.0, 0.0, 1.0));  // the centre: local +z
  CHECK(same(sphere_local({0.375, 0.5, 0.0}, 0.125), 0.5, 0.6, 0.8, 0.0));
}

// The boxes as columns: one point against every box in one pass gives obstacle_distance's values bit for bit, at
// points outside, on a face, inside (every tie of the inside rule) and rotated; other kinds get no slot.
TEST(box_columns_are_obstacle_distance_bit_for_bit) {
  std::vector<std::int64_t> kinds;
  std::vector<double> rows;
  const auto add = [&](Kind kind, const std::array<double, kRowWidth>& row) {
    kinds.push_back(static_cast<std::int64_t>(kind));
    rows.insert(rows.end(), row.begin(), row.end());
  };
  add(Kind::Box, row_at({0, 0, 0}, {1, 1, 1}));
  add(Kind::Sphere, row_at({3, 0, 0}, {0.5, 0, 0}));
  add(Kind::Box, row_at({0.3, -0.2, 0.5}, {0.2, 0.4, 0.1}));
  // a box turned by 30 degrees about z, and one by Rx(30 degrees) Ry(30 degrees)
  const double c = std::cos(0.5235987755982988), s = std::sin(0.5235987755982988);
  add(Kind::Box, {1, 2, 3, c, -s, 0, s, c, 0, 0, 0, 1, 0.3, 0.2, 0.1, -1});
  add(Kind::Box, {-1, 0.5, 0.2, c, 0, s, s * s, c, -s * c, -s * c, s, c * c, 0.25, 0.5, 0.75, -1});
  PackedView packed;
  packed.kinds = kinds.data();
  packed.rows = rows.data();
  packed.obstacle_count = kinds.size();
  const BoxColumns boxes(packed);
  CHECK(boxes.size() == 4 && boxes.slot[0] == 0 && boxes.slot[1] == -1 && boxes.slot[2] == 1 && boxes.slot[4] == 3);
  std::vector<double> out(boxes.size());
  std::uint64_t random = 0x2545F4914F6CDD1DULL;  // xorshift64
  const auto next = [&] {
    random ^= random << 13, random ^= random >> 7, random ^= random << 17;
    return static_cast<double>(random >> 11) * (6.0 / 9007199254740992.0) - 3.0;
  };
  std::vector<Vec3> points{{0, 0, 0}, {1, 0, 0}, {0.5, 0.5, 0}, {0.5, 0.5, 0.5}, {2, 2, 2}, {0.3, -0.2, 0.5}};
  for (int k = 0; k < 200; ++k) points.push_back({next(), next(), next()});
  for (const Vec3& p : points) {
    boxes.distances(p, out.data());
    for (std::size_t i = 0; i < kinds.size(); ++i)
      if (boxes.slot[i] >= 0) CHECK(out[static_cast<std::size_t>(boxes.slot[i])] == obstacle_distance(packed, i, p));
  }
}

TEST(box_faces_corners_and_inside_ties) {
  const double hx = 0.25, hy = 0.125, hz = 0.5;
  CHECK(same(box_local({0.75, 0.0, 0.0}, hx, hy, hz), 0.5, 1.0, 0.0, 0.0));
  CHECK(same(box_local({0.0, -0.625, 0.25}, hx, hy, hz), 0.5, 0.0, -1.0, 0.0));
  CHECK(same(box_local({0.625, 0.625, 0.0}, hx, hy, hz), 0.625, 0.6, 0.8, 0.0));  // an edge: 3-4-5
  const SignedDistance corner = box_local({-0.5, -0.375, -0.75}, hx, hy, hz);  // a corner: (0.25, 0.25, 0.25) off
  CHECK(near(corner, 0.25 * std::sqrt(3.0), -1.0 / std::sqrt(3.0), -1.0 / std::sqrt(3.0), -1.0 / std::sqrt(3.0)));
  CHECK(same(box_local({0.25, 0.0, 0.0}, hx, hy, hz), 0.0, 1.0, 0.0, 0.0));  // on a face
  CHECK(same(box_local({0.0, 0.0, 0.0}, 0.25, 0.25, 0.25), -0.25, 1.0, 0.0, 0.0));   // a cube's centre: x first
  CHECK(same(box_local({0.0, 0.0, 0.0}, 0.25, 0.5, 0.25), -0.25, 1.0, 0.0, 0.0));    // x before z
  CHECK(same(box_local({0.0, 0.0, 0.0}, 0.5, 0.25, 0.25), -0.25, 0.0, 1.0, 0.0));    // y before z
  CHECK(same(box_local({0.0, 0.0, -0.0}, 0.5, 0.5, 0.25), -0.25, 0.0, 0.0, 1.0));    // sign(-0) = +1
  CHECK(same(box_local({0.0, 0.0, -0.125}, 0.5, 0.5, 0.25), -0.125, 0.0, 0.0, -1.0));
}

TEST(cylinder_side_cap_ring_and_the_cap_wins_the_tie) {
  const double r = 0.25, hh = 0.25;
  CHECK(same(cylinder_local({0.0, 0.0, 0.0}, r, hh), -0.25, 0.0, 0.0, 1.0));         // cap and wall tie: the cap
  CHECK(same(cylinder_local({0.125, 0.0, -0.125}, r, hh), -0.125, 0.0, 0.0, -1.0));  // tie again, lower cap
  CHECK(same(cylinder_local({0.125, 0.0, 0.0}, r, hh), -0.125, 1.0, 0.0, 0.0));      // the wall is nearer
  CHECK(same(cylinder_local({0.0, -0.75, 0.125}, r, hh), 0.5, 0.0, -1.0, 0.0));      // beside the wall
  CHECK(same(cylinder_local({0.0, 0.0, 0.75}, r, hh), 0.5, 0.0, 0.0, 1.0));          // above the cap
  CHECK(same(cylinder_local({0.625, 0.0, -0.75}, r, hh), 0.625, 0.6, 0.0, -0.8));    // off the rim: 3-4-5
  CHECK(same(cylinder_local({0.0, 0.0, 0.25}, 0.125, 1.0), -0.125, 1.0, 0.0, 0.0));  // on the axis: local +x
}

TEST(capsule_caps_shaft_and_axis) {
  const double r = 0.125, hh = 0.25;
  CHECK(same(capsule_local({0.0, 0.0, 0.75}, r, hh), 0.375, 0.0, 0.0, 1.0));
  CHECK(same(capsule_local({0.0, 0.0, -0.75}, r, hh), 0.375, 0.0, 0.0, -1.0));
  CHECK(same(capsule_local({0.0, 0.5, 0.125}, r, hh), 0.375, 0.0, 1.0, 0.0));
  CHECK(same(capsule_local({0.0, 0.0, 0.125}, r, hh), -0.125, 1.0, 0.0, 0.0));  // on the axis segment: local +x
  CHECK(same(capsule_local({0.375, 0.0, 0.75}, r, hh), 0.5, 0.6, 0.0, 0.8));    // off a cap: 3-4-5 from its centre
}

TEST(ellipsoid_on_its_axes_and_at_its_centre) {
  const double a = 0.5, b = 0.125, c = 0.25;
  CHECK(same(ellipsoid_local({1.0, 0.0, 0.0}, a, b, c), 0.5, 1.0, 0.0, 0.0));
  CHECK(same(ellipsoid_local({0.0, 0.0, -0.5}, a, b, c), 0.25, 0.0, 0.0, -1.0));
  CHECK(same(ellipsoid_local({0.0, 0.0, 0.0}, a, b, c), -0.125, 0.0, 1.0, 0.0));      // the smallest axis, + side
  CHECK(same(ellipsoid_local({0.0, 0.0625, 0.0}, a, b, c), -0.0625, 0.0, 1.0, 0.0));  // inside, short axis
  CHECK(same(ellipsoid_local({0.5, 0.0, 0.0}, a, b, c), 0.0, 1.0, 0.0, 0.0));         // the long axis' vertex
  CHECK(near(ellipsoid_local({0.0, 0.0, 0.3}, 0.2, 0.2, 0.2), 0.1, 0.0, 0.0, 1.0));   // equal axes: a sphere
}

TEST(ellipsoid_off_axis_closest_point_is_on_the_surface_along_the_normal) {
  const double a = 0.5, b = 0.125, c = 0.25;
  for (const Vec3 q : {Vec3{0.3, 0.2, -0.4}, Vec3{-0.1, 0.05, 0.1}, Vec3{0.2, -0.01, 0.0}, Vec3{0.7, 0.0, 0.3}}) {
    const SignedDistance d = ellipsoid_local(q, a, b, c);
    const Vec3 x{q.x - d.distance * d.normal.x, q.y - d.distance * d.normal.y, q.z - d.distance * d.normal.z};
    CHECK_NEAR((x.x / a) * (x.x / a) + (x.y / b) * (x.y / b) + (x.z / c) * (x.z / c), 1.0, 1e-13);
    // the normal is the surface's there: parallel to (x/a^2, y/b^2, z/c^2)
    const double gx = x.x / (a * a), gy = x.y / (b * b), gz = x.z / (c * c);
    const double g = std::sqrt(gx * gx + gy * gy + gz * gz);
    CHECK_NEAR(d.normal.x, gx / g, 1e-12);
    CHECK_NEAR(d.normal.y, gy / g, 1e-12);
    CHECK_NEAR(d.normal.z, gz / g, 1e-12);
    CHECK((q.x / a) * (q.x / a) + (q.y / b) * (q.y / b) + (q.z / c) * (q.z / c) < 1.0 ? d.distance < 0.0
                                                                                    : d.distance > 0.0);
  }
}

TEST(triangle_closest_features) {
  const double t[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  const TrianglePoint face = closest_point_on_triangle(t, {0.25, 0.25, 1.0});
  CHECK(face.feature == Feature::Face && face.point.x == 0.25 && face.point.y == 0.25 && face.point.z == 0.0);
  CHECK(closest_point_on_triangle(t, {-1.0, -1.0, 0.0}).feature == Feature::VertexA);
  CHECK(closest_point_on_triangle(t, {2.0, -0.5, 0.0}).feature == Feature::VertexB);
  CHECK(closest_point_on_triangle(t, {0.0, 2.0, 0.5}).feature == Feature::VertexC);
  CHECK(closest_point_on_triangle(t, {0.5, -1.0, 0.0}).feature == Feature::EdgeAB);
  CHECK(closest_point_on_triangle(t, {1.0, 1.0, 0.0}).feature == Feature::EdgeBC);
  CHECK(closest_point_on_triangle(t, {-1.0, 0.5, 0.0}).feature == Feature::EdgeCA);
}

TEST(tetrahedron_mesh_signed_through_its_bvh) {
  const Tetrahedron tetrahedron(true);
  const PackedView packed = tetrahedron.view();
  CHECK(check_packed(packed).empty());
  const double s = 1.0 / std::sqrt(3.0), h = 1.0 / std::sqrt(2.0);
  CHECK(same(mesh_signed_distance(packed, 0, true, {0.25, 0.25, -0.5}), 0.5, 0.0, 0.0, -1.0));  // below a face
  CHECK(near(mesh_signed_distance(packed, 0, true, {1.0, 1.0, 1.0}), 2.0 * s, s, s, s, 1e-14));  // the slanted face
  CHECK(near(mesh_signed_distance(packed, 0, true, {0.5, -0.5, -0.5}), h, 0.0, -h, -h));        // off edge OX
  CHECK(near(mesh_signed_distance(packed, 0, true, {-0.5, -0.5, -0.5}), std::sqrt(0.75), -s, -s, -s));  // vertex O
  CHECK(same(mesh_signed_distance(packed, 0, true, {0.25, 0.25, 0.0}), 0.0, 0.0, 0.0, -1.0));  // on the surface
  // Inside, equally deep under the faces z = 0, y = 0 and x = 0: the first in traversal order (z = 0) wins.
  CHECK(same(mesh_signed_distance(packed, 0, true, {0.125, 0.125, 0.125}), -0.125, 0.0, 0.0, -1.0));
  const MeshClosest closest = mesh_closest_point(packed, 0, {0.125, 0.125, 0.125});
  CHECK(closest.triangle == 0 && closest.feature == Feature::Face && closest.distance_squared == 0.015625);
  // Placed at (1, 2, 3) by its obstacle row.
  CHECK(same(obstacle_signed_distance(packed, 0, {1.25, 2.25, 2.5}), 0.5, 0.0, 0.0, -1.0));
  CHECK(same(obstacle_signed_distance(packed, 0, {1.125, 2.125, 3.125}), -0.125, 0.0, 0.0, -1.0));
}

TEST(open_mesh_is_unsigned) {
  const Tetrahedron tetrahedron(false);
  CHECK(same(mesh_signed_distance(tetrahedron.view(), 0, false, {0.125, 0.125, 0.125}), 0.125, 0.0, 0.0, 1.0));
  CHECK(same(obstacle_signed_distance(tetrahedron.view(), 0, {1.125, 2.125, 3.125}), 0.125, 0.0, 0.0, 1.0));
}

TEST(mesh_cutoff_answers_with_the_bounding_box_beyond_it) {
  const Tetrahedron tetrahedron(true);
  const PackedView packed = tetrahedron.view();
  const Vec3 far{1.0 + 3.0, 2.0 + 0.5, 3.0 + 0.5};  // local (3, 0.5, 0.5): 2 m beyond the box
  CHECK(same(obstacle_signed_distance(packed, 0, far, 1.0), 2.0, 1.0, 0.0, 0.0));
  const SignedDistance exact = obstacle_signed_distance(packed, 0, far);
  CHECK(exact.distance > 2.0 && same(obstacle_signed_distance(packed, 0, far, 3.0), exact.distance, exact.normal.x,
                                     exact.normal.y, exact.normal.z));
}

TEST(dispatch_min_and_batch_over_several_obstacles) {
  const std::vector<std::int64_t> kinds{static_cast<std::int64_t>(Kind::Sphere), static_cast<std::int64_t>(Kind::Box),
                                        static_cast<std::int64_t>(Kind::Ellipsoid)};
  std::vector<double> rows;
  for (const auto& row : {row_at({1.0, 0.0, 0.0}, {0.25, 0, 0}), row_at({-1.0, 0.0, 0.0}, {0.25, 0.25, 0.25}),
                          row_at({0.0, 2.0, 0.0}, {0.5, 0.125, 0.25})})
    rows.insert(rows.end(), row.begin(), row.end());
  const PackedView packed{kinds.data(), rows.data(), 3};
  CHECK(check_packed(packed).empty());
  CHECK(same(obstacle_signed_distance(packed, 0, {1.0, 0.0, 0.0}), -0.25, 0.0, 0.0, 1.0));  // the sphere's centre
  // The origin is 0.75 from both the sphere and the box: the lower index wins.
  const NearestObstacle nearest = min_signed_distance(packed, {0.0, 0.0, 0.0});
  CHECK(nearest.index == 0 && same(nearest.nearest, 0.75, -1.0, 0.0, 0.0));
  CHECK(min_signed_distance(PackedView{}, {0.0, 0.0, 0.0}).index == -1);
  const double points[6] = {0.0, 0.0, 0.0, 0.0, 3.0, 0.0};
  double distances[6], normals[18];
  signed_distances(packed, points, 2, distances, normals);
  CHECK(distances[0] == 0.75 && distances[1] == 0.75 && distances[5] == 0.875);
  CHECK(normals[3] == 1.0 && normals[15] == 0.0 && normals[16] == 1.0 && normals[17] == 0.0);
  // an ellipsoid beyond the cutoff answers with its bounding sphere: 0.5 from the point (0, 3, 0)
  signed_distances(packed, points, 2, distances, normals, 0.1);
  CHECK(distances[5] == 0.5);
}

TEST(mesh_row_naming_no_mesh_is_nan) {
  std::vector<std::int64_t> kinds{static_cast<std::int64_t>(Kind::Mesh)};
  const auto row = row_at({0, 0, 0}, {1, 1, 1}, 0.0);
  const PackedView packed{kinds.data(), row.data(), 1};
  const SignedDistance d = obstacle_signed_distance(packed, 0, {0.0, 0.0, 0.0});
  CHECK(std::isnan(d.distance) && std::isnan(d.normal.x));
}

TEST(check_packed_refuses_broken_trees) {
  Tetrahedron tetrahedron(true);
  tetrahedron.nodes[1] = 0;  // the root's right child: itself
  CHECK(check_packed(tetrahedron.view()).find("child") != std::string::npos);
  Tetrahedron leaves(true);
  leaves.nodes[7] = 3;  // the second leaf: triangles 2..4 of 4
  CHECK(check_packed(leaves.view()).find("leaf") != std::string::npos);
  Tetrahedron root(true);
  root.table[0] = 3;
  CHECK(check_packed(root.view()).find("root") != std::string::npos);
}

TEST(bvh_build_splits_at_the_median_in_depth_first_order) {
  // Five small triangles along x, given out of order; two share a centroid (the stable sort keeps their order).
  const std::vector<double> xs{3.0, 0.0, 4.0, 1.0, 1.0};
  std::vector<double> centroids, lows, highs;
  for (double x : xs) {
    centroids.insert(centroids.end(), {x, 0.0, 0.0});
    lows.insert(lows.end(), {x - 0.25, -0.25, 0.0});
    highs.insert(highs.end(), {x + 0.25, 0.25, 0.0});
  }
  const Bvh bvh = build_bvh(centroids.data(), lows.data(), highs.data(), xs.size(), 2);
  CHECK((bvh.order == std::vector<std::int64_t>{1, 3, 4, 0, 2}));  // by x; triangles 3 and 4 tie, 3 first
  // root [0, 5) -> left [0, 2) leaf, right [2, 5) -> [2, 3) leaf, [3, 5) leaf; numbered depth first
  CHECK((bvh.nodes == std::vector<std::int64_t>{1, 2, 0, 0, 2, 1, 3, 4, 0, 2, 1, 1, 3, 2, 1}));
  CHECK(bvh.lower[0] == -0.25 && bvh.upper[0] == 4.25 && bvh.lower[2] == 0.0 && bvh.upper[1] == 0.25);
  CHECK(bvh.lower[3 * 2] == 0.75 && bvh.upper[3 * 2] == 4.25);  // the right child's box
  const std::vector<std::int64_t> kinds;
  const std::vector<std::int64_t> table{0, 5, 0, 5, 1};
  const std::vector<double> triangles(9 * xs.size(), 0.0), pseudo_normals(21 * xs.size(), 0.0);
  const PackedView packed{kinds.data(), nullptr, 0, triangles.data(), pseudo_normals.data(), xs.size(),
                          bvh.lower.data(), bvh.upper.data(), bvh.nodes.data(), bvh.nodes.size() / 3, table.data(), 1};
  CHECK(check_packed(packed).empty());
}
