#pragma once
// Open RAW: a bare .raw (no header, no sidecar) opened through a dialog that asks its layout
// (dims, voxel type, spacing, byte order, header bytes). The answer is written as a detached
// NRRD header (.nhdr) naming the data file by its absolute path, in the studio's state folder
// (the user's own), never beside the data (which may be read-only or someone else's). The
// studio then opens that header like any volume; since io refuses a header that reads data
// outside its folder unless told (a downloaded header must not read any file), the studio
// allows it for the headers of that folder only, and the CLI commands it gives say
// --allow-outside-data.
#include <filesystem>
#include <string>

#include "vellum/io/volume_io.hpp"

namespace vellum::studio {

class StudioApp;

/// Writes the header for `raw` with `layout` into `folder` as "<raw stem>.nhdr" (atomically,
/// through the output policy) and returns its path. Throws vellum::FileError naming the file
/// when `raw` is missing or its size does not fit the layout (header + dims x voxel size).
std::filesystem::path writeRawHeader(const std::filesystem::path& raw, const io::RawLayout& layout,
                                     const std::filesystem::path& folder);

/// Where the studio writes it: "<state folder>/raw-headers" (empty when there is no state
/// folder: no $XDG_STATE_HOME nor $HOME).
std::filesystem::path rawHeaderFolder();
/// True for a header in that folder: one the user wrote through Open RAW.
bool isOpenRawHeader(const std::filesystem::path& path);

/// The dialog's answers.
struct RawDialogState {
  bool open = false;
  std::filesystem::path data;
  int dims[3] = {512, 512, 1};
  int type = 0;  ///< index into VoxelType: int16, uint8, uint16, float32
  float spacing[3] = {1, 1, 1};
  bool bigEndian = false;
  int headerBytes = 0;
  io::RawLayout layout() const;
};
RawDialogState& rawDialog();

/// Writes the header for the dialog's answers and opens it (requestOpen). Errors go to the
/// error box.
void openRawAs(StudioApp& app, const RawDialogState& answers);
/// The "Open RAW..." button (a file browser, then the dialog) and the dialog window.
void rawOpenButton(StudioApp& app);
void drawRawDialog(StudioApp& app);

}  // namespace vellum::studio
