// Tabulated self pairs: the fitted distance of a link pair that moves apart by one or two joints, kept on a grid
// over those joints, so that the global search's state check (planning/rrt.cpp capsules_valid) decides most such
// pairs without their primitives (issue 34).
//
// Why. A link pair's relative pose depends only on the joints that move one link and not the other. On the UR5,
// forearm_link and wrist_2_link (a pair its SRDF keeps) sit 4 mm apart at the median configuration, so no bound on
// their capsules decides them: every state check placed 66 fitted primitives and measured them, about a third of a
// check on the cage scenes. Their distance is a function of wrist 1 and wrist 2 alone.
//
// The bound. For a pair p and the joints j that move one of its links alone, a joint motion Δq changes the pair's
// fitted distance D_p by at most sum_j w_pj |Δq_j| (pfield.robot.collision.self_pair_weights: the largest distance of
// a link's primitives from the joint's axis, Schwarzer, Saha & Latombe, IEEE T-RO 21(3), 2005, §III; the distance
// between two sets of segments moves no faster than their points). A table covers those joints (less the ones that
// move the pair by at most kUntabulated over their range) when there are one or two of them, with finite weights
// and ranges, and both links' primitives on their capsules' joints (the frames the weights were computed in). Each
// cell of its grid holds D_p at the cell's centre c, computed on first use (fitted_pair_distance_below with cutoff
// kTableReach: "at least kTableReach" is kept as +inf). For a configuration q in the cell, with
// delta = sum_j w_pj |q_j - c_j| (+ the untabulated joints' share):
//   D_p(c) - delta - kTableRounding >= need  -> the pair is clear of need   (D_p(q) >= D_p(c) - delta)
//   D_p(c) + delta + kTableRounding <  need  -> the pair is below need      (D_p(q) <= D_p(c) + delta)
//   otherwise                                -> not decided: the caller measures the primitives.
// Both verdicts are those the primitives would give (kTableRounding, far above the rounding of any of these
// distances, keeps them so), so a search decides every state as without tables: the same states checked, the same
// paths, only faster. A revolute joint whose range exceeds a turn is tabulated over one turn (D_p is 2π-periodic in
// it); any other over its limits.
//
// The cells are filled lazily and kept for the tables' life (pfield.planning._whole_body_core.pair_tables keeps one
// PairTables for each of the last 8 robots planned with), so the searches of a robot share them; several threads may
// fill and read them at once (relaxed atomics: a cell holds NaN or its one value, and two threads that fill a cell
// write the same bits). A configuration outside a non-turning joint's limits, or not finite, gets Unknown: the
// weights bound the motion within the limits (a prismatic joint's travel).
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "robot/robot.hpp"

