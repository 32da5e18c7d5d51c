#pragma once
// What the GL illustration shader and the CPU reference share (internal): the packed style
// table (its layout: style_layout.hpp), the precomputed gradient volumes, per-block
// visibility, and the per-sample model in C++ (the CPU reference of styled() in
// illustration/shaders/illustration_sample.frag.glsl, line for line).
#include <array>
#include <cstdint>
#include <vector>

#include "style_layout.hpp"
#include "vellum/illustration/illustration_renderer.hpp"

namespace vellum::illustration::detail {

constexpr int kMaxLabels = 256;
constexpr int kBlock = 8;          ///< empty-space skipping block, voxels per axis
constexpr int kTfSize = 1024;      ///< CT transfer-function table entries (alpha per mm)
constexpr float kEarlyAlpha = 0.99f;

struct Vec3f {
  float x = 0, y = 0, z = 0;
};
inline Vec3f operator+(Vec3f a, Vec3f b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec3f operator-(Vec3f a, Vec3f b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec3f operator*(Vec3f a, float s) { return {a.x * s, a.y * s, a.z * s}; }
inline float dot(Vec3f a, Vec3f b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

/// The style as the shader sees it: rows[label] = kRowTexels RGBA texels; features pick the
/// shader variant.
struct StyleTable {
  int rows = 0;
  std::vector<float> texels;                 ///< rows * kRowTexels * 4
  std::array<bool, kMaxLabels> visible{};    ///< per label
  bool usesCt = false;                       ///< some visible row needs the CT
  bool usesTexture = false;                  ///< some visible row has a procedural texture
  bool usesTextureVolume = false;
  Vec3f light;                               ///< camera space, normalised
  std::vector<float> tf;                     ///< CT TF: 4 * kTfSize, alpha per mm
  float tfLo = 0, tfHi = 1;
  StyleRow row(int label) const { return StyleRow(texels.data() + static_cast<size_t>(label) * kRowTexels * 4); }
};
/// Rows for ids 0..255 (features only from ids <= maxId); g: the scene grid (depths in mm).
StyleTable packStyle(const Style& style, const std::vector<Label>& table, int maxId, const Geometry& g);

/// IEEE half conversion (round to nearest even), so CPU and GL see identical values.
uint16_t floatToHalf(float f);
float halfToFloat(uint16_t h);

/// 4 channels per voxel as half floats (uploaded as-is) and their decoded floats (CPU).
struct Volume4 {
  Dims dims;
  std::vector<uint16_t> half;
  std::vector<float> value;
  const float* at(int64_t i, int64_t j, int64_t k) const {
    return value.data() + ((k * dims.y + j) * dims.x + i) * 4;
  }
  /// Trilinear with clamp-to-edge at continuous index coordinates (GL_LINEAR + CLAMP_TO_EDGE).
  std::array<float, 4> sampleLinear(float x, float y, float z) const;
};
/// (grad d in physical mm, d): label-aware differences (a neighbour with another label is
/// not used: one-sided there), so interfaces between segments keep each side's normal.
Volume4 computeDistanceGradient(const VolumeF32& distance, const VolumeU16& labels);
/// (grad CT in HU/mm physical, CT value).
Volume4 computeCtGradient(const AnyVolume& ct);

/// Per 8^3 block, the labels present in the block dilated by one voxel (256-bit masks).
struct BlockLabels {
  Dims blocks;
  std::vector<std::array<uint64_t, 4>> masks;
  std::vector<float> minAbsDistance;  ///< smallest |d| in the dilated block (mm)
  std::vector<float> ctMin, ctMax;     ///< CT value range in the dilated block (when a CT is set)
};
/// Fills ctMin/ctMax from the CT (same grid as the labels).
void computeBlockCtRange(BlockLabels& b, const AnyVolume& ct);
BlockLabels computeBlockLabels(const VolumeU16& labels, const VolumeF32& distance);
/// A block is occupied when a visible row's label is in it, and that row can have opacity
/// there: rows whose boundary enhancement has k_c = 0 on the distance measure are zero
/// wherever |d| >= boundary_width_mm, so blocks farther from every surface are skipped; rows
/// that are only the CT's transfer function (l2 = l3 = 0, illum = ct) are zero where the TF
/// has no opacity over the block's CT range (needs ctMin/ctMax).
std::vector<uint8_t> blockOccupancy(const BlockLabels& b, const StyleTable& t);

/// Texture volume for SolidTexture::Volume, normalised to [0, 1].
struct TextureVolume {
  Dims dims;
  std::vector<float> value;
  float sampleRepeat(float x, float y, float z) const;  ///< GL_LINEAR + GL_REPEAT, texel units
};
TextureVolume loadTextureVolume(const std::string& path);

/// Per-frame constants of the model.
struct SampleFrame {
  Vec3f light, centre;
  Vec3f forward;
  float radius = 1, coverageH = 1, stepMm = 1;
};

/// Styled RGBA (premultiplied, alpha per mm before the step correction) of one voxel/sample.
/// g4 = (grad d, d), ct4 = (grad CT, CT) or null, view = unit vector to the eye.
std::array<float, 4> styledSample(const StyleTable& t, int label, const float* g4, const float* ct4,
                                  const TextureVolume* texVol, Vec3f pMm, float depth, Vec3f view,
                                  const SampleFrame& f);

}  // namespace vellum::illustration::detail

namespace vellum::render::detail {
struct Frame;
}
namespace vellum::illustration::detail {
/// Bounding sphere (depth), light in physical space, coverage width, step.
SampleFrame makeSampleFrame(const Geometry& g, const render::detail::Frame& f, const StyleTable& t);
}  // namespace vellum::illustration::detail
