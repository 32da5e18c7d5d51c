#pragma once
// The backward map u(v) ([HVD 1.4] in docs/references.md), one model for everything that makes
// or samples it: deformation::ControlVolume is one (plus its coarsening factor); CPU synthesis,
// deformation::MapSampler, the GL ray caster, the CPU reference renderer and the studio's
// slices sample it. u is known on a node grid over OUTPUT space; between nodes a kernel
// (Upsampling) interpolates it; then the rigid snap (RigidSnap) makes the voxels inside a bone
// follow that bone exactly. The ray caster's GLSL constants for the kernel and the snap are
// generated from this file (render: shader_source.cpp), so the GLSL names nothing by number.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "vellum/core/enum_table.hpp"
#include "vellum/core/geometry.hpp"

namespace vellum {

/// How u is interpolated between nodes (the value is the kernel's id in the GLSL).
enum class Upsampling {
  Trilinear = 0,  ///< default: fast, exact for affine maps
  Gaussian = 1,   ///< separable 4-tap Gaussian (sigma 0.6 node), corrected to reproduce linear maps
};
const params::EnumTable<Upsampling>& upsamplings();  ///< "trilinear", "gaussian"
inline const char* upsamplingName(Upsampling u) { return upsamplings().name(u); }
inline Upsampling parseUpsampling(const std::string& name) { return upsamplings().parse(name); }

/// Standard deviation of the Gaussian kernel, in node spacings.
constexpr double kGaussianUpsamplingSigma = 0.6;

/// The Gaussian kernel: a sample at fraction f in [0, 1) between node n0 and n0 + 1 reads nodes
/// n0 - 1 .. n0 + 2 with these normalised weights, Gaussian weights adjusted so that the first
/// moment about f is zero (a linear map is reproduced exactly). All positive.
inline std::array<double, 4> gaussianUpsamplingWeights(double f) {
  std::array<double, 4> w{};
  double m1 = 0, m2 = 0;
  for (int q = 0; q < 4; ++q) {
    const double x = (q - 1) - f;
    w[q] = std::exp(-0.5 * x * x / (kGaussianUpsamplingSigma * kGaussianUpsamplingSigma));
    m1 += w[q] * x;
    m2 += w[q] * x * x;
  }
  const double beta = -m1 / m2;  // w_q *= 1 + beta x_q: zero first moment about f
  double total = 0;
  for (int q = 0; q < 4; ++q) {
    w[q] *= 1.0 + beta * ((q - 1) - f);
    total += w[q];
  }
  for (double& v : w) v /= total;
  return w;
}

/// Node m of an axis of n nodes as up to two real nodes: u(m) = w0 u(i0) + w1 u(i1). Beyond the
/// grid (the Gaussian kernel's outer taps) u is extrapolated linearly from the two edge nodes,
/// u(e + m) = u(e) + m (u(e) - u(e -+ 1)), which keeps affine maps exact at the borders.
struct NodeTap {
  int64_t i0 = 0, i1 = 0;
  double w0 = 1, w1 = 0;
};
inline NodeTap extendedNode(int64_t m, int64_t n) {
  if (n < 2 || (m >= 0 && m < n)) return {std::clamp<int64_t>(m, 0, n - 1), 0, 1, 0};
  if (m < 0) return {0, 1, double(1 - m), double(m)};
  const int64_t e = n - 1;
  return {e, e - 1, double(1 + (m - e)), double(-(m - e))};
}

/// The kernel's taps along one axis at position o, in units where the nodes lie every s (output
/// voxel index for synthesis and MapSampler; s = 1: node index), 0 <= o <= (nodes - 1) s, not
/// necessarily whole: nodes idx[t] with weights w[t]. Gaussian taps beyond the grid are folded
/// onto the edge nodes (extendedNode).
void linearTap(double o, int64_t nodes, int s, std::array<int32_t, 2>& idx, std::array<float, 2>& w);
void gaussianTap(double o, int64_t nodes, int s, std::array<int32_t, 4>& idx, std::array<float, 4>& w);

/// u at position o (per axis as for the taps) of `nodes` (3 floats per node of `nd`, x fastest,
/// in any frame): the separable sum in synthesis' order (z-blended nodes, then y, then x), in
/// float. The one CPU evaluation of the kernel at a point (MapSampler, the CPU reference
/// renderer); synthesis runs the same taps over whole rows.
Vec3 interpolateNodes(const float* nodes, const Dims& nd, Upsampling kernel, int s, const Vec3& o);

/// Voxel-level snap of rigid bodies (set by deformation::applyRigidity): interpolating a blended
/// node map is not rigid inside a bone whose node cells also touch soft tissue or another bone
/// (a cell wider than the joint gap holds nodes of both bones). So after interpolation, an
/// output position v whose source position u lands in the class voxel of rigid body c takes
/// that body's rigid transform exactly, u = R_c v + t_c, when that moves u by at most
/// `maxSnapMm` (it corrects interpolation, never a far excursion into bone).
struct RigidSnap {
  /// Source-space classes (0 air, 1 soft tissue, 2 + c body c) on `classGrid`.
  std::shared_ptr<const std::vector<uint16_t>> classes;
  Geometry classGrid;
  /// Per body: R row-major (9) then t (3), mm; `valid[c]` 0 = body left to the map.
  std::vector<std::array<double, 12>> fits;
  std::vector<uint8_t> valid;
  double maxSnapMm = 0;
  /// Per body: axis-aligned box (output mm: min xyz, max xyz) holding every output position
  /// the snap can move to that body (SnapFrame::reach). Empty = everywhere.
  std::vector<std::array<double, 6>> reachMm;
  /// Per body (or empty: none): 1 = held in place, its fit the identity (deformation holds the
  /// fixed regions). An output position v in a held body's class voxels (its own place, since
  /// it does not move) takes u = v whatever the interpolated map says: an interpolated map cell
  /// that straddles a held region's face would otherwise drag its voxels by part of the jump
  /// beside it (a fixed box beside a turning foot: 9 mm in a movie frame).
  std::vector<uint8_t> held;
};

/// A twist map's own kernel between nodes (deformation::TwistFrames at scale > 1). A twist map
/// turns each point about each joint's axis by the joint's angle times a weight w (docs/
/// deformation.md, "Twist map"); interpolating the turned positions instead cuts the arcs'
/// chords, and where w steps steeply across a thin joint space a cell folds whose corners do
/// not (knee movie frames: 17-23 voxels). So this kernel interpolates w (trilinear) and turns
/// each sample by it: det J = prod_s (1 - angle_s dw_s/dalpha) as at the nodes. The map's
/// sourceMm keep the nodes' own positions (what reads nodes only: map files, cell bounds).
struct TwistKernel {
  static constexpr int kMaxStages = 4;  ///< at most one RGBA texel per node in the shader
  struct Stage {
    Vec3 pointMm{0, 0, 0};  ///< a point on the joint's axis
    Vec3 axis{1, 0, 0};     ///< unit direction; the backward map turns by -angleRad * w about it
    double angleRad = 0;
    /// The whole turn (w = 1) as a matrix: a limb's bulk turns wholly or not at all, so most
    /// samples need no sine (about() sets it).
    Mat3 whole = Mat3::identity();
    /// The stage turning by -angleRad * w about the unit `axis` through `pointMm`.
    static Stage about(const Vec3& pointMm, const Vec3& axis, double angleRad);
    /// x turned by this stage with weight w (by -angleRad * w about the axis; w = 0 and w = 1
    /// without a sine). The one twist turn: the kernel, the twist map's nodes and its checks.
    Vec3 turned(const Vec3& x, double w) const;
  };
  /// Appends a stage (applied after the ones before it: proximal first).
  void addStage(const Vec3& pointMm, const Vec3& axis, double angleRad);
  const std::vector<Stage>& stages() const { return stages_; }
  /// Floats per node in `weights`: one per stage.
  size_t stride() const { return stages_.size(); }
  /// stride() floats per node of the map's grid (x fastest): stage s's w at offset s.
  std::vector<float> weights;

