#pragma once
// Fold repair of a control volume (issue 23 §4): where the backward map folds (det du/dv <= 0),
// the content of one source place is shown twice and tissue turns inside out. The rigid blend
// makes folds where it bends the MLS map steeply onto a bone's fit or onto a fixed region. This
// moves the FREE corners of each folding cell, pass after pass, to lift its Jacobians above a
// threshold (projections of the linearised Jacobians, averaged per node, a bounded step), and
// checks the cells around what moved, so a fold spreads into a transition wide enough not to
// fold. Hard-locked nodes (inside bones, fixed voxels' cells) are never written, soft ones only
// where a fold is locked all round: bones stay rigid, fixed regions still. docs/deformation.md.
#include <cstdint>
#include <functional>
#include <vector>

#include "vellum/deformation/control_volume.hpp"

namespace vellum::deformation {

struct FoldRepairParams {
  /// A cell is repaired while the smallest trilinear Jacobian det(du/dv) at its 8 corners and its
  /// centre is below this (a margin above 0: the voxels between the corners interpolate them).
  double minJacobian = 0.2;
  int maxRounds = 1000;  ///< passes over the folding cells (each touches only them); stops after 50 without progress
  /// Second stage, where the passes stalled: harmonic relaxation of the free nodes within r
  /// cells of each cluster still folding, r = 1 .. relaxRadius (0: off), `relaxSteps` Jacobi
  /// steps each (a few: a partial smoothing; more smoothed folds into the bones' snap on the
  /// feet), kept per cluster only when fewer of its cells fold.
  int relaxRadius = 4;
  int relaxSteps = 10;
};

struct FoldRepairStats {
  int64_t cellsBefore = 0;   ///< cells below minJacobian that the repair cares about, before
  int64_t cellsAfter = 0;    ///< ... and after
  int64_t lockedCells = 0;   ///< of cellsAfter: all 8 corners hard-locked (two bodies' voxels meet in the cell)
  int64_t nodesReleased = 0; ///< soft-locked nodes released (corners of folding cells locked all round)
  int64_t nodesRelaxed = 0;  ///< free nodes the repair wrote
  int rounds = 0;             ///< passes made
  int64_t clustersRelaxed = 0;  ///< second stage: clusters whose harmonic relaxation was kept
  double minJacobianBefore = 0, minJacobianAfter = 0;  ///< over the cared cells (corners and centres)
};

/// Lock levels of the `locked` mask.
enum : uint8_t {
  kNodeFree = 0,
  kNodeHardLock = 1,  ///< never written (lands inside a body; a corner of a fixed voxel's cell)
  /// Locked while its cells can unfold otherwise (a rigid body's weight-1 core outside the body,
  /// a fixed region's margin): released where a folding cell has all 8 corners locked.
  kNodeSoftLock = 2,
};

/// Repairs `cv` in place. A fast pass first (float, parallel, stops at the first cell below
/// the threshold): when nothing is below it, nothing is written and the stats carry only the
/// smallest cell Jacobian. `locked` (one byte per node, or empty = none; kNodeSoftLock /
/// kNodeHardLock) marks nodes not written. `cares(u)` says whether a source position is tissue (a cell is repaired when one of
/// its corners maps to tissue: folds in air are harmless and left); null = every cell. A free
/// node is never moved to a source position where `forbidden(u)` (a rigid body's voxels: its
/// content would be shown moved non-rigidly); null = anywhere.
FoldRepairStats repairFolds(ControlVolume& cv, const std::vector<uint8_t>& locked,
                            const std::function<bool(const Vec3&)>& cares = {},
                            const FoldRepairParams& params = {},
                            const std::function<bool(const Vec3&)>& forbidden = {});

/// The smallest trilinear Jacobian det(du/dv) of cell (i, j, k) (its lowest node) over its 8
/// corners and its centre.
double cellMinJacobian(const ControlVolume& cv, int64_t i, int64_t j, int64_t k);

}  // namespace vellum::deformation
