// Marker-based watershed on the depth below the mask's surface (split.hpp).
#include "vellum/segmentation/split.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <queue>

#include "vellum/core/components.hpp"
#include "vellum/core/cropped_geometry.hpp"
#include "vellum/core/distance_transform.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/parallel.hpp"
#include "vellum/segmentation/components.hpp"
#include "vellum/segmentation/morphology.hpp"

namespace vellum::segmentation {

const params::Table<SplitParams>& splitParamsTable() {
  using S = SplitParams;
  static const params::Table<S> table{
      params::real<S>("neck", &S::neckMm,
                      {"Split neck", "contacts narrower than about twice this are cut (0 = split only unconnected pieces)",
                       "mm", 0, 50}),
      params::real<S>("min_volume", &S::minVolumeMm3,
                      {"Split minimum volume", "smaller objects merge into their largest-contact neighbour or are dropped",
                       "mm^3", 0, 1e12}),
      params::real<S>("joint_contrast", &S::jointContrastHu,
                      {"Split joint contrast",
                       "joint cut: voxels this much darker than bone on both sides within the joint width (a joint "
                       "space between two subchondral plates) separate the markers and are flooded last (0 = off)",
                       "HU", 0, 5000}),
      params::real<S>("joint_width", &S::jointWidthMm,
                      {"Split joint width", "joint cut: how far each side the bright bone is looked for", "mm", 0.1, 20}),
      params::real<S>("joint_share", &S::jointShare,
                      {"Split joint share",
                       "joint cut: neighbouring objects whose contact lies less than this share in joint space "
                       "(a neck inside one bone) merge (0 = never)", "", 0, 1}),
      params::flag<S>("open_joints", &S::openJoints,
                      {"Split open joints", "joint cut: the joint spaces' voxels stay background, a gap between two "
                                            "bones (with --split-fill those inside one bone come back)", ""}),
      params::flag<S>("fill", &S::fillObjects,
                      {"Split fill", "after the split, fill each object's cavities (enclosed in a slice of the object "
                                     "alone, or in 3D) with its id, on background only: a bone's low-density inside", ""}),
      params::real<S>("thin", &S::thinMm,
                      {"Split thin", "before the split, remove tubes thinner than about twice this that stand apart from "
                                     "thick parts (a mounting wire or positioning cord on the skin, which would join the "
                                     "bones it touches); a bone's edges and thin cortical walls stay (0 = off)", "mm", 0, 20}),
  };
  return table;
}

namespace {

/// The 26 neighbour offsets of a voxel (as index steps) and their (di, dj, dk).
struct Neighbours {
  std::array<std::array<int, 3>, 26> steps{};
  Neighbours() {
    int n = 0;
    for (int dk = -1; dk <= 1; ++dk)
      for (int dj = -1; dj <= 1; ++dj)
        for (int di = -1; di <= 1; ++di)
          if (di || dj || dk) steps[n++] = {di, dj, dk};
  }
};

/// Calls f(neighbour linear index) for each in-grid 26-neighbour of voxel (i, j, k).
template <class F>
void forNeighbours(const Dims& d, int64_t i, int64_t j, int64_t k, F&& f) {
  static const Neighbours nb;
  for (const auto& s : nb.steps) {
    const int64_t a = i + s[0], b = j + s[1], c = k + s[2];
    if (a < 0 || b < 0 || c < 0 || a >= d.x || b >= d.y || c >= d.z) continue;
    f((c * d.y + b) * d.x + a);
  }
}

/// Markers: one id per seed voxel, or per 26-connected piece deeper than neckMm.
int placeMarkers(const Mask& mask, const VolumeF32& depth2, const SplitParams& p, std::vector<uint16_t>& ids) {
  const Geometry& g = mask.geometry();
  if (!p.seedsMm.empty()) {
    if (p.seedsMm.size() > 65535) throw Error("split: at most 65535 seeds");
    uint16_t next = 0;
    for (const Index3& v : seedsToVoxels(g, p.seedsMm)) {
      const size_t n = static_cast<size_t>((v.k * g.dims.y + v.j) * g.dims.x + v.i);
      const Vec3& s = p.seedsMm[next];
      if (!mask.data()[n])
        throw Error("split: seed (" + std::to_string(s.x) + ", " + std::to_string(s.y) + ", " + std::to_string(s.z) +
                    ") mm is not on the mask");
      ids[n] = ++next;  // two seeds in one voxel: the later one wins, the earlier id stays empty
    }
    return next;
  }
  const float neck2 = static_cast<float>(p.neckMm * p.neckMm);
  Mask core = makeMask(g);
  for (size_t n = 0; n < core.size(); ++n) core.data()[n] = mask.data()[n] && depth2.data()[n] > neck2;
  const Components c = connectedComponents(core, Connectivity::Vertex26);
  if (c.count() > 65535) throw Error("split: more than 65535 markers; raise the neck");
  for (size_t n = 0; n < ids.size(); ++n) ids[n] = static_cast<uint16_t>(c.labels[n]);
  return static_cast<int>(c.count());
}

/// Priority flood from the markers over the mask, deepest voxels first: a voxel takes the label
/// of the voxel that reached it first (FIFO among equal depth, so fronts meet halfway and the
/// result depends on nothing but the input).
void flood(const Mask& mask, const VolumeF32& depth2, std::vector<uint16_t>& ids, Progress& progress) {
  const Dims d = mask.dims();
  struct Item {
    float depth2;
    uint64_t order;
    uint32_t index;
    bool operator<(const Item& o) const { return depth2 != o.depth2 ? depth2 < o.depth2 : order > o.order; }
  };
  std::priority_queue<Item> queue;
  uint64_t order = 0;
  std::vector<uint16_t> reachedBy(ids.size(), 0);  // the label a queued voxel will take
  auto pushNeighbours = [&](size_t n) {
    const int64_t i = static_cast<int64_t>(n % d.x), j = static_cast<int64_t>((n / d.x) % d.y),
                  k = static_cast<int64_t>(n / (d.x * d.y));
    forNeighbours(d, i, j, k, [&](int64_t m) {
      if (!mask.data()[m] || ids[m] || reachedBy[m]) return;
      reachedBy[m] = ids[n];
      queue.push({depth2.data()[m], order++, static_cast<uint32_t>(m)});
    });
  };
  for (size_t n = 0; n < ids.size(); ++n)
    if (ids[n]) pushNeighbours(n);
  int64_t done = 0;
  while (!queue.empty()) {
    const size_t n = queue.top().index;
    queue.pop();
    ids[n] = reachedBy[n];
    pushNeighbours(n);
    if ((++done & 0xFFFF) == 0) progress.advance();
  }
}

}  // namespace

Mask jointSpaces(const VolumeI16& ct, const Mask& mask, double contrastHu, double widthMm) {
  requireSameGeometry(ct.geometry(), mask.geometry(), "joint cut: the CT and the mask");
  const Geometry& g = mask.geometry();
  const Dims d = g.dims;
  // Half of the 26 directions (the other half is the same line), each with how many steps
  // along it stay within widthMm (at least one).
  struct Line { int64_t di, dj, dk; int reach; };
  std::vector<Line> lines;
  for (int dk = -1; dk <= 1; ++dk)
    for (int dj = -1; dj <= 1; ++dj)
      for (int di = -1; di <= 1; ++di) {
        if (!(dk > 0 || (dk == 0 && dj > 0) || (dk == 0 && dj == 0 && di > 0))) continue;
        const double step = norm(Vec3{di * g.spacing.x, dj * g.spacing.y, dk * g.spacing.z});
        lines.push_back({di, dj, dk, std::max(1, static_cast<int>(std::floor(widthMm / step + 1e-9)))});
      }
  const int contrast = static_cast<int>(std::ceil(contrastHu));
  Mask out = makeMask(g);
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < d.y; ++j)
        for (int64_t i = 0; i < d.x; ++i) {
          if (!mask(i, j, k)) continue;
          const int v = ct(i, j, k);
          for (const Line& l : lines) {
            // The brightest voxel within reach on each side; the grid's edge ends a side.
            int sideA = -32768, sideB = -32768;
            for (int r = 1; r <= l.reach; ++r) {
              const int64_t a = i - r * l.di, b = j - r * l.dj, c = k - r * l.dk;
              if (a < 0 || b < 0 || c < 0 || a >= d.x || b >= d.y || c >= d.z) break;
              sideA = std::max(sideA, int(ct(a, b, c)));
            }
            if (sideA - v < contrast) continue;
            for (int r = 1; r <= l.reach; ++r) {
              const int64_t a = i + r * l.di, b = j + r * l.dj, c = k + r * l.dk;
              if (a < 0 || b < 0 || c < 0 || a >= d.x || b >= d.y || c >= d.z) break;
              sideB = std::max(sideB, int(ct(a, b, c)));
            }
            if (sideB - v >= contrast) { out(i, j, k) = 1; break; }
          }
        }
  });
  // A joint space is a sheet at least as wide as the distance looked across; smaller specks
  // are the texture of cancellous bone (fat between trabeculae), which would cut bones apart.
  removeSmallIslandsInPlace(out, M_PI * widthMm * widthMm);
  return out;
}