  /// The source position (mm) of output position `vMm`: each stage turns the position as the
  /// stages before it left it, by -angle * w with w read trilinearly at that position's node
  /// index (`mmToNode`; clamped onto the `nodes`).
  Vec3 sourceMm(const Vec3& vMm, const Geometry::ToIndex& mmToNode, const Dims& nodes) const;
  /// sourceMm() at node `node` (its position `vMm`): the first stage reads the node's own w
  /// (no interpolation), the later ones as sourceMm().
  Vec3 sourceAtNode(int64_t node, const Vec3& vMm, const Geometry::ToIndex& mmToNode, const Dims& nodes) const;
  /// Stage s's weight at node index q (trilinear, q clamped onto the nodes).
  double weightAt(size_t s, const Vec3& q, const Dims& nodes) const;
  /// x turned by stage s with weight w (Stage::turned).
  Vec3 turn(size_t s, const Vec3& x, double w) const { return stages_[s].turned(x, w); }
  /// du/dv (mm per mm) of sourceMm() at `vMm`: per stage R (I - angle t grad(w)^T), t = axis x
  /// (x - point), grad(w) from central differences of the trilinear w `stepNodes` nodes either
  /// side (the shader's filtered fetches). What turns the shading normals (J^T n).
  Mat3 jacobian(const Vec3& vMm, const Geometry::ToIndex& mmToNode, const Dims& nodes, double stepNodes) const;
  /// How far (mm) a sample's source can lie outside the box of its cell's corner sources: the
  /// kernel's turned positions bulge off the corners' chords by at most this (a bound from the
  /// steepest cell of each stage's w; the renderers' empty-space cells widen by it).
  double chordBoundMm(const Geometry& grid) const;

