#pragma once
// What the GL illustration shader and the CPU reference share (internal): the packed style
// table (its layout: style_layout.hpp), the precomputed gradient volumes, per-block
// visibility, and the per-sample model in C++ (the CPU reference of styled() in
// illustration/shaders/illustration_sample.frag.glsl, line for line).
#include <array>
#include <cstdint>
#include <vector>
#include <algorithm>
#include <cmath>

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
  std::array<bool, kMaxLabels> visible{};    ///< per label: shows colour or ink
  std::array<bool, kMaxLabels> shows{};      ///< per label: has colour/opacity (not ink only)
  bool usesInk = false;                      ///< some visible row draws lines or hatching
  float maxLineWidthPx = 0;                  ///< widest ink line of a visible row
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
/// (grad CT in HU/mm physical, CT value).
Volume4 computeCtGradient(const AnyVolume& ct);

/// One paint slot: a segment's field, its id and its shell (ShapeScene::fields, id order).
struct PaintSlot {
  int id = 0, shellId = 0;
  float shellMm = 0;
};
/// Field value -> mm as GL decodes RGBA16_SNORM texels: max(v / 32767, -1) * kFieldScaleMm.
constexpr float kFieldScaleMm = float(32767 * kFieldQuantumMm);
inline float decodeField(int16_t v) { return std::max(float(v) / 32767.f, -1.f) * kFieldScaleMm; }

/// The shader's painter loop visits item 2k = slot n-1-k's shell row (its row when it has
/// no shell), 2k+1 = its core row (shells only), 2n = label 0: `items` gets those whose row
/// can show (StyleRow Visible), in that order; `inkSlots` the slots whose outermost row draws
/// ink. Skipping the others changes nothing in the picture (their samples add nothing).
void paintItems(const StyleTable& t, const std::vector<PaintSlot>& slots, std::vector<int>& items,
                std::vector<int>& inkSlots);
/// The per-segment distances as the shader sees them: slot s is channel s % 4 of group s / 4;
/// groups are stacked along z in one RGBA16_SNORM texture (dims.x, dims.y, dims.z * groups).
struct FieldVolume {
  Dims dims;
  int groups = 0;
  std::vector<PaintSlot> slots;
  std::vector<float> value;  ///< CPU only: decoded mm, [group][z][y][x][4]
  /// Trilinear (clamp to edge) at continuous index p for every slot: d (mm) and the index-
  /// space gradient of the interpolated field, central (+-1 voxel) or forward differences.
  /// A group none of whose slots s has lo[s] < d < hi[s] gets zero gradients (not fetched:
  /// they would never be used; gradientWindows).
  void sample(float x, float y, float z, bool central, const float* lo, const float* hi, float* d,
              Vec3f* gradIndex) const;
  /// One slot's distance (mm) at continuous index p (trilinear, clamp to edge).
  float at(float x, float y, float z, int slot) const;
};
/// Per slot (padded to whole groups), the open distance interval (lo, hi) where its gradient
/// can change the picture: the slot covers the sample (d < h/2), one of its rows is visible,
/// and the normal terms have not faded out (|d| < 4 boundary widths, see styledSample);
/// everywhere when label 0 shows (it takes the nearest surface's gradient); empty otherwise.
void gradientWindows(const StyleTable& t, const std::vector<PaintSlot>& slots, float coverageH,
                     std::vector<float>& lo, std::vector<float>& hi);
/// Adaptive step (empty and homogeneous space): per slot (padded to whole groups), the
/// distances beyond which the slot's part of every sample is constant along the ray: outside
/// d > out[s] (coverage 0 and no ink pass) or inside d < -in[s] (full coverage, no boundary,
/// normal, shell or ink terms; rows reading the CT or a texture never qualify: in = inf).
/// A sample whose slots are all beyond theirs stands for the next floor(0.9 * r / step)
/// samples, r = min over slots of (d - out, -in - d): its colour is composited once for that
/// length (exact but for depth dimming across the span). marginMm covers the far field's upper
/// bound (about a voxel). Everything is inf when label 0 shows (it follows every surface).
void skipBands(const StyleTable& t, const std::vector<PaintSlot>& slots, float coverageH, float inkPassMm,
               float marginMm, std::vector<float>& out, std::vector<float>& in);
