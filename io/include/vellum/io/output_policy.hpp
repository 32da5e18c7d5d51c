#pragma once
// The output policy every writer follows (CLI, studio, app layer), so that nothing the user
// made is ever lost:
//  - an output replaces only a file of the same kind (a NRRD replaces a NRRD, never a folder,
//    never a text file that happens to have the name);
//  - a folder output (DICOM series, shape folder, movie frames, demo) is created new, or
//    replaces a folder Vellum wrote before: its marker file ".vellum-<kind>" says what it
//    holds. A folder without a marker is never replaced or written into; a Vellum folder of
//    another kind only with `force`;
//  - no output is, contains, or shares a data file with an input of the same command
//    (symlinks and hard links resolved; detached NRRD / MetaImage data files and RAW sidecars
//    count as part of their header).
// Commands describe their inputs and outputs in an OutputPlan and call check() before any
// work, so a refusal costs nothing; the writers check again when they replace.
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace vellum::io {

/// Folder outputs Vellum writes; the marker ".vellum-<name>" inside names the kind (Qa: a
/// `vellum qa` run folder).
enum class FolderKind { DicomSeries, Shape, Frames, Demo, Qa };

/// "series", "shape", "frames", "demo", "qa".
const char* folderKindName(FolderKind kind);
/// The marker file's name inside a folder of `kind` (".vellum-series", ...).
std::string folderMarkerName(FolderKind kind);

/// Throws FileError naming `folder` when a folder output of `kind` may not be written there:
/// it exists and is a file, or a folder without Vellum's marker, or (without `force`) a
/// Vellum folder of another kind. A missing folder is fine.
void checkFolderOutput(const std::filesystem::path& folder, FolderKind kind, bool force = false);

/// Writes a folder output atomically: write(tmp) fills a new hidden sibling folder, the marker
/// is added, and the complete folder replaces `target` (checked by checkFolderOutput first;
/// the old folder is removed only once the new one is in place). On any exception nothing is
/// left behind and `target` is untouched.
void writeFolderAtomically(const std::filesystem::path& target, FolderKind kind,
                           const std::function<void(const std::filesystem::path& tmp)>& write,
                           bool force = false);

/// Makes `folder` ready to be written into in place (the demo, whose many outputs are listed
/// as they are made): checkFolderOutput, then create it and its marker.
void prepareFolderInPlace(const std::filesystem::path& folder, FolderKind kind, bool force = false);

/// The files reading `path` touches: the path itself, a detached data file named by a
/// .nhdr / .nrrd / .mhd header, a .raw file's sidecar "<name>.raw.json".
std::vector<std::filesystem::path> filesReadFrom(const std::filesystem::path& path);
/// The files saving a volume or label map to `path` writes: the path, the data file of a
/// .nhdr (gzip or raw) or .mhd, a .raw file's sidecar.
std::vector<std::filesystem::path> filesWrittenTo(const std::filesystem::path& path, bool gzip = true);

/// A command's inputs and outputs, checked against the policy above before any work.
class OutputPlan {
 public:
  /// A file or folder the command reads; `what` names it in errors ("--truth"). Empty paths
  /// are ignored, so optional flags can be added unconditionally.
  OutputPlan& input(const std::filesystem::path& path, const std::string& what = "the input");
  /// A volume, label map, image, movie or JSON file the command writes (its data file and
  /// sidecar included). A path without an extension (or ending in .dcm) is a DICOM series
  /// folder, as volume_io's writers take it.
  OutputPlan& output(const std::filesystem::path& path, const std::string& what = "the output",
                     bool gzip = true);
  /// A JSON file (a report, a style, control points) whatever its name's extension.
  OutputPlan& json(const std::filesystem::path& path, const std::string& what);
  /// A folder output of `kind`.
  OutputPlan& folder(const std::filesystem::path& path, FolderKind kind,
                     const std::string& what = "the output");
  /// Replace Vellum folders of another kind too (--force).
  OutputPlan& force(bool on) {
    force_ = on;
    return *this;
  }
  /// Throws FileError naming the offending output and saying why.
  void check() const;

 private:
  struct Entry {
    std::filesystem::path path;
    std::string what;
    std::vector<std::filesystem::path> files;  ///< what it reads or writes
    bool isFolder = false;
    FolderKind kind = FolderKind::DicomSeries;
    std::string format;  ///< the extension whose signature an existing file must have
  };
  std::vector<Entry> inputs_, outputs_;
  bool force_ = false;
};

/// Throws FileError when an existing `path` may not be replaced by an output file of the kind
/// `format` (an extension such as ".nrrd"; default: the path's own) names: it is a folder, or
/// its first bytes are not that format (a file named "x.nrrd" that is not NRRD, "x.png" that
/// is not PNG, a report over a volume ...).
void checkFileOutput(const std::filesystem::path& path, const std::string& format = {});

}  // namespace vellum::io
