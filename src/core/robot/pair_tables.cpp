#include "robot/pair_tables.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

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
    if (link_start_[l1] == link_start_[l1 + 1] || link_start_[l2] == link_start_[l2 + 1]) continue;  // no primitives
    std::vector<TableAxis> axes;
    bool usable = true;
    for (std::size_t j = 0; j < n && usable; ++j) {
      const double w = weights[p * n + j];
      if (w == 0.0) continue;
      const double range = upper_[j] - lower_[j];
      usable = std::isfinite(w) && w > 0.0 && std::isfinite(range) && range > 0.0 && axes.size() < 2;
      if (!usable) break;
      TableAxis axis;
      axis.joint = j;
      axis.weight = w;
      axis.turns = kinds_[j] == static_cast<std::int64_t>(JointKind::Revolute) && range > kTurn;
      axis.origin = lower_[j];
      axes.push_back(axis);
    }
    if (!usable || axes.empty()) continue;
    // cells of kTableSlack at their corners, wider by a common factor where that makes more than kTableCells
    std::size_t size = kTableCells + 1;
    for (double wider = 1.0; size > kTableCells; wider *= 1.25) {
      size = 1;
      for (TableAxis& axis : axes) {
        const double span = axis.turns ? kTurn : upper_[axis.joint] - lower_[axis.joint];
        const double wanted = std::clamp(wider * 2.0 * kTableSlack / (static_cast<double>(axes.size()) * axis.weight),
                                         kTableWidths[0], kTableWidths[1]);
        axis.cells = static_cast<std::size_t>(std::max(1.0, std::ceil(span / wanted)));
        axis.width = span / static_cast<double>(axis.cells);
        size *= axis.cells;
      }
      if (wider > 1e6) break;  // the widest cells still too many: no table
    }
    if (size > kTableCells) continue;
    Table table;
    table.pair = p;
    table.axes = std::move(axes);
    table.size = size;
    table.values = std::make_unique<std::atomic<double>[]>(size);
    for (std::size_t c = 0; c < size; ++c) table.values[c].store(kNaN, std::memory_order_relaxed);
    table_of_[p] = static_cast<std::int64_t>(tables_.size());
    tables_.push_back(std::move(table));
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
         same(self_pairs_, l.self_pairs) && same(link_start_, l.link_start) && same(prim_joint_, l.prim_joint) &&
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
  const auto l1 = static_cast<std::size_t>(self_pairs_[2 * table.pair]);
  const auto l2 = static_cast<std::size_t>(self_pairs_[2 * table.pair + 1]);
  for (const std::size_t link : {l1, l2}) {
    world_segment_range(frames, cap_joint_.data(), cap_a_.data(), cap_b_.data(), link, link + 1, world.cap_a,
                        world.cap_b);
    world_segment_range(frames, prim_joint_.data(), prim_a_.data(), prim_b_.data(),
                        static_cast<std::size_t>(link_start_[link]), static_cast<std::size_t>(link_start_[link + 1]),
                        world.prim_a, world.prim_b);
  }
  const double d = fitted_pair_distance_below(links_, world, l1, l2, kTableReach).distance;
  return d < kTableReach ? d : kInf;
}

PairVerdict PairTables::verdict(std::size_t pair, const double* q, double need) const {
  const std::int64_t t = table_of_[pair];
  if (t < 0) return PairVerdict::Unknown;
  const Table& table = tables_[static_cast<std::size_t>(t)];
  std::size_t cell = 0;
  double delta = kTableRounding;
  for (const TableAxis& axis : table.axes) {
    double u = q[axis.joint] - axis.origin;
    if (axis.turns) u -= kTurn * std::floor(u / kTurn);  // [0, 2π): D is 2π-periodic in the joint
    const double at = std::floor(u / axis.width);
    const auto index = static_cast<std::size_t>(std::clamp(at, 0.0, static_cast<double>(axis.cells - 1)));
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
