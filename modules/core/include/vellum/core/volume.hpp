#pragma once
// Volume<T>: a dense scalar voxel grid with physical geometry.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <type_traits>
#include <variant>
#include <vector>

#include "vellum/core/error.hpp"
#include "vellum/core/geometry.hpp"
#include "vellum/core/memory_budget.hpp"

namespace vellum {

enum class VoxelType { Int16, UInt8, UInt16, Float32 };

template <class T> constexpr VoxelType voxelTypeOf();
template <> constexpr VoxelType voxelTypeOf<int16_t>() { return VoxelType::Int16; }
template <> constexpr VoxelType voxelTypeOf<uint8_t>() { return VoxelType::UInt8; }
template <> constexpr VoxelType voxelTypeOf<uint16_t>() { return VoxelType::UInt16; }
template <> constexpr VoxelType voxelTypeOf<float>() { return VoxelType::Float32; }

/// "int16", "uint8", "uint16", "float32".
const char* voxelTypeName(VoxelType t);
/// Parses the names above (also "float", "short", "ushort", "uchar"); throws vellum::Error.
VoxelType parseVoxelType(const std::string& name);
uint64_t voxelTypeSize(VoxelType t);

/// Background value by convention: -1000 (air) for CT in HU, 0 for everything else.
constexpr double kCtAirHu = -1000.0;

template <class T>
class Volume {
 public:
  using value_type = T;

  Volume() = default;
  /// Allocates dims voxels filled with `fill`, after the memory budget check.
  /// `background` is what sampling returns outside the grid.
  explicit Volume(const Geometry& geometry, T fill = T{}, double background = 0.0)
      : geometry_(geometry), background_(background) {
    checkMemoryBudget(geometry.dims, sizeof(T), voxelTypeName(voxelTypeOf<T>()));
    resizeHugePaged(data_, static_cast<size_t>(geometry.dims.voxelCount()), fill);
  }

  const Geometry& geometry() const { return geometry_; }
  /// Changes spacing/origin/direction; dims must stay the same.
  void setGeometry(const Geometry& g) {
    if (!(g.dims == geometry_.dims)) throw Error("Volume::setGeometry: dims differ");
    geometry_ = g;
  }
  const Dims& dims() const { return geometry_.dims; }
  double background() const { return background_; }
  void setBackground(double b) { background_ = b; }

  size_t size() const { return data_.size(); }
  bool empty() const { return data_.empty(); }
  T* data() { return data_.data(); }
  const T* data() const { return data_.data(); }
  std::vector<T>& voxels() { return data_; }
  const std::vector<T>& voxels() const { return data_; }

  size_t linearIndex(int64_t i, int64_t j, int64_t k) const {
    return static_cast<size_t>((k * geometry_.dims.y + j) * geometry_.dims.x + i);
  }
  T& operator()(int64_t i, int64_t j, int64_t k) { return data_[linearIndex(i, j, k)]; }
  const T& operator()(int64_t i, int64_t j, int64_t k) const { return data_[linearIndex(i, j, k)]; }

  /// Value at integer index, background outside.
  double valueOr(int64_t i, int64_t j, int64_t k) const {
    return geometry_.contains(i, j, k) ? static_cast<double>((*this)(i, j, k)) : background_;
  }

  /// Nearest-neighbour sample at continuous index coordinates; background outside
  /// [-0.5, dim-0.5) on any axis.
  double sampleNearest(const Vec3& ijk) const {
    return valueOr(static_cast<int64_t>(std::floor(ijk.x + 0.5)),
                   static_cast<int64_t>(std::floor(ijk.y + 0.5)),
                   static_cast<int64_t>(std::floor(ijk.z + 0.5)));
  }

