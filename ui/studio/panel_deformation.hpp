#pragma once
// The Deformation panel: control points (place, add, delete), rigid bones, the keyframe
// timeline (blocks as wide as their durations), playback and the movie export.
namespace vellum::studio {
class StudioApp;
void deformationSection(StudioApp& app);
}  // namespace vellum::studio
