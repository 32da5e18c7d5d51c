#include <gtest/gtest.h>

#include <random>

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

// Islands and fill holes work from the labelling's runs, in place (no component id per voxel,
// issue #22's memory): the same masks as selecting from connectedComponents' labels per voxel,
// the way they were made before, on random blobs with cavities, islands and border contact.
TEST(FillHoles, InPlaceRunsEqualPerVoxelLabelSelection) {
  const Geometry g = grid(37, 29, 33);
  std::mt19937 rng(11);
  for (double density : {0.3, 0.55, 0.75}) {
    Mask m(g, 0, 0.0);
    std::bernoulli_distribution on(density);
    for (auto& x : m.voxels()) x = on(rng) ? 1 : 0;
    fillBox(m, {5, 5, 5}, {20, 20, 20});
    fillBox(m, {8, 8, 8}, {16, 16, 16}, 0);  // a cavity with random voxels inside
    for (int64_t t = 0; t < 200; ++t) m(10 + t % 5, 10 + (t / 5) % 5, 10 + t / 25) = on(rng);
    // Before: background components per voxel, outside = touching the border.
    const Components bg = connectedComponents(maskNot(m), Connectivity::Face6);
    std::vector<uint8_t> cavity(bg.sizes.size(), 1);
    cavity[0] = 0;
    for (int64_t k = 0; k < g.dims.z; ++k)
      for (int64_t j = 0; j < g.dims.y; ++j)
        for (int64_t i = 0; i < g.dims.x; ++i)
          if (i == 0 || j == 0 || k == 0 || i == g.dims.x - 1 || j == g.dims.y - 1 || k == g.dims.z - 1)
            cavity[bg.labels[static_cast<size_t>(m.linearIndex(i, j, k))]] = 0;
    const Mask holes = selectComponents(g, bg, cavity);
    Mask expectFilled = maskOr(m, holes);
    const Mask filled = fillHoles(m);
    EXPECT_EQ(filled.voxels(), expectFilled.voxels()) << "density " << density;
    EXPECT_GT(countVoxels(filled), countVoxels(m)) << "the cavity has holes to fill";
    Mask inPlace = m;
    fillHolesInPlace(inPlace);
    EXPECT_EQ(inPlace.voxels(), expectFilled.voxels());

    for (Connectivity c : {Connectivity::Face6, Connectivity::Vertex26}) {
      const Components fg = connectedComponents(m, c);
      std::vector<uint8_t> big(fg.sizes.size(), 0);
      for (size_t l = 1; l < fg.sizes.size(); ++l) big[l] = fg.sizes[l] >= 4;
      const Mask expectKept = selectComponents(g, fg, big);
      EXPECT_EQ(removeSmallIslands(m, 4.0, c).voxels(), expectKept.voxels()) << "density " << density;
      Mask islands = m;
      removeSmallIslandsInPlace(islands, 4.0, c);
      EXPECT_EQ(islands.voxels(), expectKept.voxels());
      std::vector<uint8_t> largest(fg.sizes.size(), 0);
      largest[fg.largest()] = 1;
      EXPECT_EQ(keepLargestComponent(m, c).voxels(), selectComponents(g, fg, largest).voxels());
    }
  }
}