  /// Trilinear sample at continuous index coordinates. Neighbours outside the grid take the
  /// background value (never clamp-to-edge), so values fade to background over the half voxel
  /// beyond the outermost centres, and are exactly background one voxel beyond.
  double sampleLinear(const Vec3& ijk) const {
    const double fx = std::floor(ijk.x), fy = std::floor(ijk.y), fz = std::floor(ijk.z);
    const auto i0 = static_cast<int64_t>(fx), j0 = static_cast<int64_t>(fy),
               k0 = static_cast<int64_t>(fz);
    const double tx = ijk.x - fx, ty = ijk.y - fy, tz = ijk.z - fz;
    const Dims& d = geometry_.dims;
    if (i0 >= 0 && j0 >= 0 && k0 >= 0 && i0 + 1 < d.x && j0 + 1 < d.y && k0 + 1 < d.z) {
      // Fast path: all eight neighbours inside.
      const size_t sx = 1, sy = static_cast<size_t>(d.x), sz = static_cast<size_t>(d.x * d.y);
      const T* p = data_.data() + linearIndex(i0, j0, k0);
      const double c00 = p[0] + tx * (double(p[sx]) - p[0]);
      const double c10 = p[sy] + tx * (double(p[sy + sx]) - p[sy]);
      const double c01 = p[sz] + tx * (double(p[sz + sx]) - p[sz]);
      const double c11 = p[sz + sy] + tx * (double(p[sz + sy + sx]) - p[sz + sy]);
      const double c0 = c00 + ty * (c10 - c00), c1 = c01 + ty * (c11 - c01);
      return c0 + tz * (c1 - c0);
    }
    if (i0 < -1 || j0 < -1 || k0 < -1 || i0 >= d.x || j0 >= d.y || k0 >= d.z) return background_;
    auto v = [&](int64_t a, int64_t b, int64_t c) { return valueOr(a, b, c); };
    const double c00 = v(i0, j0, k0) + tx * (v(i0 + 1, j0, k0) - v(i0, j0, k0));
    const double c10 = v(i0, j0 + 1, k0) + tx * (v(i0 + 1, j0 + 1, k0) - v(i0, j0 + 1, k0));
    const double c01 = v(i0, j0, k0 + 1) + tx * (v(i0 + 1, j0, k0 + 1) - v(i0, j0, k0 + 1));
    const double c11 =
        v(i0, j0 + 1, k0 + 1) + tx * (v(i0 + 1, j0 + 1, k0 + 1) - v(i0, j0 + 1, k0 + 1));
    const double c0 = c00 + ty * (c10 - c00), c1 = c01 + ty * (c11 - c01);
    return c0 + tz * (c1 - c0);
  }

  /// Samples at a physical position (mm).
  double sampleLinearMm(const Vec3& p) const { return sampleLinear(geometry_.physicalToIndex(p)); }
  double sampleNearestMm(const Vec3& p) const { return sampleNearest(geometry_.physicalToIndex(p)); }

  /// Minimum and maximum voxel value (parallel). {0,0} for an empty volume.
  std::pair<double, double> valueRange() const;

 private:
  Geometry geometry_;
  double background_ = 0.0;
  std::vector<T> data_;
};

extern template class Volume<int16_t>;
extern template class Volume<uint8_t>;
extern template class Volume<uint16_t>;
extern template class Volume<float>;

using VolumeI16 = Volume<int16_t>;  ///< CT in Hounsfield units
using VolumeU8 = Volume<uint8_t>;
using VolumeU16 = Volume<uint16_t>;
using VolumeF32 = Volume<float>;

/// Any of the supported voxel types; what loaders return.
using AnyVolume = std::variant<VolumeI16, VolumeU8, VolumeU16, VolumeF32>;

const Geometry& geometryOf(const AnyVolume& v);
VoxelType voxelTypeOf(const AnyVolume& v);
double backgroundOf(const AnyVolume& v);

/// Converts any volume to another voxel type, rounding and saturating to the target range.
template <class To>
Volume<To> convertVolume(const AnyVolume& v);

/// Converts to int16 HU-like values (rounding, saturating), keeping geometry and background.
VolumeI16 toInt16(const AnyVolume& v);
VolumeF32 toFloat32(const AnyVolume& v);

}  // namespace vellum
