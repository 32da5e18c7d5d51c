#include <gtest/gtest.h>

#include "test_volumes.hpp"
#include "vellum/segmentation/components.hpp"

using namespace vellum;
using namespace vellum::segmentation;
using namespace vellum::segmentation::test;

TEST(Components, ConnectivityDecidesDiagonalContacts) {
  Mask m(grid(5, 5, 5), 0, 0.0);
  m(0, 0, 0) = 1;
  m(1, 1, 0) = 1;  // edge contact with (0,0,0)
  m(2, 2, 1) = 1;  // corner contact with (1,1,0)
  m(4, 4, 4) = 1;  // alone
  EXPECT_EQ(connectedComponents(m, Connectivity::Face6).count(), 4);
  EXPECT_EQ(connectedComponents(m, Connectivity::Edge18).count(), 3);
  const Components c = connectedComponents(m, Connectivity::Vertex26);
  EXPECT_EQ(c.count(), 2);
  EXPECT_EQ(c.sizes[1], 3);
  EXPECT_EQ(c.sizes[2], 1);
  EXPECT_EQ(c.labels[m.linearIndex(0, 0, 0)], 1u);
  EXPECT_EQ(c.labels[m.linearIndex(4, 4, 4)], 2u);
}

TEST(Components, SpiralAcrossManySlabsIsOneComponent) {
  // A path winding through every z-slice: union-find must merge across all slab faces.
  Mask m(grid(8, 8, 64), 0, 0.0);
  for (int64_t k = 0; k < 64; ++k) {
    const int64_t i = (k / 2) % 2 ? 1 : 6;
    for (int64_t x = 1; x <= 6; ++x) m(x, 3, k) = (k % 2 == 0) ? 1 : (x == i);
  }
  EXPECT_EQ(connectedComponents(m, Connectivity::Face6).count(), 1);
}

TEST(Islands, KeepLargestRemoveSmallKeepSeeded) {
  const Geometry g = grid(30, 10, 10, {1, 1, 2});  // voxel = 2 mm³
  Mask m(g, 0, 0.0);
  fillBox(m, {1, 1, 1}, {10, 8, 8});    // 640 voxels = 1280 mm³
  fillBox(m, {13, 1, 1}, {16, 4, 4});   // 64 voxels = 128 mm³
  fillBox(m, {20, 1, 1}, {20, 1, 1});   // 1 voxel = 2 mm³
  EXPECT_EQ(countVoxels(keepLargestComponent(m)), 640);
  EXPECT_EQ(countVoxels(removeSmallIslands(m, 100.0)), 704);
  EXPECT_EQ(countVoxels(removeSmallIslands(m, 128.0)), 704);   // exactly the threshold stays
  EXPECT_EQ(countVoxels(removeSmallIslands(m, 129.0)), 640);
  const Vec3 seed = g.indexToPhysical({14, 2, 2});
  EXPECT_EQ(countVoxels(keepComponentsWithSeeds(m, {seed})), 64);
  EXPECT_EQ(countVoxels(keepComponentsWithSeeds(m, {g.indexToPhysical({25, 5, 5})})), 0);
}

TEST(FillHoles, FillsCavitiesButNotOpenTunnels) {
  const Geometry g = grid(20, 20, 20);
  Mask shell(g, 0, 0.0);
  fillBox(shell, {4, 4, 4}, {15, 15, 15});
  fillBox(shell, {6, 6, 6}, {13, 13, 13}, 0);  // closed cavity of 8³
  const Mask filled = fillHoles(shell);
  EXPECT_EQ(countVoxels(filled), 12 * 12 * 12);
  // A tube along z open at both ends: no 3D hole, but every axial slice has one.
  Mask tube(g, 0, 0.0);
  fillBox(tube, {4, 4, 0}, {15, 15, 19});
  fillBox(tube, {6, 6, 0}, {13, 13, 19}, 0);
  EXPECT_EQ(countVoxels(fillHoles(tube)), countVoxels(tube));
  EXPECT_EQ(countVoxels(fillHolesPerSlice(tube, 2)), 12 * 12 * 20);
  // Across x the tube's slices are two walls with nothing enclosed.
  EXPECT_EQ(countVoxels(fillHolesPerSlice(tube, 0)), countVoxels(tube));
}

// A box open on its +y face (a cup lying on its side): no axial slice and no 3D hole encloses
// its inside, every y slice through the cup does; fillHolesAllSlices fills exactly the inside.
TEST(FillHoles, AllSliceOrientations) {
  const Geometry g = grid(20, 20, 20);
  Mask cup(g, 0, 0.0);
  fillBox(cup, {4, 4, 4}, {15, 15, 15});
  fillBox(cup, {6, 6, 6}, {13, 15, 13}, 0);
  EXPECT_EQ(countVoxels(fillHoles(cup)), countVoxels(cup));
  EXPECT_EQ(countVoxels(fillHolesPerSlice(cup, 2)), countVoxels(cup));
  EXPECT_EQ(countVoxels(fillHolesPerSlice(cup, 1)), 12 * 12 * 12);
  const Mask all = fillHolesAllSlices(cup);
  EXPECT_EQ(countVoxels(all), 12 * 12 * 12);
  EXPECT_EQ(all(9, 15, 9), 1);
  EXPECT_EQ(all(9, 16, 9), 0);
}