/// skipBands' margin for a grid: the far field's error (about a voxel of the largest spacing).
inline float skipMarginMm(const Geometry& g) { return float(1.5 * std::max({g.spacing.x, g.spacing.y, g.spacing.z})); }
/// Samples a homogeneous sample stands for (1 = no skip), given the slots' distances d (slot
/// order), the bands, the step and the samples left on the ray (the GL shader's formula).
inline int skipSamples(const float* d, size_t n, const float* out, const float* in, float stepMm, int64_t left) {
  float r = 1e30f;
  for (size_t s = 0; s < n; ++s) r = std::min(r, std::max({d[s] - out[s], -in[s] - d[s], 0.f}));
  const float k = std::floor(0.9f * r / stepMm);
  if (!(k >= 2.f)) return 1;
  return int(std::min<int64_t>(int64_t(std::min(k, 1e6f)), std::max<int64_t>(left, 1)));
}
/// Slots from the scene; `decode` fills value (the CPU reference).
FieldVolume makeFieldVolume(const ShapeScene& scene, bool decode);
/// Interleaved RGBA int16 texels of group g, slices [z0, z1) (the GL upload, slab by slab).
void packFieldSlab(const ShapeScene& scene, int group, int64_t z0, int64_t z1, std::vector<int16_t>& out);

/// Per 8^3 block (dilated by two voxels: trilinear + the gradient stencil), each slot's
/// distance range, for empty-space skipping.
struct BlockFields {
  Dims blocks;
  int slots = 0;
  std::vector<float> minD, maxD;       ///< blocks x slots (mm)
  std::vector<float> ctMin, ctMax;     ///< CT value range in the dilated block (when a CT is set)
};
BlockFields computeBlockFields(const ShapeScene& scene);
/// Fills ctMin/ctMax from the CT (same grid as the fields).
void computeBlockCtRange(BlockFields& b, const AnyVolume& ct);
/// A block is occupied when a visible row can have opacity there: its slot's coverage is
/// non-zero (min d < h/2); rows whose boundary enhancement has k_c = 0 on the distance measure
/// are zero wherever |d| >= boundary_width_mm; rows that are only the CT's transfer function
/// are zero where the TF has no opacity over the block's CT range (needs ctMin/ctMax); label
/// 0 shows wherever no slot covers the whole block. Rows with ink (lines, hatching) also
/// need every block their surface passes within inkReachMm of (SampleFrame::inkReachMm):
/// a line is found at a minimum of d along the ray, from three consecutive samples.
/// A block whose slot field is constant at |d| > inkLineMm (SampleFrame) needs no ink.
/// Returns 0 (empty), 255 (march every step) or 128 (homogeneous: markHomogeneousBlocks).
std::vector<uint8_t> blockOccupancy(const BlockFields& b, const StyleTable& t, const std::vector<PaintSlot>& slots,
                                    float coverageH, float inkReachMm = 0, float inkLineMm = 0);

/// Marks occupied blocks (255) homogeneous (128) where every sample has the same styled colour
/// and opacity (but for depth dimming): each slot's distance is constant over the dilated
/// block (the narrow band's clamp) or beyond its skipBands. The shader evaluates one sample
/// there and composites it over the block's length (adaptive step at block scale).
void markHomogeneousBlocks(const BlockFields& b, const StyleTable& t, const std::vector<PaintSlot>& slots,
                           float coverageH, std::vector<uint8_t>& occ);

/// The occupancy texture: 255 mixed, 254 homogeneous, and for an empty block the Chebyshev
/// distance n (1..kEmptyRunCap) in blocks to the nearest non-empty one: every block within
/// n - 1 of it is empty too, so the ray leaves that whole cube in one step.
constexpr int kEmptyRunCap = 64;
std::vector<uint8_t> occupancyTexels(const std::vector<uint8_t>& occ, const Dims& blocks);

/// Ink of a silhouette/contour line (CPU reference of inkLine() in the shader): a, b, c are a
/// segment's distances at three consecutive samples with b a local minimum; the parabola
/// through them gives the ray's closest approach m to the surface (for a ray that grazes a
/// surface, the image-plane distance to its silhouette). Coverage of the pixel by a line
/// widthPx wide centred on m = 0, pixMm the pixel size at that depth.
float inkLine(float a, float b, float c, float widthPx, float pixMm);
/// Silhouette ink kept for features at least a voxel round: at the line's vertex (distance m)
/// the distance one voxel (voxelMm) before and after it along the ray, dm and dp, curve as
/// 1/radius (d = m + t^2 / 2r); ink fades out from radius 2 voxels to 1: voxel-noise bumps on
/// rough bone get no outlines of their own (the knots of ink, issue 21). Centred on the vertex,
/// not on the samples, so it does not vary with where a ray's samples fell. Rows with a fill
/// only (an outline-only row's outline is its whole figure).
float inkFeatureFade(float dm, float m, float dp, float voxelMm);
/// The vertex (in steps from b, clamped to [-1, 1]) of the parabola through (-1, a), (0, b), (1, c).
float inkVertex(float a, float b, float c);
/// Hatching coverage for light n.l, in object space (a movie's strokes stay on the surface):
/// layer l's strokes are the surface's cuts by planes across hatchAxis[l], spacingPx apart at
/// the scene centre's pixel size; u[l] = the sample's position along the axis in those pixels
/// (hatchCoordinates). Strokes where n.l < 0.6, crossing ones where n.l < 0.25, a third layer
/// where n.l < -0.2, each widening from 0 to widthPx as n.l falls by 0.25, times fade[l].
float inkHatch(float ndl, const float* u, const float* fade, float spacingPx, float widthPx);
struct SampleFrame;
/// Crease probe half-span in voxels (of the grid's mean size): SampleFrame::creaseProbeMm.
constexpr double kCreaseProbeVoxels = 3.0;
/// Crease ink (CPU reference of creaseInk() in the shader) at the surface point q (continuous
/// index) of `slot`, from the slot's normals (central differences) along the screen's right, up
/// and two diagonals (a: index offsets per mm) at q +- h a and q +- R a, h = (widthPx / 2 + 1/2)
/// pixMm, R = max(h, probeMm): the largest creaseProfile of the four directions.
float creaseInk(const FieldVolume& f, int slot, Vec3f q, Vec3f rightIdx, Vec3f upIdx, const std::array<float, 9>& gradToPhys,
                float widthPx, float angleDeg, float pixMm, float probeMm);