 private:
  std::vector<Stage> stages_;  ///< applied in order (proximal first), at most kMaxStages
};

struct BackwardMap {
  /// Output-space grid of the nodes (mm geometry). The ray caster casts through this box.
  Geometry grid;
  /// grid.dims.voxelCount() * 3 floats, x fastest: for each node the SOURCE position u in mm.
  std::vector<float> sourceMm;
  /// Empty, or 4 floats per node: lightness offset (L*, -100..100), a offset, b offset (CIE
  /// L*a*b*), density scale (1 = unchanged).
  std::vector<float> attributes;
  Upsampling upsampling = Upsampling::Trilinear;
  /// Empty, or the snap applied after interpolating u.
  std::shared_ptr<const RigidSnap> rigidSnap;
  /// Empty, or the kernel between nodes (then `upsampling` is Trilinear): a twist map's.
  std::shared_ptr<const TwistKernel> twist;
  /// Empty, or the deformed volume's voxel grid (same direction as `grid`; a control volume's
  /// nodes reach up to s - 1/2 voxels beyond it): outside its voxel box the deformed volume is
  /// background.
  std::optional<Geometry> output;

  Vec3 sourceAt(int64_t node) const {
    const float* p = sourceMm.data() + 3 * node;
    return {p[0], p[1], p[2]};
  }
};

/// u = v on `grid`: 3 floats per node (mm), x fastest. Memory budget checked first.
std::vector<float> identityNodes(const Geometry& grid);

/// A RigidSnap in the frames of one sampler: u in coordinates whose mm are L u + o (source
/// index for synthesize() and the ray casters, mm for upsampleMap()), and points v as continuous
/// indices of a grid (output voxels for synthesis, map nodes for the ray casters). Floats, as
/// the GL path keeps them; borrows the class voxels (the RigidSnap must outlive it).
struct SnapFrame {
  const uint16_t* classes = nullptr;
  Dims classDims;
  std::array<float, 12> toClass{};  ///< class index = A u + b (A row-major, then b)
  std::array<float, 9> deltaToMm{};  ///< L: an offset of u -> mm
  /// Per body: u = M v + m (M row-major, then m): the body's rigid transform in these frames.
  std::vector<std::array<float, 12>> body;
  std::vector<uint8_t> valid;
  /// RigidSnap::held (valid bodies only), and the class index of point v's own place, A' v + b'
  /// (A' row-major, then b'), for the held test.
  std::vector<uint8_t> held;
  bool anyHeld = false;
  std::array<float, 12> pointToClass{};
  /// Point-index box {min xyz, max xyz} outside which no held body lies (the union of their
  /// reach boxes; everywhere without reach boxes; empty when no body is held): most samples
  /// skip the held test's lookup (the shader has only this test).
  std::array<float, 6> heldBox{-1e30f, -1e30f, -1e30f, 1e30f, 1e30f, 1e30f};
  float maxSnap2 = 0;  ///< mm^2
  /// Per body with a reach box (RigidSnap::reachMm): the point-index box {min i, j, k, max i,
  /// j, k} (inclusive) where the snap can move u to it; one box for everywhere without them.
  std::vector<std::array<int64_t, 6>> reach;

