#pragma once
// LabelVolume: integer segment ids per voxel plus a label table (id, name, colour).
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "vellum/core/volume.hpp"

namespace vellum {

struct Label {
  uint16_t id = 0;  ///< 0 is reserved for "background / unclassified"
  std::string name;
  std::array<uint8_t, 3> rgb{255, 255, 255};
  bool operator==(const Label&) const = default;
};

/// Ids are held as uint16 in memory; files store uint8 when every id fits (see io).
class LabelVolume {
 public:
  LabelVolume() = default;
  explicit LabelVolume(const Geometry& g) : ids_(g, 0, 0.0) {}
  explicit LabelVolume(VolumeU16 ids, std::vector<Label> table = {})
      : ids_(std::move(ids)), table_(std::move(table)) {}

  VolumeU16& ids() { return ids_; }
  const VolumeU16& ids() const { return ids_; }
  const Geometry& geometry() const { return ids_.geometry(); }
  uint16_t operator()(int64_t i, int64_t j, int64_t k) const { return ids_(i, j, k); }
  uint16_t& operator()(int64_t i, int64_t j, int64_t k) { return ids_(i, j, k); }

  const std::vector<Label>& table() const { return table_; }
  /// Adds or replaces the entry with label.id.
  void setLabel(const Label& label);
  std::optional<Label> label(uint16_t id) const;
  /// Lowest id >= 1 not used in the table.
  uint16_t nextFreeId() const;
  /// Largest id present in the voxels (parallel).
  uint16_t maxId() const;
  /// Number of voxels per id (index = id), sized maxId()+1.
  std::vector<uint64_t> histogram() const;

 private:
  VolumeU16 ids_;
  std::vector<Label> table_;
};

/// A distinct, readable default colour for label id `id`.
std::array<uint8_t, 3> defaultLabelColor(uint16_t id);

}  // namespace vellum