/// One direction's crease ink from the unit normals at -R, -h, +h, +R (mm): the turn between
/// -R and +R mapped from c0 = cos(angle) (none) to c1 = cos(angle + 15) (full), times how much
/// of it is concentrated within +-h (a rounded part turning evenly gets none), times the
/// coverage of a widthPx line around where the turn is centred.
float creaseProfile(Vec3f nm, Vec3f nh, Vec3f ph, Vec3f np, float R, float h, float c0, float c1, float widthPx,
                    float pixMm);
/// u and fade of inkHatch at a sample (physical position pMm, unit normal n).
void hatchCoordinates(const SampleFrame& f, Vec3f pMm, Vec3f n, float* u, float* fade);
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
  /// Size of a pixel in mm at ray parameter t: pixMm0 + pixMm1 * t (orthographic: constant;
  /// perspective: growing with the distance from the eye). Ink widths are in pixels.
  float pixMm0 = 1, pixMm1 = 0;
  float inkReachMm = 0;  ///< distance from a surface within which ink samples matter (occupancy)
  float inkPassMm = 0;   ///< widest "pass near a surface" of the ink rows (farthest depth): skipBands
  float inkLineMm = 0;   ///< farthest a sampled minimum can still lay line ink (half line + a pixel + half a step)
  /// Hatching (object space): stroke-plane normals in physical space (superior-inferior, then
  /// the two diagonals across it) and the pixel size at the scene centre (stroke spacing).
  Vec3f hatchAxis[3];
  float hatchPixMm = 1;
  /// Half the span over which creases measure the normal's turn (mm): a few voxels, since CT
  /// rounds an edge over two or three (creaseInk).
  float creaseProbeMm = 0;
  std::array<float, 9> gradToPhys{};  ///< index-space gradient -> physical (D * diag(1/spacing)), row-major
};

/// Styled RGBA (premultiplied, alpha per mm before the step correction) of one row at a
/// sample. g4 = (grad d, d) of the row's own surface, ct4 = (grad CT, CT) or null, view = unit
/// vector to the eye. (Coverage is the caller's membership weight: shadeSample.)
std::array<float, 4> styledSample(const StyleTable& t, int label, const float* g4, const float* ct4,
                                  const TextureVolume* texVol, Vec3f pMm, float depth, Vec3f view,
                                  const SampleFrame& f);

/// The sample's RGBA: a soft painter's order over the slots, last slot first. PaintSlot s covers
/// c_s = clamp(0.5 - d_s / h, 0, 1) of the sample; its weight is c_s times what later slots
/// left uncovered, and it is styled with its OWN distance and gradient (a bone inside an
/// invisible skin looks as the bone alone). A shell splits its slot at d = -shellMm; label 0
/// takes what is left, with the nearest surface's distance. d: mm; gradPhys: physical.
std::array<float, 4> shadeSample(const StyleTable& t, const std::vector<PaintSlot>& slots, const float* d,
                                 const Vec3f* gradPhys, const float* ct4, const TextureVolume* texVol, Vec3f pMm,
                                 float depth, Vec3f view, const SampleFrame& f);

}  // namespace vellum::illustration::detail

namespace vellum::render::detail {
struct Frame;
}
namespace vellum::illustration::detail {
/// Bounding sphere (depth), light in physical space, coverage width, step.
SampleFrame makeSampleFrame(const Geometry& g, const render::detail::Frame& f, const StyleTable& t);
}  // namespace vellum::illustration::detail
