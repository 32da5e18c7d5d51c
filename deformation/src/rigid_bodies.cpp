// Rigid bodies from labels (one body per id or group of ids, whatever its connectivity; cores
// join their shell; fixed regions) or from a HU threshold (26-connected components): the
// classes that applyRigidity() and the measures read (rigidity.cpp).
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <mutex>
#include <string>
#include <variant>

#include "vellum/core/components.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/index_frame.hpp"
#include "vellum/core/parallel.hpp"
#include "vellum/deformation/rigidity.hpp"

namespace vellum::deformation {
namespace {

Mat3 mmToIndexOf(const Geometry& g) {
  Mat3 inv;
  if (!indexToMm(g).inverse(inv)) throw Error("rigidity: singular geometry");
  return inv;
}

}  // namespace

void RigidBodies::finish(VolumeU16 classes) {
  // Per body: voxel count and index box (one parallel scan of the classes).
  const size_t nb = bodies_.size();
  const Dims d = classes.dims();
  std::vector<std::array<int64_t, 6>> boxes(nb, {INT64_MAX, INT64_MAX, INT64_MAX, -1, -1, -1});
  std::vector<int64_t> voxels(nb, 0);
  std::mutex mutex;
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    std::vector<std::array<int64_t, 6>> lb(nb, {INT64_MAX, INT64_MAX, INT64_MAX, -1, -1, -1});
    std::vector<int64_t> lv(nb, 0);
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < d.y; ++j)
        for (int64_t i = 0; i < d.x; ++i) {
          const uint16_t c = classes(i, j, k);
          if (c < 2) continue;
          auto& b = lb[c - 2u];
          const int64_t p[3] = {i, j, k};
          for (int a = 0; a < 3; ++a) {
            b[static_cast<size_t>(a)] = std::min(b[static_cast<size_t>(a)], p[a]);
            b[static_cast<size_t>(a + 3)] = std::max(b[static_cast<size_t>(a + 3)], p[a]);
          }
          ++lv[c - 2u];
        }
    std::lock_guard lock(mutex);
    for (size_t c = 0; c < nb; ++c) {
      for (int a = 0; a < 3; ++a) {
        boxes[c][static_cast<size_t>(a)] = std::min(boxes[c][static_cast<size_t>(a)], lb[c][static_cast<size_t>(a)]);
        boxes[c][static_cast<size_t>(a + 3)] = std::max(boxes[c][static_cast<size_t>(a + 3)], lb[c][static_cast<size_t>(a + 3)]);
      }
      voxels[c] += lv[c];
    }
  });
  for (size_t c = 0; c < nb; ++c) {
    if (voxels[c] == 0) boxes[c] = {0, 0, 0, -1, -1, -1};
    bodies_[c].voxels = voxels[c];
  }
  boxes_ = std::move(boxes);
  mmToIndex_ = mmToIndexOf(classes.geometry());
  classes_ = std::make_shared<const VolumeU16>(std::move(classes));
}

RigidBodies RigidBodies::fromMask(VolumeU16 classes, int64_t minVoxels) {
  // classes: 0 air, 1 soft, 2 rigid (not yet split). 26-connected: a thin cortex shell
  // touching only along edges/corners stays one body.
  RigidBodies rb;
  VolumeU8 rigid(classes.geometry(), 0, 0);
  for (size_t t = 0; t < rigid.size(); ++t) rigid.data()[t] = classes.data()[t] == 2;
  const Components parts = connectedComponents(rigid, Connectivity::Vertex26);
  // Small components become soft tissue; the rest are numbered 2, 3, ... in scan order.
  std::vector<uint16_t> remap(parts.sizes.size(), 1);
  uint16_t kept = 2;
  for (size_t l = 1; l < parts.sizes.size(); ++l) {
    if (parts.sizes[l] < minVoxels) {
      rb.dropped_ += parts.sizes[l];
      continue;
    }
    if (kept == 0xFFFF) throw Error("rigidity: too many rigid components");
    remap[l] = kept++;
    rb.bodies_.push_back(Body{{}, 0, 1, false});
  }
  for (size_t t = 0; t < classes.size(); ++t)
    if (const uint32_t l = parts.labels[t]) classes.data()[t] = remap[l];
  rb.finish(std::move(classes));
  return rb;
}

