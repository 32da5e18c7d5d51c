// Connected components (core/components.hpp): analytic shapes, and a breadth-first reference
// labelling on random masks (the same scan-order numbering must come out).
#include <gtest/gtest.h>

#include <random>

#include "vellum/core/components.hpp"
#include "vellum/core/error.hpp"

using namespace vellum;

namespace {

VolumeU8 emptyMask(Dims d, double spacing = 1.0) {
  Geometry g;
  g.dims = d;
  g.spacing = {spacing, spacing, spacing};
  return VolumeU8(g, 0, 0.0);
}

void fillBox(VolumeU8& m, IndexBox b, uint8_t v = 1) {
  for (int64_t k = b.lo[2]; k <= b.hi[2]; ++k)
    for (int64_t j = b.lo[1]; j <= b.hi[1]; ++j)
      for (int64_t i = b.lo[0]; i <= b.hi[0]; ++i) m(i, j, k) = v;
}

// Reference: one breadth-first fill per component, started in scan order.
std::vector<uint32_t> referenceLabels(const VolumeU16& v, Connectivity c) {
  const Dims d = v.dims();
  std::vector<uint32_t> lab(v.size(), 0);
  uint32_t next = 0;
  const int maxNonZero = c == Connectivity::Face6 ? 1 : c == Connectivity::Edge18 ? 2 : 3;
  for (int64_t start = 0; start < static_cast<int64_t>(v.size()); ++start) {
    if (!v.data()[start] || lab[static_cast<size_t>(start)]) continue;
    lab[static_cast<size_t>(start)] = ++next;
    std::vector<int64_t> queue{start};
    for (size_t h = 0; h < queue.size(); ++h) {
      const int64_t p = queue[h], i = p % d.x, j = (p / d.x) % d.y, k = p / (d.x * d.y);
      for (int dk = -1; dk <= 1; ++dk)
        for (int dj = -1; dj <= 1; ++dj)
          for (int di = -1; di <= 1; ++di) {
            const int n = (di != 0) + (dj != 0) + (dk != 0);
            if (n == 0 || n > maxNonZero) continue;
            const int64_t a = i + di, b = j + dj, e = k + dk;
            if (a < 0 || b < 0 || e < 0 || a >= d.x || b >= d.y || e >= d.z) continue;
            const int64_t q = (e * d.y + b) * d.x + a;
            if (v.data()[q] != v.data()[p] || lab[static_cast<size_t>(q)]) continue;
            lab[static_cast<size_t>(q)] = next;
            queue.push_back(q);
          }
    }
  }
  return lab;
}

}  // namespace

TEST(Components, TwoSeparatedBoxesHaveExactSizesAndBoxes) {
  VolumeU8 m = emptyMask({20, 12, 10});
  const IndexBox a{{1, 2, 3}, {4, 6, 5}};     // 4 x 5 x 3 = 60 voxels
  const IndexBox b{{10, 0, 0}, {19, 11, 9}};  // 10 x 12 x 10 = 1200 voxels, touching the faces
  fillBox(m, a);
  fillBox(m, b);
  for (Connectivity c : {Connectivity::Face6, Connectivity::Edge18, Connectivity::Vertex26}) {
    const Components cc = connectedComponents(m, c);
    ASSERT_EQ(cc.count(), 2);
    // Numbered in scan order of the first voxel: b's first voxel (10,0,0) precedes a's (1,2,3).
    EXPECT_EQ(cc.sizes[1], 1200);
    EXPECT_EQ(cc.sizes[2], 60);
    EXPECT_EQ(cc.boxes[1], b);
    EXPECT_EQ(cc.boxes[2], a);
    EXPECT_EQ(cc.values[1], 1);
    EXPECT_EQ(cc.largest(), 1u);
    EXPECT_EQ(cc.labels[m.linearIndex(0, 0, 0)], 0u);
    EXPECT_EQ(cc.labels[m.linearIndex(2, 4, 4)], 2u);
  }
}

TEST(Components, DiagonalNeighboursDependOnConnectivity) {
  VolumeU8 corner = emptyMask({4, 4, 4});
  corner(1, 1, 1) = corner(2, 2, 2) = 1;  // touch at a corner only
  EXPECT_EQ(connectedComponents(corner, Connectivity::Vertex26).count(), 1);
  EXPECT_EQ(connectedComponents(corner, Connectivity::Edge18).count(), 2);
  EXPECT_EQ(connectedComponents(corner, Connectivity::Face6).count(), 2);
  VolumeU8 edge = emptyMask({4, 4, 4});
  edge(1, 1, 1) = edge(1, 2, 2) = 1;  // touch along an edge only
  EXPECT_EQ(connectedComponents(edge, Connectivity::Vertex26).count(), 1);
  EXPECT_EQ(connectedComponents(edge, Connectivity::Edge18).count(), 1);
  EXPECT_EQ(connectedComponents(edge, Connectivity::Face6).count(), 2);
}