  /// The snap at point v of the interpolated u (both in this frame's coordinates), in Real
  /// arithmetic: u replaced and the body returned, or u unchanged and -1. A held body at v's
  /// own place comes first (heldAt()), then the body at u within maxSnap.
  template <class Real>
  int apply(const Real v[3], Real u[3]) const;
  /// The held body whose class voxel holds point v's own place, or -1.
  template <class Real>
  int heldAt(const Real v[3]) const;
  /// The class (2 + body, 1 tissue, 0 air; -1 outside the class grid) at class index A q + b.
  template <class Real>
  int classAt(const std::array<float, 12>& A, const Real q[3]) const;
  /// apply() along the whole points (0..n-1, j, k) of a row that some body can reach (u as
  /// three float arrays): synthesis skips the rest of the volume quickly.
  void applyRow(int64_t j, int64_t k, int64_t n, float* ux, float* uy, float* uz) const;
  /// True when applyRow() of v's row would visit v (continuous v: the same bounds).
  bool reaches(const Vec3& v) const;
};

/// `snap` for points of `pointGrid` and u with mm = uToMm u + uOriginMm. Throws vellum::Error for
/// a malformed snap (class voxels that do not match their grid, non-finite fits or distance,
/// singular geometry).
SnapFrame snapFrame(const RigidSnap& snap, const Geometry& pointGrid, const Mat3& uToMm, const Vec3& uOriginMm);

template <class Real>
int SnapFrame::classAt(const std::array<float, 12>& A, const Real q[3]) const {
  int64_t ci[3];
  for (int a = 0; a < 3; ++a) {
    const Real x = A[3 * a] * q[0] + A[3 * a + 1] * q[1] + A[3 * a + 2] * q[2] + A[9 + a];
    if (!(x > Real(-0.5))) return -1;
    ci[a] = static_cast<int64_t>(std::floor(x + Real(0.5)));
  }
  if (ci[0] >= classDims.x || ci[1] >= classDims.y || ci[2] >= classDims.z) return -1;
  return int(classes[(ci[2] * classDims.y + ci[1]) * classDims.x + ci[0]]);
}

template <class Real>
int SnapFrame::heldAt(const Real v[3]) const {
  if (!anyHeld) return -1;
  for (int a = 0; a < 3; ++a)
    if (!(v[a] >= Real(heldBox[a]) && v[a] <= Real(heldBox[a + 3]))) return -1;
  const int c = classAt(pointToClass, v) - 2;
  return c >= 0 && c < int(held.size()) && held[static_cast<size_t>(c)] ? c : -1;
}

template <class Real>
int SnapFrame::apply(const Real v[3], Real u[3]) const {
  const int heldBody = heldAt(v);
  const int c = heldBody >= 0 ? heldBody : classAt(toClass, u) - 2;
  if (c < 0 || c >= int(body.size()) || !valid[static_cast<size_t>(c)]) return -1;
  const auto& m = body[static_cast<size_t>(c)];
  Real s[3], d2 = 0;
  for (int a = 0; a < 3; ++a) s[a] = m[3 * a] * v[0] + m[3 * a + 1] * v[1] + m[3 * a + 2] * v[2] + m[9 + a];
  for (int a = 0; a < 3 && heldBody < 0; ++a) {
    const Real e = deltaToMm[3 * a] * (s[0] - u[0]) + deltaToMm[3 * a + 1] * (s[1] - u[1]) +
                   deltaToMm[3 * a + 2] * (s[2] - u[2]);
    d2 += e * e;
  }
  if (!(d2 <= maxSnap2)) return -1;
  std::copy_n(s, 3, u);
  return c;
}

}  // namespace vellum
