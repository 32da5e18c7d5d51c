#pragma once
// The tool panel on the left of the window: file, view, segmentation, labels, undo.
#include <vector>

namespace vellum::studio {

class StudioApp;

/// The keyboard and mouse shortcuts (Help in the panel; docs/studio.md lists the same).
struct Shortcut {
  const char* keys;
  const char* what;
};
const std::vector<Shortcut>& shortcuts();

/// Draws the panel (fixed at the window's left edge) for this frame.
void drawToolPanel(StudioApp& app, float width, float height);

}  // namespace vellum::studio
