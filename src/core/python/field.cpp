// Bindings of the 3D potential field (pfield.field) and its task-space planning loop: a thin list of defs over
// field/evaluate.hpp, field/batch.hpp and planning/task_space.hpp. A Field binds a PotentialField's arrays once
// (goal, parameters, per-obstacle data, the packed obstacles), so each call passes only the pose.
#include <nanobind/nanobind.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/tuple.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <stdexcept>
#include <tuple>
#include <utility>

#include "field/batch.hpp"
#include "field/evaluate.hpp"
#include "field/forces.hpp"
#include "planning/task_space.hpp"
#include "python/arrays.hpp"
#include "python/packed.hpp"
#include "python/values.hpp"
#include "safety/limits.hpp"

namespace pfield::python {
namespace {

using namespace nb::literals;
using field::ConstrainedTwist;
using field::FieldParams;
using field::ObstacleAux;
using math::Quat;
using math::Vec3;

static_assert(sizeof(FieldParams) == 16 * sizeof(double), "FieldParams is FieldConfig.packed()'s 16 doubles");
static_assert(sizeof(ObstacleAux) == 8 * sizeof(double), "ObstacleAux is a row of obstacle_aux's (M, 8)");

using Out6 = nb::ndarray<double, nb::shape<6>, nb::c_contig, nb::device::cpu>;
using Pose7 = nb::ndarray<const double, nb::shape<7>, nb::c_contig, nb::device::cpu>;

Vec3 vec3(const double* v) { return {v[0], v[1], v[2]}; }
Quat quat(const double* v) { return {v[0], v[1], v[2], v[3]}; }

void write_twist(const field::Twist& t, double* out) {
  out[0] = t.linear.x, out[1] = t.linear.y, out[2] = t.linear.z;
  out[3] = t.angular.x, out[4] = t.angular.y, out[5] = t.angular.z;
}

void write_wrench(const field::Wrench& w, double* out) {
  out[0] = w.force.x, out[1] = w.force.y, out[2] = w.force.z;
  out[3] = w.torque.x, out[4] = w.torque.y, out[5] = w.torque.z;
}

class BoundField {
 public:
  BoundField(const Vector& goal, const Vector& params, const Rows<8>& aux, const Kinds& kinds, const Rows<16>& rows,
             const Triangles& triangles, const PseudoNormals& pseudo_normals, const Rows<3>& bvh_lower,
             const Rows<3>& bvh_upper, const Nodes& bvh_nodes, const MeshTable& mesh_table)
      : goal_(goal), params_(params), aux_(aux),
        packed_(kinds, rows, triangles, pseudo_normals, bvh_lower, bvh_upper, bvh_nodes, mesh_table) {
    if (goal.shape(0) != 7) throw std::invalid_argument("goal: expected 7 numbers (position, quaternion)");
    if (params.shape(0) != 16) throw std::invalid_argument("params: expected FieldConfig.packed()'s 16 numbers");
    if (aux.shape(0) != kinds.shape(0)) throw std::invalid_argument("aux: expected one row per obstacle");
    const double* g = goal.data();
    field_ = {&packed_.view(), reinterpret_cast<const ObstacleAux*>(aux.data()), aux.shape(0), vec3(g), quat(g + 3),
              reinterpret_cast<const FieldParams*>(params.data())};
  }

  // The constrained twist at a pose under the output contract: (linear (3,), angular (3,), the contract's outcome),
  // two new read-only arrays that pfield.spatial.twist_from_checked adopts. A previous twist beyond the speed limits
  // is scaled within them first (safety rule 3), the answer is finite and within them (rules 1 and 2). The pose's
  // arrays (3) and (4) and the previous twist's (3) and (3), or both None, are read as Doubles (the hot path of
  // PotentialField.twist: a Pose's and a Twist's arrays, validated when they were built).
  std::tuple<nb::object, nb::object, int> twist(nb::handle position, nb::handle orientation,
                                                nb::handle previous_linear, nb::handle previous_angular,
                                                double dt) const {
    const double *p = doubles(position, 3), *q = doubles(orientation, 4);
    double out[6];
    int outcome;
    if (previous_linear.is_none() || previous_angular.is_none()) {
      outcome = limited_twist(p, q, nullptr, nullptr, dt, out);
    } else {
      outcome = limited_twist(p, q, doubles(previous_linear, 3), doubles(previous_angular, 3), dt, out);
    }
    return {readonly_copy(out, 3), readonly_copy(out + 3, 3), outcome};
  }

