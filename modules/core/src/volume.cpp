#include "vellum/core/volume.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <cctype>
#include <limits>

namespace vellum {

const char* voxelTypeName(VoxelType t) {
  switch (t) {
    case VoxelType::Int16: return "int16";
    case VoxelType::UInt8: return "uint8";
    case VoxelType::UInt16: return "uint16";
    case VoxelType::Float32: return "float32";
  }
  return "unknown";
}

VoxelType parseVoxelType(const std::string& name) {
  std::string n;
  for (char c : name) n += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (n == "int16" || n == "short" || n == "int16_t" || n == "signed short") return VoxelType::Int16;
  if (n == "uint8" || n == "uchar" || n == "uint8_t" || n == "unsigned char") return VoxelType::UInt8;
  if (n == "uint16" || n == "ushort" || n == "uint16_t" || n == "unsigned short")
    return VoxelType::UInt16;
  if (n == "float32" || n == "float") return VoxelType::Float32;
  throw Error("unsupported voxel type '" + name + "' (use int16, uint8, uint16 or float32)");
}

uint64_t voxelTypeSize(VoxelType t) {
  switch (t) {
    case VoxelType::Int16: return 2;
    case VoxelType::UInt8: return 1;
    case VoxelType::UInt16: return 2;
    case VoxelType::Float32: return 4;
  }
  return 0;
}

template <class T>
std::pair<double, double> Volume<T>::valueRange() const {
  if (data_.empty()) return {0.0, 0.0};
  using Range = std::pair<double, double>;
  const Range init{std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
  return tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, data_.size(), 1 << 16), init,
      [&](const tbb::blocked_range<size_t>& r, Range acc) {
        T lo = data_[r.begin()], hi = data_[r.begin()];
        for (size_t i = r.begin(); i < r.end(); ++i) {
          lo = std::min(lo, data_[i]);
          hi = std::max(hi, data_[i]);
        }
        return Range{std::min<double>(acc.first, lo), std::max<double>(acc.second, hi)};
      },
      [](Range a, Range b) { return Range{std::min(a.first, b.first), std::max(a.second, b.second)}; });
}

template class Volume<int16_t>;
template class Volume<uint8_t>;
template class Volume<uint16_t>;
template class Volume<float>;

const Geometry& geometryOf(const AnyVolume& v) {
  return std::visit([](const auto& vol) -> const Geometry& { return vol.geometry(); }, v);
}

VoxelType voxelTypeOf(const AnyVolume& v) {
  return std::visit([](const auto& vol) { return voxelTypeOf<typename std::decay_t<decltype(vol)>::value_type>(); }, v);
}

double backgroundOf(const AnyVolume& v) {
  return std::visit([](const auto& vol) { return vol.background(); }, v);
}

template <class To>
Volume<To> convertVolume(const AnyVolume& any) {
  return std::visit(
      [](const auto& src) {
        using From = typename std::decay_t<decltype(src)>::value_type;
        Volume<To> out(src.geometry(), To{}, src.background());
        if constexpr (std::is_same_v<From, To>) {
          out.voxels() = src.voxels();
        } else {
          const From* in = src.data();
          To* o = out.data();
          const size_t n = src.size();
          for (size_t i = 0; i < n; ++i) {
            if constexpr (std::is_floating_point_v<To>) {
              o[i] = static_cast<To>(in[i]);
            } else {
              double v = static_cast<double>(in[i]);
              if constexpr (std::is_floating_point_v<From>) v = std::isfinite(v) ? std::round(v) : 0.0;
              v = std::clamp(v, double(std::numeric_limits<To>::lowest()), double(std::numeric_limits<To>::max()));
              o[i] = static_cast<To>(v);
            }
          }
        }
        return out;
      },
      any);
}

template Volume<int16_t> convertVolume<int16_t>(const AnyVolume&);
template Volume<uint8_t> convertVolume<uint8_t>(const AnyVolume&);
template Volume<uint16_t> convertVolume<uint16_t>(const AnyVolume&);
template Volume<float> convertVolume<float>(const AnyVolume&);

VolumeI16 toInt16(const AnyVolume& v) { return convertVolume<int16_t>(v); }
VolumeF32 toFloat32(const AnyVolume& v) { return convertVolume<float>(v); }

}  // namespace vellum
