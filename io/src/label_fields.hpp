#pragma once
// Label table <-> NRRD key/value fields: Vellum's own "vellum_label_<id>:=name r g b" and the
// 3D Slicer segmentation fields (Segment<N>_ID/_Name/_Color/_LabelValue/_Layer ...), so that
// Slicer shows segment names and colours for a label map written by Vellum.
#include <filesystem>
#include <map>
#include <ostream>
#include <string>
#include <vector>

#include "vellum/core/label_volume.hpp"

namespace vellum::io::detail {

/// Reads the table: vellum_label_* entries when present, else Slicer Segment*_ fields.
/// `found` is set when either kind was present. Malformed entries throw FileError.
std::vector<Label> parseLabelFields(const std::filesystem::path& path,
                                    const std::map<std::string, std::string>& keyValues,
                                    bool* found);

/// Writes both kinds of fields, one line each, sorted by id.
void writeLabelFields(std::ostream& out, const std::vector<Label>& labels, const Dims& dims);

}  // namespace vellum::io::detail
