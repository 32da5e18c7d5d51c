#pragma once
// Island editing by seeds and hole filling, over core's connected components.
#include <vector>

#include "vellum/core/progress.hpp"
#include "vellum/segmentation/mask.hpp"

namespace vellum::segmentation {

// The labelling itself, keep-largest and island removal are core's (core/components.hpp).
using vellum::Components;
using vellum::connectedComponents;
using vellum::keepLargestComponent;
using vellum::removeSmallIslands;
using vellum::removeSmallIslandsInPlace;
using vellum::paintComponents;

/// Keeps the components that contain at least one of the seeds (mm). Seeds outside the grid
/// throw vellum::Error; seeds on background select nothing.
Mask keepComponentsWithSeeds(const Mask& m, const std::vector<Vec3>& seedsMm,
                             Connectivity connectivity = Connectivity::Vertex26);

/// Fills cavities: background regions (6-connected) that do not touch the border of the grid.
Mask fillHoles(const Mask& m);
/// The same in place (no second mask; non-zero voxels keep their values).
void fillHolesInPlace(Mask& m);
/// Fills holes in each 2D slice across `axis` (0 = x, 1 = y, 2 = z: axial slices for
/// usual CT): background regions (4-connected in the slice) not touching the slice border.
Mask fillHolesPerSlice(const Mask& m, int axis = 2);
/// Union of fillHolesPerSlice along x, y and z, then fillHoles (3D). Whole bones from a
/// cortex threshold on coarse grids: where the cortex ring of an axial slice is open (thin,
/// partial-volumed cortex met tangentially, e.g. the femoral condyles at ~2 mm voxels), the
/// coronal or sagittal slices through the same marrow are usually still closed (knee phantom,
/// whole-bone preset, Dice vs every bone label at 96³: 0.90 axial only, 0.987 with this).
Mask fillHolesAllSlices(const Mask& m);

}  // namespace vellum::segmentation
