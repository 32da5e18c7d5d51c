#include <gtest/gtest.h>

#include "test_volumes.hpp"
#include "vellum/segmentation/label_map.hpp"

using namespace vellum;
using namespace vellum::segmentation;
using namespace vellum::segmentation::test;

namespace {
LabelVolume existing() {
  LabelVolume l(grid(6, 1, 1));
  l(0, 0, 0) = 1; l(1, 0, 0) = 1; l(2, 0, 0) = 2; l(5, 0, 0) = 3;
  l.setLabel({1, "a", {1, 2, 3}});
  return l;
}
Mask newSegment() {
  Mask m(grid(6, 1, 1), 0, 0.0);
  m(1, 0, 0) = m(2, 0, 0) = m(3, 0, 0) = 1;
  return m;
}
}  // namespace

TEST(LabelMap, OverlapRules) {
  {
    LabelVolume l = existing();
    const AddResult r = addSegment(l, newSegment(), {3, "new", {9, 9, 9}}, OverlapRule::Overwrite);
    EXPECT_EQ(r.written, 3);
    const uint16_t want[6] = {1, 3, 3, 3, 0, 3};
    for (int i = 0; i < 6; ++i) EXPECT_EQ(l(i, 0, 0), want[i]) << i;
    ASSERT_TRUE(l.label(3));
    EXPECT_EQ(l.label(3)->name, "new");
  }
  {
    LabelVolume l = existing();
    const AddResult r = addSegment(l, newSegment(), {3, "new", {9, 9, 9}}, OverlapRule::KeepExisting);
    EXPECT_EQ(r.written, 1);
    EXPECT_EQ(r.skipped, 2);
    const uint16_t want[6] = {1, 1, 2, 3, 0, 3};
    for (int i = 0; i < 6; ++i) EXPECT_EQ(l(i, 0, 0), want[i]) << i;
  }
  {
    LabelVolume l = existing();
    const AddResult r = addSegment(l, newSegment(), {3, "new", {9, 9, 9}}, OverlapRule::Replace);
    EXPECT_EQ(r.cleared, 1);
    const uint16_t want[6] = {1, 3, 3, 3, 0, 0};
    for (int i = 0; i < 6; ++i) EXPECT_EQ(l(i, 0, 0), want[i]) << i;
  }
  EXPECT_EQ(parseOverlapRule("only-background"), OverlapRule::KeepExisting);
  EXPECT_THROW(parseOverlapRule("merge"), Error);
}

TEST(LabelMap, RejectsIdZeroAndOtherGeometry) {
  LabelVolume l = existing();
  EXPECT_THROW(addSegment(l, newSegment(), {0, "bg", {0, 0, 0}}), Error);
  Mask other(grid(5, 1, 1), 0, 0.0);
  EXPECT_THROW(addSegment(l, other, {4, "x", {0, 0, 0}}), Error);
}
