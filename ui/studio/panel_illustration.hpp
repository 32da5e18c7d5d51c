#pragma once
// The Illustration panel: shapes (made from the labels or read from a `vellum shape`
// folder), the 3D view as an illustration, the style preset and every style field, per
// segment, generated from the style's parameter tables (one undo step per finished edit).
namespace vellum::studio {
class StudioApp;
void illustrationSection(StudioApp& app);
}  // namespace vellum::studio