  // PotentialField.twist's answer, a new pfield.Twist, when its arguments are the ones its hot path takes: exactly
  // a pfield.Pose, and None or exactly a pfield.Twist with a float dt in (0, inf) (python/values.hpp: read as they
  // were built and checked). Else None, and None for an answer the output contract halted (a non-finite twist):
  // PotentialField.twist then checks its arguments, and reports, in Python. The arrays are read in place through
  // borrowed pointers while the GIL is held: this call must not release it.
  nb::object twist_value(nb::handle pose, nb::handle previous, nb::handle dt) const {
    const double *p, *q;
    if (!values::read(pose, values::Kind::Pose, p, q)) return nb::none();
    double out[6];
    int outcome;
    if (previous.is_none()) {
      outcome = limited_twist(p, q, nullptr, nullptr, 0.0, out);
    } else {
      const double *l, *a;
      if (!values::read(previous, values::Kind::Twist, l, a) || !PyFloat_CheckExact(dt.ptr())) return nb::none();
      const double step = PyFloat_AS_DOUBLE(dt.ptr());
      if (!(step > 0.0 && step < std::numeric_limits<double>::infinity())) return nb::none();
      outcome = limited_twist(p, q, l, a, step, out);
    }
    if (outcome == static_cast<int>(safety::Outcome::Halted)) return nb::none();
    return values::make(values::Kind::Twist, out, out + 3);
  }

  // PreparedTwist's call: the bound pose (7,) and previous twist (6,) in, the twist into `out` (6,) under the
  // output contract; 0, or the input's defect, leaving `out` unchanged: 1 position not finite, 2 not a unit
  // quaternion within 1e-9, 3 a previous twist that is not finite.
  int evaluate(const Pose7& pose, const Vector& previous, bool use_previous, double dt, Out6& out) const {
    const double* p = pose.data();
    if (!(std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]))) return 1;
    const double norm2 = p[3] * p[3] + p[4] * p[4] + p[5] * p[5] + p[6] * p[6];
    if (!(std::abs(norm2 - 1.0) <= 2.0 * 1e-9)) return 2;
    if (use_previous && std::isnan(safety::twist_scale(previous.data(), params().max_linear_velocity,
                                                      params().max_angular_velocity)))
      return 3;
    const double* before = use_previous ? previous.data() : nullptr;
    limited_twist(p, p + 3, before, use_previous ? before + 3 : nullptr, dt, out.data());
    return 0;
  }

  // PotentialField.wrench's answer, a new pfield.Wrench, for exactly a pfield.Pose (as twist_value); else None.
  nb::object wrench_value(nb::handle pose) const {
    const double *p, *q;
    if (!values::read(pose, values::Kind::Pose, p, q)) return nb::none();
    double out[6];
    write_wrench(field::field_wrench(field_, vec3(p), quat(q)), out);
    return values::make(values::Kind::Wrench, out, out + 3);
  }

  // The raw wrench at a pose: (force (3,), torque (3,)), new read-only arrays (pfield.spatial.wrench_from_checked).
  std::tuple<nb::object, nb::object> wrench(nb::handle position, nb::handle orientation) const {
    double out[6];
    write_wrench(field::field_wrench(field_, vec3(doubles(position, 3)), quat(doubles(orientation, 4))), out);
    return {readonly_copy(out, 3), readonly_copy(out + 3, 3)};
  }