TEST(Components, ShapeJoinedOnlyAtTheTopIsOneComponentAcrossSlabs) {
  // A U: two columns over the whole height joined by a bar in the last slice. Every z-slab
  // sees two parts; only the merge across slab faces makes them one.
  VolumeU8 m = emptyMask({8, 3, 64});
  fillBox(m, {{0, 1, 0}, {0, 1, 63}});
  fillBox(m, {{7, 1, 0}, {7, 1, 63}});
  fillBox(m, {{0, 1, 63}, {7, 1, 63}});
  const Components c = connectedComponents(m, Connectivity::Face6);
  ASSERT_EQ(c.count(), 1);
  EXPECT_EQ(c.sizes[1], 64 + 64 + 6);
  EXPECT_EQ(c.boxes[1], (IndexBox{{0, 1, 0}, {7, 1, 63}}));
}

TEST(Components, RegionsOfDifferentIdsStaySeparate) {
  Geometry g;
  g.dims = {6, 2, 2};
  VolumeU16 ids(g, 0, 0);
  for (int64_t k = 0; k < 2; ++k)
    for (int64_t j = 0; j < 2; ++j)
      for (int64_t i = 0; i < 6; ++i) ids(i, j, k) = i < 3 ? 5 : 9;  // two touching blocks
  ids(5, 1, 1) = 0;
  const Components c = connectedRegions(ids, Connectivity::Vertex26);
  ASSERT_EQ(c.count(), 2);
  EXPECT_EQ(c.values[1], 5);
  EXPECT_EQ(c.values[2], 9);
  EXPECT_EQ(c.sizes[1], 12);
  EXPECT_EQ(c.sizes[2], 11);
}

TEST(Components, MatchBreadthFirstReferenceOnRandomMasks) {
  std::mt19937 rng(7);
  Geometry g;
  g.dims = {23, 17, 31};
  for (double density : {0.2, 0.45, 0.7}) {
    VolumeU16 v(g, 0, 0);
    std::bernoulli_distribution on(density);
    std::uniform_int_distribution<int> id(1, 3);
    for (auto& x : v.voxels()) x = on(rng) ? static_cast<uint16_t>(id(rng)) : 0;
    VolumeU8 mask(g, 0, 0.0);
    VolumeU16 ones(g, 0, 0);
    for (size_t t = 0; t < v.size(); ++t) mask.data()[t] = ones.data()[t] = v.data()[t] != 0;
    for (Connectivity c : {Connectivity::Face6, Connectivity::Edge18, Connectivity::Vertex26}) {
      EXPECT_EQ(connectedRegions(v, c).labels, referenceLabels(v, c)) << "density " << density;
      const Components m = connectedComponents(mask, c);
      EXPECT_EQ(m.labels, referenceLabels(ones, c)) << "density " << density;
      int64_t total = 0;
      for (int64_t s : m.sizes) total += s;
      EXPECT_EQ(total, static_cast<int64_t>(std::count(mask.voxels().begin(), mask.voxels().end(), 1)));
    }
  }
}

TEST(Components, KeepLargestAndRemoveSmallIslandsInMm) {
  VolumeU8 m = emptyMask({30, 10, 10}, 2.0);  // 8 mm³ voxels
  fillBox(m, {{0, 0, 0}, {3, 3, 3}});    // 64 voxels = 512 mm³
  fillBox(m, {{10, 0, 0}, {11, 1, 1}});  // 8 voxels = 64 mm³
  fillBox(m, {{20, 0, 0}, {20, 0, 0}});  // 1 voxel = 8 mm³
  auto count = [](const VolumeU8& x) { return std::count(x.voxels().begin(), x.voxels().end(), 1); };
  EXPECT_EQ(count(keepLargestComponent(m)), 64);
  EXPECT_EQ(count(removeSmallIslands(m, 64.0)), 72);  // exactly the threshold stays
  EXPECT_EQ(count(removeSmallIslands(m, 64.1)), 64);
  EXPECT_EQ(count(keepLargestComponent(emptyMask({3, 3, 3}))), 0);
  EXPECT_EQ(connectivityFromInt(18), Connectivity::Edge18);
  EXPECT_THROW(connectivityFromInt(8), Error);
}