std::vector<int64_t> fillObjectHoles(VolumeU16& objects) {
  const Dims d = objects.dims();
  const int ids = 1 + *std::max_element(objects.voxels().begin(), objects.voxels().end());
  struct Box { int64_t lo[3]{INT64_MAX, INT64_MAX, INT64_MAX}, hi[3]{-1, -1, -1}; int64_t voxels = 0; };
  std::vector<Box> box(ids);
  for (int64_t k = 0; k < d.z; ++k)
    for (int64_t j = 0; j < d.y; ++j)
      for (int64_t i = 0; i < d.x; ++i) {
        const uint16_t o = objects(i, j, k);
        if (!o) continue;
        Box& b = box[o];
        const int64_t at[3] = {i, j, k};
        for (int a = 0; a < 3; ++a) { b.lo[a] = std::min(b.lo[a], at[a]); b.hi[a] = std::max(b.hi[a], at[a]); }
        ++b.voxels;
      }
  std::vector<int> order;
  for (int o = 1; o < ids; ++o)
    if (box[o].voxels) order.push_back(o);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return box[a].voxels > box[b].voxels; });
  std::vector<int64_t> added(ids, 0);
  for (int o : order) {
    // The object alone on its box grown by one voxel, so that the box's rim is outside.
    const Box& b = box[o];
    int64_t lo[3], n[3];
    const int64_t dim[3] = {d.x, d.y, d.z};
    VoxelBox grown;
    for (int a = 0; a < 3; ++a) {
      lo[a] = grown.lo[size_t(a)] = std::max<int64_t>(0, b.lo[a] - 1);
      grown.hi[size_t(a)] = std::min<int64_t>(dim[a] - 1, b.hi[a] + 1);
      n[a] = grown.hi[size_t(a)] - lo[a] + 1;
    }
    Mask alone = makeMask(croppedGeometry(objects.geometry(), grown));
    for (int64_t k = 0; k < n[2]; ++k)
      for (int64_t j = 0; j < n[1]; ++j)
        for (int64_t i = 0; i < n[0]; ++i) alone(i, j, k) = objects(lo[0] + i, lo[1] + j, lo[2] + k) == o;
    const Mask filled = fillHolesAllSlices(alone);
    for (int64_t k = 0; k < n[2]; ++k)
      for (int64_t j = 0; j < n[1]; ++j)
        for (int64_t i = 0; i < n[0]; ++i) {
          uint16_t& v = objects(lo[0] + i, lo[1] + j, lo[2] + k);
          if (filled(i, j, k) && !v) { v = static_cast<uint16_t>(o); ++added[o]; }
        }
  }
  return added;
}