  // Twists (under the output contract, as twist()) or wrenches at N poses (field/batch.hpp), on every core from
  // field::kParallelFrom poses (threads: 0 for that rule, else how many); one orientation row may serve every
  // position. Returns (values (N, 6), the first row that is not finite or has no rotation, -1 for none).
  std::tuple<NumpyArray, std::int64_t> batch(const Rows<3>& positions, const Rows<4>& orientations, bool wrenches,
                                             unsigned threads) const {
    const std::size_t n = positions.shape(0);
    const bool one = orientations.shape(0) == 1;
    if (!one && orientations.shape(0) != n) throw std::invalid_argument("orientations: expected N rows or one");
    auto [out, data] = new_array({n, 6});
    const field::Poses poses{positions.data(), orientations.data(), n, one};
    field::BatchResult result;
    {
      nb::gil_scoped_release release;
      result = wrenches ? field::batch_wrenches(field_, poses, data, {threads})
                        : field::batch_twists(field_, poses, data, {threads, contract_row});
    }
    return {out, result.invalid_row};
  }

  double rk4_steps(const Pose7& pose, const Vector& previous, double dt, std::int64_t count) const {
    if (previous.shape(0) != 6) throw std::invalid_argument("previous: expected 6 numbers (linear, angular)");
    nb::gil_scoped_release release;
    return planning::rk4_steps(field_, pose.data(), previous.data(), dt, count);
  }

  std::tuple<std::int64_t, std::int64_t, std::int64_t> plan(const Pose7& start, double dt, double goal_tolerance,
                                                            double rotation_tolerance, std::int64_t max_iterations,
                                                            std::int64_t window, double progress,
                                                            const Cancel& cancel, OutRows<7>& poses,
                                                            OutRows<6>& twists, OutVector& clearances) const {
    const std::size_t rows = static_cast<std::size_t>(max_iterations) + 1;
    if (max_iterations < 0 || window < 1) throw std::invalid_argument("max_iterations >= 0 and window >= 1");
    if (poses.shape(0) < rows || twists.shape(0) < rows || clearances.shape(0) < rows)
      throw std::invalid_argument("poses, twists, clearances: expected max_iterations + 1 rows");
    planning::LoopResult result;
    {
      nb::gil_scoped_release release;
      result = planning::plan_task_space(field_, start.data(),
                                         {dt, goal_tolerance, rotation_tolerance, max_iterations, window, progress},
                                         cancel.data(), poses.data(), twists.data(), clearances.data());
    }
    return {result.count, static_cast<std::int64_t>(result.status), result.obstacle};
  }

 private:
  static field::Twist twist_of(const double* v) { return {{v[0], v[1], v[2]}, {v[3], v[4], v[5]}}; }
  const FieldParams& params() const { return *field_.params; }

  // The output contract on a twist (6) in place: twist(), evaluate() and the batch's rows (in its threads) take it
  // from here (safety::limit_twist, its one compiled copy, the one pfield.safety calls too).
  static safety::Outcome contract(double* twist, const FieldParams& params) {
    return safety::limit_twist(twist, params.max_linear_velocity, params.max_angular_velocity);
  }
  static void contract_row(double* twist, const FieldParams& params) { contract(twist, params); }

  // The twist under the output contract into out (6): the previous twist's linear and angular parts (3 each, or
  // both null: none) clipped to the speed limits first.
  int limited_twist(const double* position, const double* orientation, const double* previous_linear,
                    const double* previous_angular, double dt, double* out) const {
    const double vmax = params().max_linear_velocity, wmax = params().max_angular_velocity;
    const bool given = previous_linear != nullptr;
    field::Twist before{};
    if (given) {
      const double *l = previous_linear, *a = previous_angular;
      double clipped[6] = {l[0], l[1], l[2], a[0], a[1], a[2]};
      safety::limit_twist(clipped, vmax, wmax);  // a previous command beyond the limits was never sent
      before = twist_of(clipped);
    }
    const ConstrainedTwist t =
        field::constrained_twist(field_, vec3(position), quat(orientation), given ? &before : nullptr, dt);
    write_twist(t.twist, out);
    return static_cast<int>(contract(out, params()));
  }

  // the arrays the views point into, kept alive as long as this object
  Vector goal_, params_;
  Rows<8> aux_;
  PackedArrays packed_;
  field::Field field_{};
};

