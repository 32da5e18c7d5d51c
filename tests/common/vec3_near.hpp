#pragma once
// EXPECT_VEC3_NEAR(v, x, y, z, tol): each component of a Vec3 (a spacing, an origin, a
// physical position) within `tol` of x, y, z; a failure names the expression and the axis.
#include <gtest/gtest.h>

#include "vellum/core/vec.hpp"

#define EXPECT_VEC3_NEAR(v, x_, y_, z_, tol)                    \
  do {                                                          \
    const ::vellum::Vec3 vec3Near_ = (v);                       \
    EXPECT_NEAR(vec3Near_.x, (x_), (tol)) << #v << ".x";        \
    EXPECT_NEAR(vec3Near_.y, (y_), (tol)) << #v << ".y";        \
    EXPECT_NEAR(vec3Near_.z, (z_), (tol)) << #v << ".z";        \
  } while (0)