namespace {

// Index of each voxel's fixed-box membership: 1 where the voxel centre lies in a box.
VolumeU8 boxMask(const Geometry& g, const std::vector<std::array<double, 6>>& boxes) {
  VolumeU8 in(g, 0, 0);
  const Dims d = g.dims;
  for (const auto& b : boxes)
    for (double v : b)
      if (!std::isfinite(v)) throw Error("fixed box: coordinates must be finite (mm)");
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < d.y; ++j)
        for (int64_t i = 0; i < d.x; ++i) {
          const Vec3 p = g.indexToPhysical({double(i), double(j), double(k)});
          for (const auto& b : boxes)
            if (insideFixedBox(b, p)) {
              in(i, j, k) = 1;
              break;
            }
        }
  });
  return in;
}

// Face contacts of each piece: with every other piece it touches, and in all.
struct PieceContacts {
  std::vector<int64_t> total;                             // per piece: faces to anything not itself
  std::map<std::pair<uint32_t, uint32_t>, int64_t> with;  // (piece, other piece) -> faces
};

PieceContacts contactsOf(const Components& parts) {
  const Dims d = parts.dims;
  const size_t np = parts.sizes.size();
  PieceContacts out;
  out.total.assign(np, 0);
  std::mutex mutex;
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    std::vector<int64_t> total(np, 0);
    std::map<std::pair<uint32_t, uint32_t>, int64_t> with;
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < d.y; ++j)
        for (int64_t i = 0; i < d.x; ++i) {
          const int64_t t = (k * d.y + j) * d.x + i;
          const uint32_t p = parts.labels[static_cast<size_t>(t)];
          if (p == 0) continue;
          // Faces inside the volume only: beyond it nothing is known.
          const int64_t nbr[6] = {i > 0 ? t - 1 : -1, i + 1 < d.x ? t + 1 : -1,
                                  j > 0 ? t - d.x : -1, j + 1 < d.y ? t + d.x : -1,
                                  k > 0 ? t - d.x * d.y : -1, k + 1 < d.z ? t + d.x * d.y : -1};
          for (int64_t n : nbr) {
            if (n < 0) continue;
            const uint32_t q = parts.labels[static_cast<size_t>(n)];
            if (q == p) continue;
            ++total[p];
            if (q != 0) ++with[{p, q}];
          }
        }
    std::lock_guard lock(mutex);
    for (size_t p = 0; p < np; ++p) out.total[p] += total[p];
    for (const auto& [key, n] : with) out.with[key] += n;
  });
  return out;
}

}  // namespace

RigidBodies RigidBodies::fromLabels(const LabelVolume& labels, const std::vector<uint16_t>& rigidIds,
                                    int64_t minVoxels, const FixedRegions& fixed) {
  std::vector<std::vector<uint16_t>> groups;
  for (uint16_t id : rigidIds)
    if (std::none_of(groups.begin(), groups.end(), [&](const auto& g) { return g.front() == id; })) groups.push_back({id});
  return fromLabelGroups(labels, groups, minVoxels, fixed);
}

