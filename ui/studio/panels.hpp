#pragma once
// The tool panel on the left of the window: file, view, segmentation, labels, undo.
namespace vellum::studio {

class StudioApp;

/// Draws the panel (fixed at the window's left edge) for this frame.
void drawToolPanel(StudioApp& app, float width, float height);

}  // namespace vellum::studio
