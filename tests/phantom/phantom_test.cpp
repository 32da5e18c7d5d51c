#include <gtest/gtest.h>
#include "vellum/phantom/phantom.hpp"
TEST(Phantom, Placeholder) { EXPECT_TRUE(vellum::phantom::isBone(vellum::phantom::kFemurCortex)); }
