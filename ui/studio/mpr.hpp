#pragma once
// The slice views' resampling is vellum::app's (vellum/app/mpr.hpp), shared with `vellum slice`;
// the studio uses its names as its own.
#include "scene.hpp"
#include "vellum/app/mpr.hpp"

namespace vellum::studio {

using app::findWindowPreset;
using app::makePlane;
using app::navigated;
using app::orientationLetters;
using app::pannedBy;
using app::renderSlice;
using app::SliceAxis;
using app::sliceAxisName;
using app::SliceNavigation;
using app::SlicePlane;
using app::SliceStyle;
using app::WindowPreset;
using app::windowPresets;
using app::zoomedAbout;

}  // namespace vellum::studio