// PreparedTwist's state: the pose (7), the previous twist (6) and the answer (6) live here, seen from Python as
// NumPy arrays over this memory, so a control loop's call passes nothing but dt.
class Prepared {
 public:
  explicit Prepared(nb::handle_t<BoundField> field) : field_(field) {}

  int evaluate(double dt) {
    Pose7 pose(pose_, {7});
    Vector previous(previous_, {6});
    Out6 out(twist_, {6});
    return field_->evaluate(pose, previous, dt > 0.0, dt, out);
  }

  double pose_[7] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0};
  double previous_[6] = {};
  double twist_[6] = {};

 private:
  Held<BoundField> field_;  // the bound field, kept alive
};

template <std::size_t N>
nb::ndarray<nb::numpy, double, nb::shape<N>> view(double (&buffer)[N], nb::handle owner) {
  return nb::ndarray<nb::numpy, double, nb::shape<N>>(buffer, {N}, owner);
}

}  // namespace

void bind_field(nb::module_& m) {
  m.doc() = "The 3D potential field and its task-space planning loop (pfield.field's compiled core).";
  // The laws one call at a time, out of line (forces.hpp): pfield.field.forces's Python face. And the two rate limits,
  // for their property tests.
  m.def(
      "attraction",
      [](double ex, double ey, double ez, double gain, double threshold) {
        const Vec3 f = field::out_of_line::attraction({ex, ey, ez}, gain, threshold);
        return std::make_tuple(f.x, f.y, f.z);
      },
      "ex"_a, "ey"_a, "ez"_a, "gain"_a, "threshold"_a,
      "Attractive force for the goal error e = g - p: k e within threshold, k threshold e/|e| beyond.");
  m.def("khatib_magnitude", &field::out_of_line::khatib_magnitude, "distance"_a, "gain"_a, "influence"_a, "cap"_a,
        "The saturated Khatib repulsion magnitude at a signed distance: 0 beyond influence, cap inside.");
  m.def(
      "soft_saturate",
      [](double x, double y, double z, double limit) {
        const Vec3 v = field::out_of_line::soft_saturate({x, y, z}, limit);
        return std::make_tuple(v.x, v.y, v.z);
      },
      "x"_a, "y"_a, "z"_a, "limit"_a, "v <- limit tanh(|v|/limit) v/|v|.");
  m.def("damper_speed", &field::out_of_line::damper_speed, "distance"_a, "influence"_a, "safety"_a, "gain"_a,
        "max_speed"_a, "max_acceleration"_a,
        "The largest allowed approach speed of a rate-limited twist at a distance < influence.");
  m.def("stepped_damper_speed", &field::out_of_line::stepped_damper_speed, "distance"_a, "influence"_a, "safety"_a,
        "max_speed"_a, "dt"_a, "The largest allowed approach speed for one step of dt (the whole-body QP's rows).");
  m.def(
      "deflect",
      [](double vx, double vy, double vz, double nx, double ny, double nz, double cx, double cy, double cz,
         double allowed, double circulation) {
        const field::Limited out =
            field::out_of_line::deflect({vx, vy, vz}, {nx, ny, nz}, {cx, cy, cz}, allowed, circulation);
        return std::make_tuple(out.v.x, out.v.y, out.v.z, out.changed);
      },
      "vx"_a, "vy"_a, "vz"_a, "nx"_a, "ny"_a, "nz"_a, "cx"_a, "cy"_a, "cz"_a, "allowed"_a, "circulation"_a,
      "The damper n.v >= -allowed, the removed approach speed turned about the axis c: (vx, vy, vz, active).");
  m.def(
      "project_damper",
      [](double vx, double vy, double vz, double nx, double ny, double nz, double allowed) {
        const field::Limited out = field::out_of_line::project_damper({vx, vy, vz}, {nx, ny, nz}, allowed);
        return std::make_tuple(out.v.x, out.v.y, out.v.z, out.changed);
      },
      "vx"_a, "vy"_a, "vz"_a, "nx"_a, "ny"_a, "nz"_a, "allowed"_a,
      "The nearest twist with approach speed -n.v <= allowed: (vx, vy, vz, changed).");
  m.def(
      "rate_limit",
      [](double x, double y, double z, double px, double py, double pz, double max_change) {
        const Vec3 v = field::rate_limit({x, y, z}, {px, py, pz}, max_change);
        return std::make_tuple(v.x, v.y, v.z);
      },
      "x"_a, "y"_a, "z"_a, "px"_a, "py"_a, "pz"_a, "max_change"_a,
      "The point of the ball |v - v_prev| <= max_change nearest to v.");
  m.def(
      "braking_rate_limit",
      [](double x, double y, double z, double px, double py, double pz, double max_change, double nx, double ny,
         double nz, double limit) {
        const Vec3 v = field::braking_rate_limit({x, y, z}, {px, py, pz}, max_change, {nx, ny, nz}, limit);
        return std::make_tuple(v.x, v.y, v.z);
      },
      "x"_a, "y"_a, "z"_a, "px"_a, "py"_a, "pz"_a, "max_change"_a, "nx"_a, "ny"_a, "nz"_a, "limit"_a,
      "The rate limit that spends its budget on braking along n first, then |v| <= limit.");
  m.attr("PARALLEL_FROM") = field::kParallelFrom;  // the batches' threads start here
  m.attr("CHUNK") = field::kChunk;
  // FieldParams member -> its index in FieldConfig.packed(), from the struct's own layout (a test holds it equal
  // to FieldConfig's field order)
  nb::dict offsets;
#define PFIELD_OFFSET(member) offsets[#member] = offsetof(FieldParams, member) / sizeof(double)
  PFIELD_OFFSET(attractive_gain);
  PFIELD_OFFSET(rotational_attractive_gain);
  PFIELD_OFFSET(repulsive_gain);
  PFIELD_OFFSET(max_linear_velocity);
  PFIELD_OFFSET(max_angular_velocity);
  PFIELD_OFFSET(max_linear_acceleration);
  PFIELD_OFFSET(max_angular_acceleration);
  PFIELD_OFFSET(influence_distance);
  PFIELD_OFFSET(attractive_threshold);
  PFIELD_OFFSET(rotation_tolerance);
  PFIELD_OFFSET(max_repulsive_force);
  PFIELD_OFFSET(safety_distance);
  PFIELD_OFFSET(damper_gain);
  PFIELD_OFFSET(circulation_gain);
  PFIELD_OFFSET(stagnation_window);
  PFIELD_OFFSET(stagnation_progress);
#undef PFIELD_OFFSET
  m.attr("PARAM_OFFSETS") = offsets;
  nb::class_<BoundField>(m, "Field")
      .def(nb::init<const Vector&, const Vector&, const Rows<8>&, const Kinds&, const Rows<16>&, const Triangles&,
                    const PseudoNormals&, const Rows<3>&, const Rows<3>&, const Nodes&, const MeshTable&>(),
           "goal"_a, "params"_a, "aux"_a, "kinds"_a, "rows"_a, "triangles"_a, "pseudo_normals"_a, "bvh_lower"_a,
           "bvh_upper"_a, "bvh_nodes"_a, "mesh_table"_a,
           "Bind a field's arrays (FieldArrays): goal (7,), FieldConfig.packed() (16,), obstacle_aux (M, 8) and the "
           "eight arrays of PackedObstacles; they are read in place for the object's life.")
      .def("twist", &BoundField::twist, "position"_a, "orientation"_a, "previous_linear"_a.none() = nb::none(),
           "previous_angular"_a.none() = nb::none(), "dt"_a = 0.0,
           "(linear (3,), angular (3,), the output contract's outcome): the constrained twist at a pose (float64 "
           "arrays of 3 and 4 values, a unit quaternion), new read-only arrays; rate-limited against the previous "
           "twist's linear and angular parts (3,) when given.")
      .def("twist_value", &BoundField::twist_value, "pose"_a.none(), "previous"_a.none(), "dt"_a.none(),
           "PotentialField.twist's answer (a new pfield.Twist) for exactly a pfield.Pose, and None or exactly a "
           "pfield.Twist with a float dt in (0, inf); else None (the Python layer checks and answers), and None "
           "for an answer the output contract halted.")
      .def(
          "call_floor", [](const BoundField&, nb::handle, nb::handle, nb::handle) { return nb::none(); }, "pose"_a,
          "previous"_a.none(), "dt"_a.none(),
          "Does nothing with twist_value's arguments: the benchmarks' floor of a call from Python.")
      .def(
          "call_floor_value",
          [](const BoundField&, nb::handle, nb::handle, nb::handle) {
            const double zeros[3] = {0.0, 0.0, 0.0};
            return values::make(values::Kind::Twist, zeros, zeros);
          },
          "pose"_a, "previous"_a.none(), "dt"_a.none(),
          "Computes nothing and answers as twist_value does (a new pfield.Twist): the benchmarks' floor of a call "
          "and its answer.")
      .def("evaluate", &BoundField::evaluate, "pose"_a, "previous"_a, "use_previous"_a, "dt"_a, "out"_a,
           "PreparedTwist's call: 0, or 1/2 for a pose whose position / quaternion is not valid.")
      .def("wrench", &BoundField::wrench, "position"_a, "orientation"_a,
           "(force (3,), torque (3,)): the raw wrench at a pose, new read-only arrays.")
      .def("wrench_value", &BoundField::wrench_value, "pose"_a.none(),
           "PotentialField.wrench's answer (a new pfield.Wrench, the raw wrench) for exactly a pfield.Pose; else "
           "None (the Python layer checks).")
      .def(
          "twists",
          [](const BoundField& self, const Rows<3>& positions, const Rows<4>& orientations, unsigned threads) {
            return self.batch(positions, orientations, false, threads);
          },
          "positions"_a, "orientations"_a, "threads"_a = 0,
          "(constrained twists (N, 6) without a previous twist, under the output contract; the first invalid row "
          "or -1): quaternions normalised here; on every core from PARALLEL_FROM poses (threads=0).")
      .def(
          "wrenches",
          [](const BoundField& self, const Rows<3>& positions, const Rows<4>& orientations, unsigned threads) {
            return self.batch(positions, orientations, true, threads);
          },
          "positions"_a, "orientations"_a, "threads"_a = 0,
          "(raw wrenches (N, 6), the first invalid row or -1), as twists.")
      .def("plan", &BoundField::plan, "start"_a, "dt"_a, "goal_tolerance"_a, "rotation_tolerance"_a,
           "max_iterations"_a, "window"_a, "progress"_a, "cancel"_a, "poses"_a, "twists"_a, "clearances"_a,
           "The task-space plan into poses/twists/clearances: (waypoint count, PlanStatus value, obstacle or -1); "
           "the GIL is released and cancel[0] read every step.")
      .def("rk4_steps", &BoundField::rk4_steps, "pose"_a, "previous"_a, "dt"_a, "count"_a,
           "count RK4 steps from one pose (7,) and previous twist (6,), nothing else of a plan step (the bench's "
           "figure): the sum of their mean v_x.");
  nb::class_<Prepared>(m, "Prepared")
      .def(nb::init<nb::handle_t<BoundField>>(), "field"_a, "The state of a PreparedTwist over a bound Field.")
      .def_prop_ro("pose", [](nb::handle_t<Prepared> self) { return view(nb::cast<Prepared&>(self).pose_, self); },
                   "(7,) position then unit quaternion, a NumPy view of the object's memory")
      .def_prop_ro("previous",
                   [](nb::handle_t<Prepared> self) { return view(nb::cast<Prepared&>(self).previous_, self); },
                   "(6,) the previous twist, a view")
      .def_prop_ro("twist", [](nb::handle_t<Prepared> self) { return view(nb::cast<Prepared&>(self).twist_, self); },
                   "(6,) the answer, a view")
      .def("evaluate", &Prepared::evaluate, "dt"_a,
           "The twist at pose into twist (rate-limited against previous when dt > 0) under the output contract; 0, "
           "or 1/2/3 for a position / quaternion / previous twist it refused.");
}

}  // namespace pfield::python