RigidBodies RigidBodies::fromLabelGroups(const LabelVolume& labels, const std::vector<std::vector<uint16_t>>& groups,
                                         int64_t minVoxels, const FixedRegions& fixed) {
  const Geometry& g = labels.geometry();
  const auto& ids = labels.ids().voxels();
  enum Role : uint8_t { kOther = 0, kRigid = 1, kFixed = 2 };
  std::vector<uint8_t> role(65536, kOther);
  std::vector<std::vector<int>> groupsOfId(65536);
  const int ng = static_cast<int>(groups.size());
  if (ng + 3 >= 0xFFFF) throw Error("rigidity: too many rigid bodies");
  for (int gi = 0; gi < ng; ++gi) {
    if (groups[static_cast<size_t>(gi)].empty()) throw Error("rigid labels: an empty body (a '+' with no id)");
    for (uint16_t id : groups[static_cast<size_t>(gi)]) {
      if (id == 0) throw Error("rigid label id 0 is background");
      role[id] = kRigid;
      if (std::find(groupsOfId[id].begin(), groupsOfId[id].end(), gi) == groupsOfId[id].end()) groupsOfId[id].push_back(gi);
    }
  }
  for (uint16_t id : fixed.ids) {
    if (id == 0) throw Error("fixed label id 0 is background (use a fixed box for a region of air)");
    if (role[id] == kRigid) throw Error("label " + std::to_string(id) + " is both rigid and fixed");
    role[id] = kFixed;
  }
  const bool hasBoxes = !fixed.boxesMm.empty();
  const VolumeU8 inBox = hasBoxes ? boxMask(g, fixed.boxesMm) : VolumeU8();
  const auto isFixed = [&](size_t t) { return role[ids[t]] == kFixed || (hasBoxes && inBox.data()[t]); };

  // Pieces: 26-connected parts of each rigid id (fixed voxels excluded).
  VolumeU16 rigid(g, 0, 0);
  parallelFor(static_cast<int64_t>(ids.size()), [&](int64_t t0, int64_t t1) {
    for (int64_t t = t0; t < t1; ++t)
      if (role[ids[static_cast<size_t>(t)]] == kRigid && !isFixed(static_cast<size_t>(t)))
        rigid.data()[t] = ids[static_cast<size_t>(t)];
  });
  const Components parts = connectedRegions(rigid, Connectivity::Vertex26);
  const size_t np = parts.sizes.size();
  const PieceContacts contacts = contactsOf(parts);
  std::map<std::pair<uint32_t, uint16_t>, int64_t> withId;  // (piece, other id) -> faces
  for (const auto& [key, n] : contacts.with) withId[{key.first, parts.values[key.second]}] += n;

  // Each piece's group: its id's, or for an id listed in several groups (the phantom's 11 in
  // 8+11 and 9+11) the group whose other ids it touches most (ties and no contact: the first).
  std::vector<int> groupOf(np, -1);
  for (size_t p = 1; p < np; ++p) {
    const auto& cands = groupsOfId[parts.values[p]];
    int best = cands.front();
    int64_t bestN = 0;
    if (cands.size() > 1)
      for (int gi : cands) {
        int64_t n = 0;
        for (uint16_t other : groups[static_cast<size_t>(gi)])
          if (other != parts.values[p])
            if (const auto it = withId.find({static_cast<uint32_t>(p), other}); it != withId.end()) n += it->second;
        if (n > bestN) { bestN = n; best = gi; }
      }
    groupOf[p] = best;
  }
  // Contacts with each other group (all its pieces together: a cortex label is often several
  // thin pieces around one marrow piece). A piece more than half of whose faces touch one
  // other group is its core.
  std::vector<int64_t> rigidContacts(np, 0);  // faces touching any other piece (any id)
  for (const auto& [key, n] : contacts.with) rigidContacts[key.first] += n;
  std::vector<int> coreOf(np, -1);
  {
    std::map<std::pair<uint32_t, int>, int64_t> withGroup;
    for (const auto& [key, n] : contacts.with)
      if (groupOf[key.first] != groupOf[key.second]) withGroup[{key.first, groupOf[key.second]}] += n;
    for (const auto& [key, n] : withGroup) {
      if (2 * n > contacts.total[key.first]) coreOf[key.first] = key.second;  // at most one group can
    }
  }
  std::vector<int64_t> largestSize(static_cast<size_t>(ng), 0), groupVoxels(static_cast<size_t>(ng), 0);
  for (size_t p = 1; p < np; ++p) {
    const size_t gi = static_cast<size_t>(groupOf[p]);
    largestSize[gi] = std::max(largestSize[gi], parts.sizes[p]);
    groupVoxels[gi] += parts.sizes[p];
  }
  // Specks: small isolated pieces (touching no other rigid piece), not their group's largest.
  std::vector<uint8_t> speck(np, 0);
  std::vector<int> own(static_cast<size_t>(ng), 0);             // pieces neither cores nor specks
  std::vector<int64_t> largestPiece(static_cast<size_t>(ng), -1);  // largest non-speck piece
  for (size_t p = 1; p < np; ++p) {
    const size_t gi = static_cast<size_t>(groupOf[p]);
    speck[p] = coreOf[p] < 0 && rigidContacts[p] == 0 && parts.sizes[p] < minVoxels && parts.sizes[p] != largestSize[gi];
    if (speck[p]) continue;
    if (coreOf[p] < 0) ++own[gi];
    if (largestPiece[gi] < 0 || parts.sizes[p] > parts.sizes[static_cast<size_t>(largestPiece[gi])])
      largestPiece[gi] = static_cast<int64_t>(p);
  }
  // The group whose body a group's cores end in: itself when it has pieces of its own, else
  // where its largest piece is a core. A cycle of groups all cores of each other (never seen)
  // gives its group with the most voxels a body.
  std::vector<int> resolved(static_cast<size_t>(ng), -2);  // -2 unknown, -1 no body, else a group
  std::vector<uint8_t> promoted(static_cast<size_t>(ng), 0);
  const auto resolve = [&](int start) {
    std::vector<int> path;
    int x = start, r = -1;
    for (;;) {
      if (resolved[static_cast<size_t>(x)] != -2) { r = resolved[static_cast<size_t>(x)]; break; }
      if (own[static_cast<size_t>(x)] > 0) { r = x; break; }
      if (const auto it = std::find(path.begin(), path.end(), x); it != path.end()) {
        r = *std::max_element(it, path.end(), [&](int a, int b) { return groupVoxels[static_cast<size_t>(a)] < groupVoxels[static_cast<size_t>(b)]; });
        promoted[static_cast<size_t>(r)] = 1;
        break;
      }
      path.push_back(x);
      const int64_t lp = largestPiece[static_cast<size_t>(x)];
      if (lp < 0 || coreOf[static_cast<size_t>(lp)] < 0) break;  // only specks: no body
      x = coreOf[static_cast<size_t>(lp)];
    }
    for (int y : path) resolved[static_cast<size_t>(y)] = r;
    resolved[static_cast<size_t>(start)] = r;
    return r;
  };
  for (int gi = 0; gi < ng; ++gi) resolve(gi);

  // Bodies in the order of the groups (a group with no piece of its own has none).
  RigidBodies rb;
  std::vector<int> bodyOfGroup(static_cast<size_t>(ng), -1);
  for (int gi = 0; gi < ng; ++gi) {
    if (own[static_cast<size_t>(gi)] == 0 && !promoted[static_cast<size_t>(gi)]) continue;
    bodyOfGroup[static_cast<size_t>(gi)] = static_cast<int>(rb.bodies_.size());
    rb.bodies_.push_back(Body{{}, 0, own[static_cast<size_t>(gi)], false});
  }
  // Piece -> class; a body's ids are those of the pieces it holds (its group's first).
  std::vector<uint16_t> classOfPiece(np, 1);
  std::vector<std::vector<uint16_t>> idsOf(rb.bodies_.size());
  for (size_t p = 1; p < np; ++p) {
    const int owner = speck[p] ? -1 : resolved[static_cast<size_t>(coreOf[p] >= 0 ? coreOf[p] : groupOf[p])];
    if (owner < 0 || bodyOfGroup[static_cast<size_t>(owner)] < 0) {
      rb.dropped_ += parts.sizes[p];
      continue;
    }
    const int b = bodyOfGroup[static_cast<size_t>(owner)];
    classOfPiece[p] = static_cast<uint16_t>(b + 2);
    auto& v = idsOf[static_cast<size_t>(b)];
    if (std::find(v.begin(), v.end(), parts.values[p]) == v.end()) v.push_back(parts.values[p]);
  }
  for (int gi = 0; gi < ng; ++gi) {
    const int b = bodyOfGroup[static_cast<size_t>(gi)];
    if (b < 0) continue;
    auto& out = rb.bodies_[static_cast<size_t>(b)].ids;
    for (uint16_t id : groups[static_cast<size_t>(gi)])  // the group's own ids first, as given
      if (std::find(idsOf[static_cast<size_t>(b)].begin(), idsOf[static_cast<size_t>(b)].end(), id) != idsOf[static_cast<size_t>(b)].end() &&
          std::find(out.begin(), out.end(), id) == out.end())
        out.push_back(id);
    std::vector<uint16_t> rest;
    for (uint16_t id : idsOf[static_cast<size_t>(b)])
      if (std::find(out.begin(), out.end(), id) == out.end()) rest.push_back(id);
    std::sort(rest.begin(), rest.end());
    out.insert(out.end(), rest.begin(), rest.end());
  }
  // Fixed regions: one body, last.
  int64_t fixedVoxels = 0;
  for (size_t t = 0; t < ids.size(); ++t) fixedVoxels += isFixed(t) ? 1 : 0;
  uint16_t fixedClass = 0;
  if (!fixed.empty()) {
    if (fixedVoxels == 0) throw Error("the fixed regions (--fixed-labels, --fixed-box) hold no voxel of the label map");
    rb.fixedBody_ = static_cast<int>(rb.bodies_.size());
    fixedClass = static_cast<uint16_t>(rb.fixedBody_ + 2);
    std::vector<uint16_t> fixedIds = fixed.ids;
    std::sort(fixedIds.begin(), fixedIds.end());
    rb.bodies_.push_back(Body{fixedIds, 0, 0, true});
  }
  VolumeU16 cls(g, 0, 0);
  VolumeU8 boxAir;
  if (hasBoxes) boxAir = VolumeU8(g, 0, 0);
  parallelFor(static_cast<int64_t>(ids.size()), [&](int64_t t0, int64_t t1) {
    for (int64_t t = t0; t < t1; ++t) {
      const size_t u = static_cast<size_t>(t);
      if (isFixed(u)) {
        cls.data()[t] = fixedClass;
        if (hasBoxes && ids[u] == 0) boxAir.data()[t] = 1;
      } else if (const uint32_t p = parts.labels[u]) {
        cls.data()[t] = classOfPiece[p];
      } else {
        cls.data()[t] = ids[u] == 0 ? 0 : 1;
      }
    }
  });
  if (hasBoxes) rb.boxAir_ = std::make_shared<const VolumeU8>(std::move(boxAir));
  rb.finish(std::move(cls));
  return rb;
}

RigidBodies RigidBodies::fromThreshold(const AnyVolume& ct, double boneHu, double airHu,
                                       int64_t minVoxels) {
  VolumeU16 cls(geometryOf(ct), 0, 0);
  std::visit([&](const auto& vol) {
    for (size_t t = 0; t < vol.size(); ++t) {
      const double v = static_cast<double>(vol.data()[t]);
      cls.data()[t] = v >= boneHu ? 2 : v > airHu ? 1 : 0;
    }
  }, ct);
  return fromMask(std::move(cls), minVoxels);
}

uint16_t RigidBodies::classAt(const Vec3& mm) const {
  const Vec3 idx = mmToIndex_ * (mm - classes_->geometry().origin);
  return static_cast<uint16_t>(classes_->sampleNearest(idx));
}

bool RigidBodies::tissueAt(const Vec3& mm) const {
  const Vec3 idx = mmToIndex_ * (mm - classes_->geometry().origin);
  const uint16_t c = static_cast<uint16_t>(classes_->sampleNearest(idx));
  if (c == 0) return false;
  if (boxAir_ && c == fixedBody_ + 2) return boxAir_->sampleNearest(idx) == 0;
  return true;
}

}  // namespace vellum::deformation