SplitResult splitObjects(const Mask& input, const SplitParams& p, Progress& progress, const VolumeI16* ct) {
  params::validate(splitParamsTable(), p);
  // Thin parts first (a wire on the skin): everything below splits the mask without them.
  const Mask thinned = p.thinMm > 0 ? removeThin(input, p.thinMm, progress) : Mask{};
  const Mask& mask = p.thinMm > 0 ? thinned : input;
  const Geometry& g = mask.geometry();
  const Dims d = g.dims;
  if (static_cast<uint64_t>(mask.size()) > 0xFFFFFFFFull) throw Error("split: more than 2^32 voxels");
  // The depth below the surface; with the joint cut the joint spaces count as surface too
  // (depth 0: no marker crosses them, and the flood reaches them last).
  VolumeF32 depth2;
  int64_t jointVoxels = 0;
  Mask joint;
  if (p.jointContrastHu > 0) {
    if (!ct) throw Error("split: the joint cut (joint contrast) needs the CT");
    joint = jointSpaces(*ct, mask, p.jointContrastHu, p.jointWidthMm);
    jointVoxels = countVoxels(joint);
    Mask core = makeMask(g);
    for (size_t n = 0; n < core.size(); ++n) core.data()[n] = mask.data()[n] && !joint.data()[n];
    depth2 = squaredDistanceMm(maskNot(core), progress);
  } else {
    depth2 = squaredDistanceMm(maskNot(mask), progress);  // 0 on background
  }
  std::vector<uint16_t> ids(mask.size(), 0);
  const int markers = placeMarkers(mask, depth2, p, ids);
  progress.begin("Splitting objects", static_cast<uint64_t>(countVoxels(mask)) / 65536 + 1);
  flood(mask, depth2, ids, progress);

  // Mask pieces no marker reached (thinner than the neck everywhere): objects of their own,
  // unless seeds chose the objects.
  const double voxelMm3 = voxelVolumeMm3(g);
  int count = markers;
  int64_t unreachedVoxels = 0;
  {
    Mask unreached = makeMask(g);
    for (size_t n = 0; n < ids.size(); ++n) {
      unreached.data()[n] = mask.data()[n] && !ids[n];
      unreachedVoxels += unreached.data()[n];
    }
    if (unreachedVoxels > 0 && p.seedsMm.empty()) {
      const Components c = connectedComponents(unreached, Connectivity::Vertex26);
      if (count + c.count() > 65535) throw Error("split: more than 65535 objects; raise the neck");
      for (size_t n = 0; n < ids.size(); ++n)
        if (c.labels[n]) ids[n] = static_cast<uint16_t>(count + c.labels[n]);
      count += static_cast<int>(c.count());
    }
  }
  std::vector<double> volume(count + 1, 0.0);
  for (uint16_t id : ids) volume[id] += voxelMm3;

  // Contacts between objects (26 neighbours, each pair counted from both sides alike).
  // With the joint cut, also the pairs next to the joint space: its sheet is one voxel thin in
  // places, and two voxels 26-adjacent across an oblique sheet meet in the joint too.
  const Mask jointNear = joint.empty() ? Mask{} : dilate(joint, norm(g.spacing));
  std::map<std::pair<uint16_t, uint16_t>, int64_t> contact, contactInJoint;
  for (int64_t k = 0; k < d.z; ++k)
    for (int64_t j = 0; j < d.y; ++j)
      for (int64_t i = 0; i < d.x; ++i) {
        const int64_t n = (k * d.y + j) * d.x + i;
        const uint16_t a = ids[n];
        if (!a) continue;
        const bool inJoint = !jointNear.empty() && jointNear.data()[n];
        forNeighbours(d, i, j, k, [&](int64_t m) {
          const uint16_t b = ids[m];
          if (!b || b == a) return;
          ++contact[{a, b}];
          if (inJoint || (!jointNear.empty() && jointNear.data()[m])) ++contactInJoint[{a, b}];
        });
      }
  SplitResult out;
  out.jointVoxels = jointVoxels;
  if (p.thinMm > 0) out.thinRemovedMm3 = double(countVoxels(input) - countVoxels(mask)) * voxelMm3;
  std::vector<uint16_t> parent(count + 1);
  std::iota(parent.begin(), parent.end(), uint16_t{0});
  auto root = [&](uint16_t a) {
    while (parent[a] != a) a = parent[a];
    return a;
  };
  // With the joint cut, neighbours that meet mostly outside the joint spaces were cut apart by
  // a neck inside one bone (or by a gap in the joint sheet): one bone, one object.
  if (!joint.empty() && p.jointShare > 0) {
    // Least joint-like contacts first (ties: lower ids first), so a clear neck merges before a doubtful one.
    std::vector<std::pair<double, std::pair<uint16_t, uint16_t>>> byShare;
    for (const auto& [pair, n] : contact) {
      if (pair.first > pair.second) continue;  // each pair once
      const auto inJoint = contactInJoint.find(pair);
      byShare.push_back({double(inJoint == contactInJoint.end() ? 0 : inJoint->second) / double(n), pair});
    }
    std::stable_sort(byShare.begin(), byShare.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
    for (const auto& [share, pair] : byShare) {
      if (share >= p.jointShare) break;
      const uint16_t a = root(pair.first), b = root(pair.second);
      if (a == b) continue;
      const uint16_t keep = volume[a] >= volume[b] ? a : b, gone = keep == a ? b : a;
      parent[gone] = keep;
      volume[keep] += volume[gone];
      volume[gone] = 0;
      ++out.jointMerges;
    }
  }
  // Small objects, smallest first, join the neighbour they touch most (or are dropped).
  std::vector<uint16_t> order(count);
  std::iota(order.begin(), order.end(), uint16_t{1});
  std::stable_sort(order.begin(), order.end(), [&](uint16_t a, uint16_t b) { return volume[a] < volume[b]; });
  double dropped = 0;
  for (uint16_t a : order) {
    if (root(a) != a || volume[a] >= p.minVolumeMm3) continue;
    std::map<uint16_t, int64_t> touching;
    for (const auto& [pair, n] : contact) {
      if (root(pair.first) != a) continue;
      const uint16_t b = root(pair.second);
      if (b != a) touching[b] += n;
    }
    uint16_t target = 0;
    int64_t most = 0;
    for (const auto& [b, n] : touching)
      if (n > most) { most = n; target = b; }
    if (target) {
      parent[a] = target;
      volume[target] += volume[a];
    } else {
      parent[a] = 0;  // dropped
      dropped += volume[a];
    }
    volume[a] = 0;
  }
  if (!p.seedsMm.empty()) dropped += double(unreachedVoxels) * voxelMm3;  // unseeded pieces
  // Open joints: the joint spaces go back to background, a gap between two bones (the sheet's
  // pieces inside one bone come back with the fill below, being enclosed by that bone alone).
  if (p.openJoints && !joint.empty()) {
    for (size_t n = 0; n < ids.size(); ++n) {
      if (!joint.data()[n] || !ids[n]) continue;
      const uint16_t r = root(ids[n]);
      if (r) {
        volume[r] -= voxelMm3;
        out.openedMm3 += voxelMm3;
      }
      ids[n] = 0;
    }
  }
  // Each object's cavities join it (on background only), before the numbering by volume.
  if (p.fillObjects) {
    VolumeU16 merged(g, 0, 0.0);
    uint16_t* m = merged.data();
    for (size_t n = 0; n < ids.size(); ++n) m[n] = ids[n] ? root(ids[n]) : 0;
    const std::vector<int64_t> added = fillObjectHoles(merged);
    for (size_t a = 1; a < added.size(); ++a) {
      volume[a] += double(added[a]) * voxelMm3;
      out.filledMm3 += double(added[a]) * voxelMm3;
    }
    for (size_t n = 0; n < ids.size(); ++n) ids[n] = m[n];  // roots are their own parents
  }
  // Renumber the surviving roots by volume, largest first (ties: lower old id first).
  std::vector<uint16_t> roots;
  for (uint16_t a = 1; a <= count; ++a)
    if (root(a) == a && volume[a] > 0.5 * voxelMm3) roots.push_back(a);  // (an object all joint space is gone)
  std::stable_sort(roots.begin(), roots.end(), [&](uint16_t a, uint16_t b) { return volume[a] > volume[b]; });
  std::vector<uint16_t> newId(count + 1, 0);
  out.volumesMm3.push_back(0.0);
  for (size_t r = 0; r < roots.size(); ++r) {
    newId[roots[r]] = static_cast<uint16_t>(r + 1);
    out.volumesMm3.push_back(volume[roots[r]]);
  }
  out.objects = VolumeU16(g, 0, 0.0);
  uint16_t* o = out.objects.data();
  for (size_t n = 0; n < ids.size(); ++n) o[n] = ids[n] ? newId[root(ids[n])] : 0;
  out.droppedMm3 = dropped;
  out.markers = markers;
  progress.end();
  return out;
}

}  // namespace vellum::segmentation