namespace pfield::robot {

// (m) distances of a cell at least this large are kept as "at least kTableReach" (+inf): beyond any need of the
// search (its margin and a pair's start offset), and the fill measures fewer primitive pairs than at a larger cutoff
constexpr double kTableReach = 0.02;
// (m) the largest delta over a cell (at its corners): each joint's cell width is 2 kTableSlack / (axes w_pj), within
// kTableWidths, and wider by a common factor where that would make more than kTableCells cells. Measured on the UR5
// cage problems 5, 15, 16 and 21 (359 685 state checks, one thread, 2026-12-07): 2.71 us a check without tables;
// with 1 / 2 / 4 / 8 / 16 mm, 3.01 / 2.53 / 2.27 / 2.20 / 2.22 us while the cells fill (the first pass over the four)
// and 2.18 / 2.15 / 2.15 / 2.17 / 2.19 us once filled (the second): finer cells decide more states but each cell
// filled costs a measure of the pair, and a first plan meets mostly new cells. Pairs moved by three joints (the UR5's
// forearm against its wrist 3 and gripper links) were measured too: 2.05 us once filled but 2.84 while filling, in
// 24 MB of tables; a table covers one or two joints.
constexpr double kTableSlack = 0.008;
// (rad or m) the narrowest and widest cells, and the most cells a table holds (2 MB of doubles)
constexpr double kTableWidths[2] = {0.002, 0.1};
constexpr std::size_t kTableCells = std::size_t{1} << 18;
// (m) added to delta in both verdicts: the rounding of a computed distance is below 1e-14 m
constexpr double kTableRounding = 1e-9;
// (m/rad) added to every weight: the distances from an axis that make them lose up to ~5e-9 to cancellation
constexpr double kWeightRounding = 1e-8;
// (m) a joint that moves the pair by at most this much over its whole range is not tabulated: that much is added
// to every delta of the table instead (a link whose primitives lie on the joint's axis)
constexpr double kUntabulated = 1e-4;

enum class PairVerdict : std::int64_t {
  Unknown = 0,  // the table does not decide (or the pair has none): measure the primitives
  Clear = 1,    // the pair's fitted distance is at least need
  Below = 2,    // the pair's fitted distance is below need
};

// One tabulated joint of a pair.
struct TableAxis {
  std::size_t joint = 0;
  double origin = 0.0;  // the first cell's lower edge (rad or m)
  double width = 0.0;   // one cell (rad or m)
  std::size_t cells = 0;
  bool turns = false;   // tabulated over one turn (a revolute joint whose range exceeds it)
  double weight = 0.0;  // w_pj (m/rad or m/m)
};

class PairTables {
 public:
  // Tables for the self pairs of `robot`'s fitted link model that qualify (above), with weights (pairs, n) w_pj
  // (m/rad or m/m).
  // Copies what it reads of robot: the tables outlive the view.
  PairTables(const RobotView& robot, const double* weights);
  PairTables(const PairTables&) = delete;
  PairTables& operator=(const PairTables&) = delete;

  // Whether robot has the kinematics, link model and limits these tables were made from (bit for bit).
  bool made_from(const RobotView& robot) const;

  // What the table of self pair k says of "fitted distance at q (n,) >= need"; Unknown when k has no table.
  PairVerdict verdict(std::size_t pair, const double* q, double need) const;

  std::size_t joint_count() const { return kinematics_.joint_count; }
  std::size_t pair_count() const { return table_of_.size(); }
  // The pair's tabulated joints (empty without a table), and its cells filled so far.
  const std::vector<TableAxis>& axes(std::size_t pair) const;
  std::size_t filled(std::size_t pair) const;

 private:
  struct Table {
    std::size_t pair = 0;
    std::vector<TableAxis> axes;
    double fixed = 0.0;  // (m) the most the joints moving the pair but not tabulated (weights ~0) change it
    std::size_t size = 0;
    std::unique_ptr<std::atomic<double>[]> values;  // (size,) NaN: not yet computed; +inf: at least kTableReach
  };

  // D_p at the centre of cell `cell` of `table` (other joints at 0, which do not move the pair), kTableReach and
  // beyond as +inf.
  double centre_distance(const Table& table, std::size_t cell) const;
  // Whether link's primitives are all on its capsule's joint (the frame the weights were computed in) and it has some.
  bool on_own_joint(std::size_t link) const;
  // Each axis's cells and width (kTableSlack at a cell's corners, wider while the table would exceed kTableCells);
  // false when even the widest cells make too many.
  bool sized(std::vector<TableAxis>& axes);

  // the robot's arrays, copied (views below point into them)
  std::vector<std::int64_t> parents_, kinds_, support_, cap_joint_, self_pairs_, link_start_, prim_joint_;
  std::vector<double> place_rot_, place_pos_, axes_, cap_a_, cap_b_, cap_r_, self_r_, prim_a_, prim_b_, prim_r_;
  std::vector<double> lower_, upper_;
  KinematicsView kinematics_;
  LinkModelView links_;
  std::vector<std::int64_t> table_of_;  // (pairs,) the pair's table, -1: none
  std::vector<Table> tables_;
};

}  // namespace pfield::robot
