#include "robot/pair_tables.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "robot/clearance.hpp"
#include "robot/kinematics.hpp"

namespace pfield::robot {
namespace {

constexpr double kTurn = 6.283185307179586;  // 2π
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

template <class T>
std::vector<T> copied(const T* data, std::size_t count) {
  return data == nullptr ? std::vector<T>() : std::vector<T>(data, data + count);
}

template <class T>
bool same(const std::vector<T>& copy, const T* data) {
  return copy.empty() || (data != nullptr && std::equal(copy.begin(), copy.end(), data));
}

}  // namespace

PairTables::PairTables(const RobotView& robot, const double* weights) {
  const KinematicsView& k = robot.kinematics;
  const LinkModelView& l = robot.links;
  const std::size_t n = k.joint_count, caps = l.capsule_count, prims = l.primitive_count, pairs = l.pair_count;
  parents_ = copied(k.parents, n);
  kinds_ = copied(k.kinds, n);
  support_ = copied(k.support, n * n);
  place_rot_ = copied(k.place_rot, 9 * n);
  place_pos_ = copied(k.place_pos, 3 * n);
  axes_ = copied(k.axes, 3 * n);
  cap_joint_ = copied(l.cap_joint, caps);
  cap_a_ = copied(l.cap_a, 3 * caps);
  cap_b_ = copied(l.cap_b, 3 * caps);
  cap_r_ = copied(l.cap_r, caps);
  self_r_ = copied(l.self_r, caps);
  self_pairs_ = copied(l.self_pairs, 2 * pairs);
  link_start_ = copied(l.link_start, caps + 1);
  prim_joint_ = copied(l.prim_joint, prims);
  prim_a_ = copied(l.prim_a, 3 * prims);
  prim_b_ = copied(l.prim_b, 3 * prims);
  prim_r_ = copied(l.prim_r, prims);
  lower_ = copied(robot.limits.lower, n);
  upper_ = copied(robot.limits.upper, n);
  kinematics_ = {n, parents_.data(), place_rot_.data(), place_pos_.data(), axes_.data(), kinds_.data(),
                 support_.data(), -1, nullptr, nullptr};
  links_ = {caps, cap_joint_.data(), cap_a_.data(), cap_b_.data(), cap_r_.data(), self_r_.data(), pairs,
            self_pairs_.data(), prims, link_start_.data(), prim_joint_.data(), prim_a_.data(), prim_b_.data(),
            prim_r_.data()};
  table_of_.assign(pairs, -1);
  if (prims == 0 || weights == nullptr) return;
  for (std::size_t p = 0; p < pairs; ++p) {
    const auto l1 = static_cast<std::size_t>(self_pairs_[2 * p]), l2 = static_cast<std::size_t>(self_pairs_[2 * p + 1]);
    if (!on_own_joint(l1) || !on_own_joint(l2)) continue;
    // the joints that move one link and not the other: each a table axis, or, where its weight is too small to
    // matter over its whole range, a constant share of the slack
    const std::int64_t m1 = cap_joint_[l1], m2 = cap_joint_[l2];
    std::vector<TableAxis> axes;
    double fixed = 0.0;
    bool usable = true;
    for (std::size_t j = 0; j < n; ++j) {
      const bool moves1 = m1 >= 0 && support_[static_cast<std::size_t>(m1) * n + j] != 0;
      const bool moves2 = m2 >= 0 && support_[static_cast<std::size_t>(m2) * n + j] != 0;
      if (moves1 == moves2) continue;  // neither link, or both rigidly together
      const double w = weights[p * n + j] + kWeightRounding;
      const bool turns = kinds_[j] == static_cast<std::int64_t>(JointKind::Revolute) && upper_[j] - lower_[j] > kTurn;
      const double span = turns ? kTurn : upper_[j] - lower_[j];
      usable = std::isfinite(w) && w > 0.0 && std::isfinite(span) && span > 0.0;
      if (usable && w * span <= kUntabulated) {
        fixed += w * span;
        continue;
      }
      usable = usable && axes.size() < 2;
      if (!usable) break;
      TableAxis axis;
      axis.joint = j;
      axis.weight = w;
      axis.turns = turns;
      axis.origin = std::isfinite(lower_[j]) ? lower_[j] : -0.5 * kTurn;  // a continuous joint: any turn will do
      axes.push_back(axis);
    }
    if (!usable || axes.empty() || !sized(axes)) continue;
    Table table;
    table.pair = p;
    table.axes = std::move(axes);
    table.fixed = fixed;
    table.size = 1;
    for (const TableAxis& axis : table.axes) table.size *= axis.cells;
    table.values = std::make_unique<std::atomic<double>[]>(table.size);
    for (std::size_t c = 0; c < table.size; ++c) table.values[c].store(kNaN, std::memory_order_relaxed);
    table_of_[p] = static_cast<std::int64_t>(tables_.size());
    tables_.push_back(std::move(table));
  }
}

bool PairTables::on_own_joint(std::size_t link) const {
  const auto start = static_cast<std::size_t>(link_start_[link]);
  const auto stop = static_cast<std::size_t>(link_start_[link + 1]);
  return start < stop && std::all_of(prim_joint_.begin() + static_cast<std::ptrdiff_t>(start),
                                     prim_joint_.begin() + static_cast<std::ptrdiff_t>(stop),
                                     [&](std::int64_t j) { return j == cap_joint_[link]; });
}

bool PairTables::sized(std::vector<TableAxis>& axes) {
  // cells of kTableSlack at their corners, wider by a common factor while that makes more than kTableCells; no
  // table when the widest cells still do
  for (double wider = 1.0;; wider *= 1.25) {
    double size = 1.0;
    bool widest = true;
    for (TableAxis& axis : axes) {
      const double span = axis.turns ? kTurn : upper_[axis.joint] - lower_[axis.joint];
      const double wanted = wider * 2.0 * kTableSlack / (static_cast<double>(axes.size()) * axis.weight);
      const double width = std::clamp(wanted, kTableWidths[0], kTableWidths[1]);
      widest = widest && width == kTableWidths[1];
      const double cells = std::max(1.0, std::ceil(span / width));
      size *= cells;
      axis.cells = cells <= static_cast<double>(kTableCells) ? static_cast<std::size_t>(cells) : kTableCells + 1;
      axis.width = span / cells;
    }
    if (size <= static_cast<double>(kTableCells)) return true;
    if (widest) return false;
  }
}

bool PairTables::made_from(const RobotView& robot) const {
  const KinematicsView& k = robot.kinematics;
  const LinkModelView& l = robot.links;
  if (k.joint_count != kinematics_.joint_count || l.capsule_count != links_.capsule_count ||
      l.primitive_count != links_.primitive_count || l.pair_count != links_.pair_count)
    return false;
  return same(parents_, k.parents) && same(kinds_, k.kinds) && same(support_, k.support) &&
         same(place_rot_, k.place_rot) && same(place_pos_, k.place_pos) && same(axes_, k.axes) &&
         same(cap_joint_, l.cap_joint) && same(cap_a_, l.cap_a) && same(cap_b_, l.cap_b) && same(cap_r_, l.cap_r) &&
         same(self_r_, l.self_r) && same(self_pairs_, l.self_pairs) && same(link_start_, l.link_start) &&
         same(prim_joint_, l.prim_joint) &&
         same(prim_a_, l.prim_a) && same(prim_b_, l.prim_b) && same(prim_r_, l.prim_r) &&
         same(lower_, robot.limits.lower) && same(upper_, robot.limits.upper);
}

const std::vector<TableAxis>& PairTables::axes(std::size_t pair) const {
  static const std::vector<TableAxis> none;
  const std::int64_t t = table_of_.at(pair);
  return t < 0 ? none : tables_[static_cast<std::size_t>(t)].axes;
}

std::size_t PairTables::filled(std::size_t pair) const {
  const std::int64_t t = table_of_.at(pair);
  if (t < 0) return 0;
  const Table& table = tables_[static_cast<std::size_t>(t)];
  std::size_t count = 0;
  for (std::size_t c = 0; c < table.size; ++c)
    count += std::isnan(table.values[c].load(std::memory_order_relaxed)) ? 0 : 1;
  return count;
}

double PairTables::centre_distance(const Table& table, std::size_t cell) const {
  const std::size_t n = kinematics_.joint_count;
  thread_local std::vector<double> q, rotations, origins, caps, prims;
  q.assign(n, 0.0);
  for (std::size_t a = table.axes.size(); a-- > 0;) {  // the last axis varies fastest
    const TableAxis& axis = table.axes[a];
    q[axis.joint] = axis.origin + (static_cast<double>(cell % axis.cells) + 0.5) * axis.width;
    cell /= axis.cells;
  }
  rotations.resize(9 * n);
  origins.resize(3 * n);
  caps.resize(6 * links_.capsule_count);
  prims.resize(6 * links_.primitive_count);
  Frames frames{rotations.data(), origins.data()};
  joint_transforms(kinematics_, q.data(), frames);
  WorldSegments world{caps.data(), caps.data() + 3 * links_.capsule_count, prims.data(),
                      prims.data() + 3 * links_.primitive_count};
  capsule_segments(links_, frames, world);
  const auto l1 = static_cast<std::size_t>(self_pairs_[2 * table.pair]);
  const auto l2 = static_cast<std::size_t>(self_pairs_[2 * table.pair + 1]);
  const PrimitivePlacement placement{&links_, &frames, &world, nullptr};
  placement.place(l1);
  placement.place(l2);
  const double d = fitted_pair_distance_below(links_, world, l1, l2, kTableReach).distance;
  return d < kTableReach ? d : kInf;
}

PairVerdict PairTables::verdict(std::size_t pair, const double* q, double need) const {
  const std::int64_t t = table_of_[pair];
  if (t < 0) return PairVerdict::Unknown;
  const Table& table = tables_[static_cast<std::size_t>(t)];
  std::size_t cell = 0;
  double delta = kTableRounding + table.fixed;
  for (const TableAxis& axis : table.axes) {
    double u = q[axis.joint] - axis.origin;
    if (axis.turns) u -= kTurn * std::floor(u / kTurn);  // [0, 2π): D is 2π-periodic in the joint
    const double span = axis.turns ? kTurn : upper_[axis.joint] - lower_[axis.joint];
    // beyond the limits (or not a number) the weights bound nothing: a prismatic joint's travel is within them
    if (!(u >= 0.0 && u <= span)) return PairVerdict::Unknown;
    const auto index = std::min(static_cast<std::size_t>(u / axis.width), axis.cells - 1);
    delta += axis.weight * std::abs(u - (static_cast<double>(index) + 0.5) * axis.width);
    cell = cell * axis.cells + index;
  }
  double value = table.values[cell].load(std::memory_order_relaxed);
  if (std::isnan(value)) {
    value = centre_distance(table, cell);
    table.values[cell].store(value, std::memory_order_relaxed);
  }
  if ((std::isinf(value) ? kTableReach : value) - delta >= need) return PairVerdict::Clear;
  if (value + delta < need) return PairVerdict::Below;
  return PairVerdict::Unknown;
}

}  // namespace pfield::robot
