// Joints and poses: the pose file, the joint chain, the generated control points and the
// joint measures (see pose.hpp).
#include "vellum/deformation/pose.hpp"

#include <Eigen/Dense>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>
#include <numbers>
#include <set>
#include <sstream>
#include <tuple>

#include "axis_geometry.hpp"
#include "vellum/core/cropped_geometry.hpp"
#include "vellum/core/distance_transform.hpp"
#include "vellum/core/error.hpp"
#include "vellum/deformation/point_files.hpp"
#include "vellum/core/json_input.hpp"
#include "vellum/core/parallel.hpp"
#include "vellum/core/rotation.hpp"
#include "vellum/deformation/placement.hpp"
#include "vellum/io/nrrd_writer.hpp"

namespace vellum::deformation {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

constexpr uint64_t kMaxPoseFileBytes = 16u << 20;
constexpr size_t kMaxJoints = 256;
constexpr double kDeg = std::numbers::pi / 180.0;

std::vector<uint16_t> readIds(const json& j, const char* key, const fs::path& path, const std::string& where,
                              bool required = true) {
  if (!j.contains(key)) {
    if (required) throw FileError(path, where + "missing \"" + key + "\"");
    return {};
  }
  const json& v = j.at(key);
  std::vector<uint16_t> ids;
  const auto one = [&](const json& x) {
    if (!x.is_number_integer() || x.get<int64_t>() < 1 || x.get<int64_t>() > 65535)
      throw FileError(path, where + "\"" + key + "\" must be a label id 1..65535 or a list of them");
    ids.push_back(static_cast<uint16_t>(x.get<int64_t>()));
  };
  if (v.is_array()) {
    if (v.empty() && required) throw FileError(path, where + "\"" + key + "\" is empty");
    if (v.size() > 65535) throw FileError(path, where + "\"" + key + "\" has too many ids");
    for (const json& x : v) one(x);
  } else {
    one(v);
  }
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  return ids;
}

Vec3 readPoint(const json& v, const fs::path& path, const std::string& what) {
  if (!v.is_array() || v.size() != 3 || !v[0].is_number() || !v[1].is_number() || !v[2].is_number())
    throw FileError(path, what + " must be [x, y, z] in mm");
  return {v[0].get<double>(), v[1].get<double>(), v[2].get<double>()};
}

void onlyKeys(const json& j, const std::set<std::string>& allowed, const fs::path& path, const std::string& where) {
  for (auto it = j.begin(); it != j.end(); ++it)
    if (!allowed.count(it.key())) throw FileError(path, where + "unknown key \"" + it.key() + "\"");
}

bool contains(const std::vector<uint16_t>& sorted, uint16_t id) {
  return std::binary_search(sorted.begin(), sorted.end(), id);
}

/// Per-id voxel moments (index space), for the ids flagged in `want`.
struct IdMoments {
  double n = 0;
  Eigen::Vector3d s = Eigen::Vector3d::Zero();
  Eigen::Matrix3d ss = Eigen::Matrix3d::Zero();
};

std::map<uint16_t, IdMoments> idMoments(const LabelVolume& labels, const std::vector<uint16_t>& ids) {
  std::vector<int> slot(65536, -1);
  for (size_t i = 0; i < ids.size(); ++i) slot[ids[i]] = static_cast<int>(i);
  const Dims d = labels.geometry().dims;
  std::vector<IdMoments> total(ids.size());
  std::mutex m;
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    std::vector<IdMoments> acc(ids.size());
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < d.y; ++j)
        for (int64_t i = 0; i < d.x; ++i) {
          const int s = slot[labels(i, j, k)];
          if (s < 0) continue;
          const Eigen::Vector3d p{double(i), double(j), double(k)};
          acc[s].n += 1;
          acc[s].s += p;
          acc[s].ss += p * p.transpose();
        }
    std::lock_guard lock(m);
    for (size_t i = 0; i < ids.size(); ++i) {
      total[i].n += acc[i].n;
      total[i].s += acc[i].s;
      total[i].ss += acc[i].ss;
    }
  });
  std::map<uint16_t, IdMoments> out;
  for (size_t i = 0; i < ids.size(); ++i) out[ids[i]] = total[i];
  return out;
}

/// Centroid and principal axes (index space, columns by increasing variance) of moments.
void principal(const IdMoments& a, Eigen::Vector3d& mean, Eigen::Matrix3d& axes, Eigen::Vector3d& sigma) {
  mean = a.s / a.n;
  const Eigen::Matrix3d cov = a.ss / a.n - mean * mean.transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
  axes = es.eigenvectors();
  sigma = es.eigenvalues().cwiseMax(0.0).cwiseSqrt();
}

/// Angle (deg) of a rotation matrix.
double rotationAngleDeg(const Mat3& r) {
  const double c = std::clamp((r(0, 0) + r(1, 1) + r(2, 2) - 1) / 2, -1.0, 1.0);
  return std::acos(c) / kDeg;
}

/// Signed angle (deg) that `r` turns vectors perpendicular to the unit axis `n` about it (the
/// twist of a swing-twist split): a reference vector across the axis, turned and projected.
double twistDeg(const Mat3& r, const Vec3& n) {
  const Vec3 helper = std::abs(n.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
  const Vec3 p = normalized(cross(n, helper));
  Vec3 q = r * p;
  q = q - n * dot(n, q);
  return std::atan2(dot(n, cross(p, q)), dot(p, q)) / kDeg;
}

}  // namespace

const params::Table<PoseOptions>& poseOptionsTable() {
  using O = PoseOptions;
  static const params::Table<O> t{
      params::real<O>("sample_spread", &O::sampleSpread,
                      {"Bone sample spread", "points on each bone at its centroid +- this many standard deviations "
                       "along its principal axes (snapped to the bone's nearest voxel)", "", 0.1, 3}),
      params::real<O>("sample_step", &O::sampleStepMm,
                      {"Bone sample step", "also one point per cell of this size on every bone of a joint, so "
                       "that each bone's own points dominate the map inside it (0 = principal samples only)",
                       "mm", 0, 200}),
      params::integer<O>("anchors", &O::anchors,
                         {"Still anchors", "points on the volume's inset box that stay put (0 = none)", "", 0, 64}),
      params::real<O>("anchor_inset", &O::anchorInset,
                      {"Anchor inset", "inset of the anchors' box, fraction of the volume's extent", "", 0, 0.49}),
      params::real<O>("contact", &O::contactMm,
                      {"Contact distance", "\"axis\": \"estimate\": parent and child voxels this close form the "
                       "joint's contact zone", "mm", 0.5, 30}),
      params::real<O>("max_step", &O::maxStepDeg,
                      {"Movie angle step", "movies: generated keyframes at most this many degrees apart per joint",
                       "deg", 0.1, 90}),
      params::integer<O>("measure_stride", &O::measureStride,
                         {"Joint measure stride", "joint measures visit every N-th voxel per axis (1 = all)", "", 1, 64}),
      params::real<O>("twist_power", &O::twistPower,
                      {"Twist blend power", "--map twist: the weight between the still side (0) and the moving "
                       "side (1) is dS^p / (dS^p + dM^p) of the distances to them", "", 0.5, 8}),
      params::real<O>("twist_margin", &O::twistMargin,
                      {"Twist slope margin", "--map twist: the weight is relaxed until angle * dw/dalpha <= 1 - this "
                       "(det J >= this) wherever it is free", "", 0.01, 0.9}),
  };
  return t;
}

std::vector<double> Pose::anglesAt(double timeS) const {
  const ControlPoints p = angles.at(timeS);
  std::vector<double> a(p.size());
  for (size_t i = 0; i < p.size(); ++i) a[i] = p[i].source.x;
  return a;
}

double Pose::lastKeyframeTimeS() const {
  double t = 0;
  for (size_t k = 0; k + 1 < angles.keyframes.size(); ++k) t += angles.keyframes[k].durationS;
  return t;
}

std::vector<uint16_t> Pose::boneIds() const {
  std::vector<uint16_t> ids;
  for (const Joint& j : joints) {
    ids.insert(ids.end(), j.parent.begin(), j.parent.end());
    ids.insert(ids.end(), j.child.begin(), j.child.end());
  }
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  return ids;
}

int Pose::jointMoving(uint16_t id) const {
  for (size_t j = 0; j < joints.size(); ++j)
    if (contains(joints[j].child, id)) return static_cast<int>(j);
  return -1;
}

RigidTransform rotationAbout(const Vec3& a, const Vec3& b, double angleDeg) {
  const Mat3 r = rotationMatrix(normalized(b - a), angleDeg * kDeg);
  RigidTransform out;
  out.rotation = r;
  out.translation = a - r * a;  // the axis stays where it is
  return out;
}

std::vector<RigidTransform> jointTransforms(const Pose& pose, const std::vector<double>& anglesDeg) {
  const size_t n = pose.joints.size();
  if (anglesDeg.size() != n) throw Error("pose: " + std::to_string(anglesDeg.size()) + " angles for " +
                                         std::to_string(n) + " joints");
  std::vector<RigidTransform> out(n);
  std::vector<bool> done(n, false);
  // Proximal joints first (linkJoints() guarantees there is no cycle).
  for (size_t pass = 0; pass < n; ++pass)
    for (size_t j = 0; j < n; ++j) {
      if (done[j]) continue;
      const Joint& joint = pose.joints[j];
      if (joint.proximal >= 0 && !done[joint.proximal]) continue;
      const RigidTransform own = rotationAbout(joint.axisA, joint.axisB, anglesDeg[j]);
      if (joint.proximal < 0) {
        out[j] = own;
      } else {  // distal first, then the proximal chain: x -> P(own(x))
        out[j] = compose(out[joint.proximal], own);
      }
      done[j] = true;
    }
  return out;
}

void linkJoints(Pose& pose) {
  const size_t n = pose.joints.size();
  for (size_t j = 0; j < n; ++j) {
    Joint& joint = pose.joints[j];
    const std::string where = "joint \"" + joint.name + "\": ";
    for (uint16_t id : joint.child)
      if (contains(joint.parent, id)) throw Error(where + "label " + std::to_string(id) + " is both parent and child");
    for (size_t k = 0; k < j; ++k) {
      if (pose.joints[k].name == joint.name) throw Error(where + "two joints have this name");
      for (uint16_t id : joint.child)
        if (contains(pose.joints[k].child, id))
          throw Error(where + "label " + std::to_string(id) + " is also the child of joint \"" +
                      pose.joints[k].name + "\" (a bone follows one joint)");
    }
    for (uint16_t id : joint.child)
      if (std::find(pose.fixed.ids.begin(), pose.fixed.ids.end(), id) != pose.fixed.ids.end())
        throw Error(where + "child label " + std::to_string(id) + " is in \"fixed_labels\"");
    if (!joint.estimateAxis && !(norm(joint.axisB - joint.axisA) > 1e-6))
      throw Error(where + "the two axis points coincide");
    // The chain: the joint whose child holds this joint's parent.
    joint.proximal = -1;
    for (size_t k = 0; k < n; ++k) {
      if (k == j) continue;
      const bool holds = std::any_of(joint.parent.begin(), joint.parent.end(),
                                     [&](uint16_t id) { return contains(pose.joints[k].child, id); });
      if (!holds) continue;
      if (joint.proximal >= 0)
        throw Error(where + "its parent bone is moved by two joints (\"" + pose.joints[joint.proximal].name +
                    "\" and \"" + pose.joints[k].name + "\")");
      joint.proximal = static_cast<int>(k);
    }
  }
  for (size_t j = 0; j < n; ++j) {  // a chain longer than the joint count loops
    int p = pose.joints[j].proximal;
    for (size_t steps = 0; p >= 0; ++steps, p = pose.joints[p].proximal)
      if (steps > n) throw Error("joint \"" + pose.joints[j].name + "\": the joints form a cycle");
  }
}

Pose loadPose(const fs::path& path) {
  const json j = readJsonFile(path, kMaxPoseFileBytes, "pose file");
  if (!j.is_object()) throw FileError(path, "expected a JSON object with \"joints\" and \"keyframes\"");
  onlyKeys(j, {"units", "joints", "fixed_labels", "fixed_boxes", "keyframes", "interpolation", "loop", "map"}, path, "");
  if (j.contains("units") && !(j.at("units").is_string() && j.at("units").get<std::string>() == "mm"))
    throw FileError(path, "\"units\" must be \"mm\"");
  Pose pose;
  if (j.contains("map")) {
    const json& m = j.at("map");
    if (!m.is_string() || (m.get<std::string>() != "twist" && m.get<std::string>() != "mls"))
      throw FileError(path, "\"map\" must be \"twist\" or \"mls\"");
    pose.map = m.get<std::string>();
  }
  if (!j.contains("joints") || !j.at("joints").is_array() || j.at("joints").empty())
    throw FileError(path, "\"joints\" must be a non-empty array");
  if (j.at("joints").size() > kMaxJoints)
    throw FileError(path, "\"joints\" has more than " + std::to_string(kMaxJoints) + " entries");
  for (const json& o : j.at("joints")) {
    const std::string where = "joint " + std::to_string(pose.joints.size()) + ": ";
    if (!o.is_object()) throw FileError(path, where + "not an object");
    onlyKeys(o, {"name", "parent", "child", "axis", "axis_hint", "axis_hint_cone"}, path, where);
    Joint joint;
    if (!o.contains("name") || !o.at("name").is_string() || o.at("name").get<std::string>().empty())
      throw FileError(path, where + "\"name\" must be a non-empty string");
    joint.name = o.at("name").get<std::string>();
    joint.parent = readIds(o, "parent", path, where);
    joint.child = readIds(o, "child", path, where);
    if (!o.contains("axis")) throw FileError(path, where + "missing \"axis\" ([[x, y, z], [x, y, z]] or \"estimate\")");
    const json& ax = o.at("axis");
    if (ax.is_string() && ax.get<std::string>() == "estimate") {
      joint.estimateAxis = true;
    } else {
      if (!ax.is_array() || ax.size() != 2)
        throw FileError(path, where + "\"axis\" must be two points [[x, y, z], [x, y, z]] (mm) or \"estimate\"");
      joint.axisA = readPoint(ax[0], path, where + "\"axis\"[0]");
      joint.axisB = readPoint(ax[1], path, where + "\"axis\"[1]");
    }
    if (o.contains("axis_hint")) {
      const json& h = o.at("axis_hint");
      if (!joint.estimateAxis) throw FileError(path, where + "\"axis_hint\" goes with \"axis\": \"estimate\"");
      if (!h.is_array() || h.size() != 2)
        throw FileError(path, where + "\"axis_hint\" must be two points [[x, y, z], [x, y, z]] (mm)");
      joint.hintA = readPoint(h[0], path, where + "\"axis_hint\"[0]");
      joint.hintB = readPoint(h[1], path, where + "\"axis_hint\"[1]");
      if (!(norm(joint.hintB - joint.hintA) > 1e-6)) throw FileError(path, where + "\"axis_hint\": the two points coincide");
      joint.hasAxisHint = true;
    }
    if (o.contains("axis_hint_cone")) {
      const json& c = o.at("axis_hint_cone");
      if (!joint.hasAxisHint) throw FileError(path, where + "\"axis_hint_cone\" goes with \"axis_hint\"");
      if (!c.is_number() || !(c.get<double>() >= 0 && c.get<double>() <= 45))
        throw FileError(path, where + "\"axis_hint_cone\" must be a number of degrees in [0, 45]");
      joint.hintConeDeg = c.get<double>();
    }
    pose.joints.push_back(std::move(joint));
  }
  pose.fixed.ids = readIds(j, "fixed_labels", path, "", false);
  if (j.contains("fixed_boxes")) {
    const json& b = j.at("fixed_boxes");
    if (!b.is_array()) throw FileError(path, "\"fixed_boxes\" must be a list of [x0, y0, z0, x1, y1, z1] (mm)");
    for (const json& box : b) {
      bool ok = box.is_array() && box.size() == 6;
      for (size_t i = 0; ok && i < 6; ++i) ok = box[i].is_number();
      if (!ok) throw FileError(path, "\"fixed_boxes\" must be a list of [x0, y0, z0, x1, y1, z1] (mm)");
      std::array<double, 6> a{};
      for (size_t i = 0; i < 6; ++i) a[i] = box[i].get<double>();
      pose.fixed.boxesMm.push_back(a);
    }
  }
  // The angles: one point per joint whose source.x is its angle (timing and interpolation
  // are then the keyframe track's).
  KeyframeTrack& t = pose.angles;
  readTrackSettings(j, path, t);
  for (const json& k : j.at("keyframes")) {
    const std::string where = "keyframe " + std::to_string(t.keyframes.size()) + ": ";
    if (!k.is_object()) throw FileError(path, where + "not an object");
    onlyKeys(k, {"duration", "angles"}, path, where);
    Keyframe kf;
    if (k.contains("duration")) {
      if (!k.at("duration").is_number()) throw FileError(path, where + "\"duration\" must be a number (s)");
      kf.durationS = k.at("duration").get<double>();
    }
    if (!k.contains("angles") || !k.at("angles").is_object())
      throw FileError(path, where + "\"angles\" must be an object {\"joint name\": degrees}");
    const json& a = k.at("angles");
    for (auto it = a.begin(); it != a.end(); ++it)
      if (std::none_of(pose.joints.begin(), pose.joints.end(), [&](const Joint& jt) { return jt.name == it.key(); }))
        throw FileError(path, where + "\"angles\" names no joint \"" + it.key() + "\"");
    for (const Joint& joint : pose.joints) {
      double deg = 0;  // a joint a keyframe does not name is at rest
      if (a.contains(joint.name)) {
        const json& v = a.at(joint.name);
        if (!v.is_number() || !(std::abs(v.get<double>()) <= 360))
          throw FileError(path, where + "\"angles\".\"" + joint.name + "\" must be a number in -360..360 (degrees)");
        deg = v.get<double>();
      }
      kf.points.push_back({{deg, 0, 0}, {deg, 0, 0}, {}});
    }
    t.keyframes.push_back(std::move(kf));
  }
  try {
    t.validate();
    linkJoints(pose);
  } catch (const FileError&) {
    throw;
  } catch (const Error& e) {
    throw FileError(path, e.what());
  }
  return pose;
}

void savePose(const Pose& pose, const fs::path& path) {
  json joints = json::array();
  for (const Joint& jt : pose.joints) {
    json o = {{"name", jt.name}, {"parent", jt.parent}, {"child", jt.child}};
    if (jt.estimateAxis) o["axis"] = "estimate";
    else o["axis"] = {{jt.axisA.x, jt.axisA.y, jt.axisA.z}, {jt.axisB.x, jt.axisB.y, jt.axisB.z}};
    if (jt.hasAxisHint) {
      o["axis_hint"] = {{jt.hintA.x, jt.hintA.y, jt.hintA.z}, {jt.hintB.x, jt.hintB.y, jt.hintB.z}};
      if (jt.hintConeDeg != 0) o["axis_hint_cone"] = jt.hintConeDeg;
    }
    joints.push_back(std::move(o));
  }
  json keyframes = json::array();
  for (const Keyframe& kf : pose.angles.keyframes) {
    json angles = json::object();
    for (size_t j = 0; j < pose.joints.size() && j < kf.points.size(); ++j) angles[pose.joints[j].name] = kf.points[j].source.x;
    keyframes.push_back({{"duration", kf.durationS}, {"angles", std::move(angles)}});
  }
  json boxes = json::array();
  for (const auto& b : pose.fixed.boxesMm) boxes.push_back(b);
  json j = {{"units", "mm"}, {"joints", std::move(joints)}};
  if (!pose.fixed.ids.empty()) j["fixed_labels"] = pose.fixed.ids;
  if (!boxes.empty()) j["fixed_boxes"] = std::move(boxes);
  if (!pose.map.empty()) j["map"] = pose.map;
  j["interpolation"] = interpolationName(pose.angles.interpolation);
  j["loop"] = pose.angles.loop;
  j["keyframes"] = std::move(keyframes);
  io::writeTextFile(path, j.dump(2) + "\n");
}

namespace {

/// A joint's contact zone: the parent's and the child's voxels within contactMm of the other
/// bone. Per side its surface voxels (a 6-neighbour outside the bone) with their outward
/// normals, kept only where they face the other bone (its nearest voxel lies within 60° of the
/// normal): articular surfaces face each other across the joint space; the zone's rim and the
/// far side of a thin piece do not. Per child id, how many of its voxels lie in the zone.
struct ContactZone {
  IdMoments moments;                         ///< every zone voxel (index space)
  std::vector<Vec3> surface[2], normals[2];  ///< parent, child (mm; outward unit normals)
  std::map<uint16_t, int64_t> childContact;  ///< child id -> its voxels in the zone
};

ContactZone contactZone(const LabelVolume& labels, const std::vector<uint16_t>& parent,
                        const std::vector<uint16_t>& child, double contactMm, Progress& progress) {
  const Geometry& g = labels.geometry();
  const Dims d = g.dims;
  std::vector<uint8_t> side(65536, 0);
  for (uint16_t id : parent) side[id] = 1;
  for (uint16_t id : child) side[id] = 2;
  ContactZone zone;
  // Only where both bones' boxes, grown by the reach, overlap can a voxel lie within reach of
  // the other bone (and that bone's nearest voxel lies there too): the distance fields are made
  // on that box alone, a few cm around a joint on a 512² scan.
  const auto [pb, cb] = axis::markedBoxes(labels, side);
  const double reach[3] = {contactMm / g.spacing.x, contactMm / g.spacing.y, contactMm / g.spacing.z};
  const int64_t dims[3] = {d.x, d.y, d.z};
  VoxelBox box;
  for (int a = 0; a < 3; ++a) {
    const auto grown = [&](const VoxelBox& b, bool low) {
      return low ? b.lo[a] - int64_t(std::ceil(reach[a])) : b.hi[a] + int64_t(std::ceil(reach[a]));
    };
    box.lo[a] = std::max<int64_t>({grown(pb, true), grown(cb, true), 0});
    box.hi[a] = std::min<int64_t>({grown(pb, false), grown(cb, false), dims[a] - 1});
    if (pb.hi[a] < 0 || cb.hi[a] < 0 || box.hi[a] < box.lo[a]) return zone;  // a bone missing, or apart
  }
  // Squared distance (mm²) of every box voxel to the nearest parent and child voxel.
  const Geometry bg = croppedGeometry(g, box);
  const Dims bd = bg.dims;
  VolumeU8 mask[2] = {VolumeU8(bg), VolumeU8(bg)};
  parallelFor(bd.z, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < bd.y; ++j)
        for (int64_t i = 0; i < bd.x; ++i) {
          const uint8_t s = side[labels(box.lo[0] + i, box.lo[1] + j, box.lo[2] + k)];
          mask[0](i, j, k) = s == 1;
          mask[1](i, j, k) = s == 2;
        }
  });
  const VolumeF32 dist2[2] = {squaredDistanceMm(mask[0]), squaredDistanceMm(mask[1])};
  const double reach2 = contactMm * contactMm;
  const double minSpacing = g.minSpacing();
  const double facing = std::cos(60 * kDeg);
  std::mutex m;
  parallelFor(bd.z, [&](int64_t k0, int64_t k1) {
    IdMoments acc;
    std::map<uint16_t, int64_t> contact;
    std::vector<Vec3> found[2], foundNormals[2];
    const auto inside = [&](int64_t a, int64_t b, int64_t c) {
      return a >= 0 && b >= 0 && c >= 0 && a < d.x && b < d.y && c < d.z;
    };
    for (int64_t k = k0; k < k1; ++k) {
      progress.checkCancelled();
      for (int64_t j = 0; j < bd.y; ++j)
        for (int64_t i = 0; i < bd.x; ++i) {
          const int64_t gi = box.lo[0] + i, gj = box.lo[1] + j, gk = box.lo[2] + k;
          const uint8_t s = side[labels(gi, gj, gk)];
          if (!s) continue;
          const VolumeF32& other = dist2[2 - s];  // the other bone's squared distance
          const double nearest2 = other(i, j, k);
          if (!(nearest2 <= reach2)) continue;
          const Eigen::Vector3d p{double(gi), double(gj), double(gk)};
          acc.n += 1;
          acc.s += p;
          acc.ss += p * p.transpose();
          if (s == 2) ++contact[labels(gi, gj, gk)];
          const auto own = [&](int64_t a, int64_t b, int64_t c) { return inside(a, b, c) && side[labels(a, b, c)] == s; };
          if (own(gi - 1, gj, gk) && own(gi + 1, gj, gk) && own(gi, gj - 1, gk) && own(gi, gj + 1, gk) &&
              own(gi, gj, gk - 1) && own(gi, gj, gk + 1))
            continue;
          // Outward normal: away from the bone's voxels in the 5³ neighbourhood (mm).
          Vec3 n{0, 0, 0};
          for (int64_t dk = -2; dk <= 2; ++dk)
            for (int64_t dj = -2; dj <= 2; ++dj)
              for (int64_t di = -2; di <= 2; ++di)
                if (own(gi + di, gj + dj, gk + dk)) n = n - mul(Vec3{double(di), double(dj), double(dk)}, g.spacing);
          const Vec3 here = g.indexToPhysical({double(gi), double(gj), double(gk)});
          const Vec3 ahead =
              g.indexToPhysical({p.x() + n.x / g.spacing.x, p.y() + n.y / g.spacing.y, p.z() + n.z / g.spacing.z});
          const double len = norm(n);
          const bool clear = len > 5 * minSpacing;  // else a sliver: no clear side
          // The nearest voxel of the other bone (its distance is known: search only the box that
          // reaches it, in the same order, so the first of equally near voxels is taken).
          const double nearestMm = std::sqrt(nearest2);
          const int64_t r[3] = {int64_t(std::ceil(nearestMm / g.spacing.x + 1e-6)),
                                int64_t(std::ceil(nearestMm / g.spacing.y + 1e-6)),
                                int64_t(std::ceil(nearestMm / g.spacing.z + 1e-6))};
          Vec3 nearest{0, 0, 0};
          double best = std::numeric_limits<double>::infinity();
          for (int64_t dk = -r[2]; dk <= r[2]; ++dk)
            for (int64_t dj = -r[1]; dj <= r[1]; ++dj)
              for (int64_t di = -r[0]; di <= r[0]; ++di) {
                const int64_t a = gi + di, b = gj + dj, c = gk + dk;
                if (!inside(a, b, c)) continue;
                const uint8_t o = side[labels(a, b, c)];
                if (!o || o == s) continue;
                const Vec3 dmm = mul(Vec3{double(di), double(dj), double(dk)}, g.spacing);
                const double l = norm(dmm);
                if (l < best) nearest = dmm, best = l;
              }
          if (clear && best > 0 && dot(n, nearest) < facing * len * best) continue;  // faces away
          found[s - 1].push_back(here);
          foundNormals[s - 1].push_back(clear ? normalized(ahead - here) : Vec3{0, 0, 0});
        }
    }
    std::lock_guard lock(m);
    zone.moments.n += acc.n;
    zone.moments.s += acc.s;
    zone.moments.ss += acc.ss;
    for (const auto& [id, count] : contact) zone.childContact[id] += count;
    for (int s = 0; s < 2; ++s) {
      zone.surface[s].insert(zone.surface[s].end(), found[s].begin(), found[s].end());
      zone.normals[s].insert(zone.normals[s].end(), foundNormals[s].begin(), foundNormals[s].end());
    }
  });
  // Slab order differs between runs: sort, so that the (thinned) fits are deterministic.
  for (int s = 0; s < 2; ++s) {
    std::vector<size_t> order(zone.surface[s].size());
    for (size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
      const Vec3 &p = zone.surface[s][a], &q = zone.surface[s][b];
      return std::tie(p.z, p.y, p.x) < std::tie(q.z, q.y, q.x);
    });
    std::vector<Vec3> ps, ns;
    for (size_t i : order) ps.push_back(zone.surface[s][i]), ns.push_back(zone.normals[s][i]);
    zone.surface[s] = std::move(ps);
    zone.normals[s] = std::move(ns);
  }
  return zone;
}

/// The joint's articular partner among the child's ids: the one with the most voxels in the
/// contact zone (the talus under the plafond, not the calcaneus that a tibial lip may touch).
uint16_t articularPartner(const ContactZone& zone) {
  uint16_t best = 0;
  int64_t most = -1;
  for (const auto& [id, count] : zone.childContact)
    if (count > most) best = id, most = count;
  return best;
}

/// A warning when another child id touches the parent almost as much as the partner (80 %):
/// then the partner may be the wrong bone (on the feet the calcaneus catches up with the talus
/// from ~10 mm of reach). Empty otherwise.
std::string partnerTie(const ContactZone& zone, uint16_t partner, double contactMm) {
  const int64_t most = zone.childContact.at(partner);
  for (const auto& [id, count] : zone.childContact)
    if (id != partner && 5 * count >= 4 * most) {
      std::ostringstream s;
      s << "child ids " << partner << " and " << id << " touch the parent almost equally (" << most << " and " << count
        << " voxels within " << contactMm << " mm): the fitted partner " << partner
        << " may be the wrong bone (lower --contact, or give the axis as two points)";
      return s.str();
    }
  return {};
}

/// The zone's centroid and widest direction (mm): the axis when no surface fits, as a hint.
AxisEstimate contactFallback(const ContactZone& zone, const Geometry& g) {
  Eigen::Vector3d mean, sigma;
  Eigen::Matrix3d axes;
  principal(zone.moments, mean, axes, sigma);
  const Vec3 c = g.indexToPhysical({mean.x(), mean.y(), mean.z()});
  const Eigen::Vector3d e = axes.col(2);
  AxisEstimate est;
  est.point = c;
  est.direction = normalized(g.indexToPhysical({mean.x() + e.x(), mean.y() + e.y(), mean.z() + e.z()}) - c);
  return est;
}

/// The ids joint `ji` turns: its child's and those of every joint distal to it.
std::vector<uint16_t> movingIds(const Pose& pose, size_t ji) {
  std::vector<uint16_t> ids;
  for (size_t k = 0; k < pose.joints.size(); ++k) {
    int j = int(k);
    for (size_t hops = 0; j >= 0 && j != int(ji) && hops <= pose.joints.size(); ++hops) j = pose.joints[size_t(j)].proximal;
    if (j == int(ji)) ids.insert(ids.end(), pose.joints[k].child.begin(), pose.joints[k].child.end());
  }
  return ids;
}

}  // namespace

void estimateAxes(Pose& pose, const LabelVolume& labels, double contactMm, Progress& progress) {
  const Geometry& g = labels.geometry();
  // Inlier band of the surface fits: 1.5 voxels (voxel surfaces stair-step by half a voxel).
  const double band = 1.5 * (g.spacing.x + g.spacing.y + g.spacing.z) / 3.0;
  for (size_t ji = 0; ji < pose.joints.size(); ++ji) {
    Joint& joint = pose.joints[ji];
    if (!joint.estimateAxis) continue;
    const ContactZone all = contactZone(labels, joint.parent, joint.child, contactMm, progress);
    if (all.moments.n < 3)
      throw Error("joint \"" + joint.name + "\": \"axis\": \"estimate\": the parent and child bones come no closer than " +
                  std::to_string(contactMm) + " mm (no contact zone; give the axis as two points or raise --contact)");
    // Only the articular partner's contact with the parent is the joint (a child of several
    // ids: the foot's bones under the tibia); the others' contacts are not fitted.
    const uint16_t partner = articularPartner(all);
    const ContactZone zone =
        all.childContact.size() > 1 ? contactZone(labels, joint.parent, {partner}, contactMm, progress) : all;
    // Both bones' articular surfaces share the hinge's axis: fitted together.
    progress.checkCancelled();
    AxisEstimate est = fitArticularSurfaces(zone.surface[0], zone.normals[0], zone.surface[1], zone.normals[1], band);
    est.fit.surfaceMethod = est.fit.method;
    if (est.fit.method.empty()) {
      // No curved surface fits, or the fit was refused: the zone's centroid and widest
      // direction, as a hint only, and why.
      AxisFit refused = est.fit;
      est = contactFallback(zone, g);
      est.fit = refused;
      est.fit.method = "contact";
      std::string why = "no cylinder or sphere fits the joint's contact surfaces (flat or too small)";
      if (!refused.refusals.empty()) {
        why = "the surface fit was refused (";
        for (size_t i = 0; i < refused.refusals.size(); ++i) why += (i ? "; " : "") + refused.refusals[i];
        why += ")";
      }
      est.fit.warning = why + ": the axis is only the contact zone's widest direction through its centroid (give it as two points)";
    }
    // A hint: the motion search (joint_motion.hpp) places the axis near it, the axis about
    // which the whole child (all its ids, everything distal) slides along the parent with the
    // least collision over a hinge's working range either way (not the keyframes' angles: the
    // axis is the joint's, and the studio places it before any angle is set); the surface
    // fit above stays in the report.
    if (joint.hasAxisHint) {
      Vec3 point = joint.hintA, dir = normalized(joint.hintB - joint.hintA);
      const HingeMotion motion(labels, joint.parent, movingIds(pose, ji), all.surface[0], all.surface[1],
                               kHintAnglesDeg, kHintReachMm, progress);
      est.fit.motion = motion.search(point, dir, joint.hintConeDeg, kHintReachMm, progress);
      const MotionFit& m = est.fit.motion;
      if (m.searched) {
        est.point = point, est.direction = dir;
        est.fit.method = "motion";
        est.fit.warning.clear();
        if (m.shiftMm > kHintReachMm - 0.5 || (m.coneDeg > 0 && m.turnDeg > m.coneDeg - 0.5)) {
          std::ostringstream w;
          w.setf(std::ios::fixed);
          w.precision(1);
          w << "the axis found lies at the edge of the search about the hint (" << m.shiftMm << " mm, " << m.turnDeg
            << " deg from it): check the hint";
          est.fit.warning = w.str();
        }
      } else {
        est.fit.warning = "the axis hint could not be placed (no contact voxels to score): " + est.fit.warning;
      }
    }
    est.fit.partner = partner;
    for (const auto& [id, count] : all.childContact) est.fit.contactVoxels.push_back({id, count});
    const std::string tie = est.fit.motion.searched ? "" : partnerTie(all, partner, contactMm);
    if (!tie.empty()) est.fit.warning += (est.fit.warning.empty() ? "" : "; ") + tie;
    Vec3 dir = normalized(est.direction);
    // Deterministic sign: the hint's (the user's sense of a positive angle), else the largest
    // component positive.
    const int big = std::abs(dir.x) >= std::abs(dir.y) && std::abs(dir.x) >= std::abs(dir.z) ? 0
                    : std::abs(dir.y) >= std::abs(dir.z)                                   ? 1
                                                                                           : 2;
    if (joint.hasAxisHint ? dot(dir, joint.hintB - joint.hintA) < 0 : dir[big] < 0) dir = -dir;
    joint.axisA = est.point - dir * 10.0;
    joint.axisB = est.point + dir * 10.0;
    joint.fit = est.fit;
  }
}

PoseSamples poseSamples(const Pose& pose, const LabelVolume& labels, const PoseOptions& o) {
  params::validate(poseOptionsTable(), o);
  const Geometry& g = labels.geometry();
  const Dims d = g.dims;
  std::vector<uint16_t> ids = pose.boneIds();
  ids.insert(ids.end(), pose.fixed.ids.begin(), pose.fixed.ids.end());
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  const std::map<uint16_t, IdMoments> moments = idMoments(labels, ids);
  // Ideal sample positions per id (index space): the centroid and +- spread sigma on each axis.
  constexpr int kPerId = 7;
  std::vector<int> slot(65536, -1);
  std::vector<std::array<Eigen::Vector3d, kPerId>> want(ids.size());
  for (size_t s = 0; s < ids.size(); ++s) {
    const IdMoments& a = moments.at(ids[s]);
    if (a.n == 0) throw Error("label " + std::to_string(ids[s]) + " of the pose has no voxel in the label map");
    slot[ids[s]] = static_cast<int>(s);
    Eigen::Vector3d mean, sigma;
    Eigen::Matrix3d axes;
    principal(a, mean, axes, sigma);
    want[s][0] = mean;
    for (int k = 0; k < 3; ++k)
      for (int sgn = 0; sgn < 2; ++sgn)
        want[s][1 + 2 * k + sgn] = mean + axes.col(k) * ((sgn ? 1 : -1) * o.sampleSpread * sigma(k));
  }
  // Snap each to the id's nearest voxel (so every sample sits on its bone: a curved bone's
  // centroid may lie outside it). Per slab best candidates, merged.
  struct Best {
    double d2 = std::numeric_limits<double>::infinity();
    int64_t i = 0, j = 0, k = 0;
  };
  std::vector<std::array<Best, kPerId>> best(ids.size());
  std::mutex m;
  const Vec3 sp = g.spacing;
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    std::vector<std::array<Best, kPerId>> local(ids.size());
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < d.y; ++j)
        for (int64_t i = 0; i < d.x; ++i) {
          const int s = slot[labels(i, j, k)];
          if (s < 0) continue;
          for (int q = 0; q < kPerId; ++q) {
            const Eigen::Vector3d& w = want[s][q];
            const double dx = (double(i) - w.x()) * sp.x, dy = (double(j) - w.y()) * sp.y, dz = (double(k) - w.z()) * sp.z;
            const double d2 = dx * dx + dy * dy + dz * dz;
            if (d2 < local[s][q].d2) local[s][q] = {d2, i, j, k};
          }
        }
    std::lock_guard lock(m);
    for (size_t s = 0; s < ids.size(); ++s)
      for (int q = 0; q < kPerId; ++q) {
        const Best& b = local[s][q];
        Best& t = best[s][q];
        // Ties broken by index so the result does not depend on the slab order.
        if (b.d2 < t.d2 || (b.d2 == t.d2 && std::tie(b.k, b.j, b.i) < std::tie(t.k, t.j, t.i))) t = b;
      }
  });
  PoseSamples out;
  const double minGap = 0.5 * std::min({sp.x, sp.y, sp.z});
  auto add = [&](const Vec3& p, int joint) {
    for (const Vec3& q : out.sources)
      if (norm(q - p) < minGap) return false;
    out.sources.push_back(p);
    out.joint.push_back(joint);
    return true;
  };
  for (size_t s = 0; s < ids.size(); ++s) {
    const bool fixed = std::find(pose.fixed.ids.begin(), pose.fixed.ids.end(), ids[s]) != pose.fixed.ids.end();
    const int joint = fixed ? -1 : pose.jointMoving(ids[s]);
    for (int q = 0; q < kPerId; ++q) {
      const Best& b = best[s][q];
      if (add(g.indexToPhysical({double(b.i), double(b.j), double(b.k)}), joint)) ++(fixed ? out.fixedPoints : out.bonePoints);
    }
  }
  // Lattice samples on the bones of the joints: per cell of sampleStepMm (index-space cells),
  // the id's voxel nearest the cell's centre. Serial: one pass over the labels, few hits.
  if (o.sampleStepMm > 0) {
    const int64_t c[3] = {std::max<int64_t>(1, std::llround(o.sampleStepMm / sp.x)),
                          std::max<int64_t>(1, std::llround(o.sampleStepMm / sp.y)),
                          std::max<int64_t>(1, std::llround(o.sampleStepMm / sp.z))};
    const int64_t cx = (d.x + c[0] - 1) / c[0], cy = (d.y + c[1] - 1) / c[1];
    std::vector<uint8_t> bone(65536, 0);
    for (uint16_t id : pose.boneIds())
      if (std::find(pose.fixed.ids.begin(), pose.fixed.ids.end(), id) == pose.fixed.ids.end()) bone[id] = 1;
    std::map<std::pair<uint16_t, int64_t>, Best> cells;  // ordered: deterministic point order
    for (int64_t k = 0; k < d.z; ++k)
      for (int64_t j = 0; j < d.y; ++j)
        for (int64_t i = 0; i < d.x; ++i) {
          const uint16_t id = labels(i, j, k);
          if (!bone[id]) continue;
          const int64_t a = i / c[0], b = j / c[1], e = k / c[2];
          const double dx = (double(i) - (double(a * c[0]) + 0.5 * double(c[0] - 1))) * sp.x;
          const double dy = (double(j) - (double(b * c[1]) + 0.5 * double(c[1] - 1))) * sp.y;
          const double dz = (double(k) - (double(e * c[2]) + 0.5 * double(c[2] - 1))) * sp.z;
          const double d2 = dx * dx + dy * dy + dz * dz;
          Best& best = cells[{id, (e * cy + b) * cx + a}];
          if (d2 < best.d2) best = {d2, i, j, k};
        }
    for (const auto& [key, b] : cells)
      if (add(g.indexToPhysical({double(b.i), double(b.j), double(b.k)}), pose.jointMoving(key.first))) ++out.bonePoints;
  }
  // Fixed boxes: their corners and centre, clipped to the volume's box.
  const Vec3 lo = g.indexToPhysical({0, 0, 0}), hi = g.indexToPhysical({double(d.x - 1), double(d.y - 1), double(d.z - 1)});
  for (const auto& b : pose.fixed.boxesMm) {
    Vec3 a{std::min(b[0], b[3]), std::min(b[1], b[4]), std::min(b[2], b[5])};
    Vec3 c{std::max(b[0], b[3]), std::max(b[1], b[4]), std::max(b[2], b[5])};
    for (int k = 0; k < 3; ++k) {
      const double l = std::min(lo[k], hi[k]), h = std::max(lo[k], hi[k]);
      a[k] = std::clamp(a[k], l, h);
      c[k] = std::clamp(c[k], l, h);
    }
    for (int corner = 0; corner < 8; ++corner)
      if (add({(corner & 1) ? c.x : a.x, (corner & 2) ? c.y : a.y, (corner & 4) ? c.z : a.z}, -1)) ++out.fixedPoints;
    if (add((a + c) * 0.5, -1)) ++out.fixedPoints;
  }
  if (o.anchors > 0)
    for (const ControlPoint& p : boxControlPoints(g, o.anchors, o.anchorInset))
      if (add(p.source, -1)) ++out.anchorPoints;
  return out;
}

ControlPoints posedPoints(const PoseSamples& samples, const Pose& pose, const std::vector<double>& anglesDeg) {
  const std::vector<RigidTransform> t = jointTransforms(pose, anglesDeg);
  ControlPoints pts(samples.sources.size());
  for (size_t i = 0; i < pts.size(); ++i) {
    pts[i].source = samples.sources[i];
    const int j = samples.joint[i];
    pts[i].target = j < 0 ? samples.sources[i] : t[j].apply(samples.sources[i]);
  }
  return pts;
}

std::vector<std::optional<RigidTransform>> knownBodyTransforms(const Pose& pose, const RigidBodies& bodies,
                                                               const std::vector<double>& anglesDeg) {
  const std::vector<RigidTransform> t = jointTransforms(pose, anglesDeg);
  const std::vector<uint16_t> ids = pose.boneIds();
  std::vector<std::optional<RigidTransform>> out;
  for (const RigidBodies::Body& b : bodies.bodies()) {
    std::optional<RigidTransform> known;
    if (!b.fixed && !b.ids.empty() && contains(ids, b.ids.front())) {
      const int j = pose.jointMoving(b.ids.front());
      const RigidTransform f = j < 0 ? RigidTransform{} : t[static_cast<size_t>(j)];
      known = f.inverse();
    }
    out.push_back(known);
  }
  return out;
}

std::vector<FixedBoxCut> fixedBoxCuts(const Pose& pose, const LabelVolume& labels) {
  std::vector<FixedBoxCut> cuts;
  if (pose.fixed.boxesMm.empty()) return cuts;
  std::vector<uint8_t> moving(65536, 0);
  for (uint16_t id : pose.boneIds())  // an id both moved and fixed is refused by loadPose()
    if (pose.jointMoving(id) >= 0) moving[id] = 1;
  const Geometry& g = labels.geometry();
  const Dims d = g.dims;
  const uint16_t* ids = labels.ids().data();
  std::map<std::pair<size_t, uint16_t>, int64_t> count;
  std::mutex m;
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    std::map<std::pair<size_t, uint16_t>, int64_t> local;
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < d.y; ++j)
        for (int64_t i = 0; i < d.x; ++i) {
          const uint16_t id = ids[(k * d.y + j) * d.x + i];
          if (!moving[id]) continue;
          const Vec3 p = g.indexToPhysical({double(i), double(j), double(k)});
          for (size_t b = 0; b < pose.fixed.boxesMm.size(); ++b)
            if (insideFixedBox(pose.fixed.boxesMm[b], p)) {
              ++local[{b, id}];
              break;
            }
        }
    std::lock_guard lock(m);
    for (const auto& [key, n] : local) count[key] += n;
  });
  for (const auto& [key, n] : count) cuts.push_back({key.first, key.second, n});
  return cuts;
}

KeyframeTrack poseTrack(const PoseSamples& samples, const Pose& pose, double maxStepDeg) {
  if (!(maxStepDeg > 0)) throw Error("pose: the movie's angle step must be > 0");
  const KeyframeTrack& a = pose.angles;
  const size_t n = a.keyframes.size();
  KeyframeTrack out;
  out.interpolation = Interpolation::Linear;
  out.loop = a.loop;
  // Segment k runs from keyframe k for its duration (to k+1, or back to 0 when looping; the
  // last keyframe of a non-looping track is a hold).
  double t0 = 0;
  for (size_t k = 0; k < n; ++k) {
    const double dur = a.keyframes[k].durationS;
    const bool travels = k + 1 < n || a.loop;
    int pieces = 1;
    if (travels && dur > 0) {
      // The angles' largest variation over the segment, sampled finely (smooth paths overshoot).
      constexpr int kProbe = 32;
      std::vector<double> prev = pose.anglesAt(t0);
      double worst = 0;
      for (int s = 1; s <= kProbe; ++s) {
        const double ts = t0 + dur * s / kProbe;
        const std::vector<double> cur =
            (s == kProbe && k + 1 == n) ? pose.anglesAt(0) : pose.anglesAt(std::min(ts, a.totalDurationS()));
        for (size_t j = 0; j < cur.size(); ++j) worst = std::max(worst, std::abs(cur[j] - prev[j]) * kProbe);
        prev = cur;
      }
      pieces = std::max(1, static_cast<int>(std::ceil(worst / maxStepDeg)));
    }
    for (int p = 0; p < pieces; ++p) {
      Keyframe kf;
      kf.durationS = dur / pieces;
      kf.points = posedPoints(samples, pose, pose.anglesAt(t0 + dur * p / pieces));
      out.keyframes.push_back(std::move(kf));
    }
    t0 += dur;
  }
  out.validate();
  return out;
}

std::vector<JointMeasure> measureJoints(const std::vector<float>& mapMm, const Geometry& output,
                                        const LabelVolume& labels, const Pose& pose,
                                        const std::vector<double>& anglesDeg, int stride) {
  const Dims d = output.dims;
  if (mapMm.size() != static_cast<size_t>(d.voxelCount()) * 3) throw Error("measureJoints: map size mismatch");
  if (stride < 1) throw Error("measureJoints: stride must be >= 1");
  const std::vector<uint16_t> ids = pose.boneIds();
  std::vector<int> slot(65536, -1);
  for (size_t s = 0; s < ids.size(); ++s) slot[ids[s]] = static_cast<int>(s);
  const Geometry& src = labels.geometry();
  const Geometry::ToIndex toIndex = src.physicalToIndexMap();
  const Dims sd = src.dims;
  // Per id: sums of (source u, output v) pairs over the output voxels whose source lies in it.
  std::vector<RigidFitSums> sums(ids.size());
  std::vector<Vec3> centroidSum(ids.size(), Vec3{0, 0, 0});
  std::mutex m;
  const int64_t slabs = (d.z + stride - 1) / stride;
  parallelFor(slabs, [&](int64_t s0, int64_t s1) {
    std::vector<RigidFitSums> local(ids.size());
    for (int64_t sk = s0; sk < s1; ++sk) {
      const int64_t k = sk * stride;
      for (int64_t j = 0; j < d.y; j += stride)
        for (int64_t i = 0; i < d.x; i += stride) {
          const size_t at = static_cast<size_t>((k * d.y + j) * d.x + i) * 3;
          const Vec3 u{mapMm[at], mapMm[at + 1], mapMm[at + 2]};
          const Vec3 ui = toIndex(u);
          const int64_t a = std::llround(ui.x), b = std::llround(ui.y), c = std::llround(ui.z);
          if (a < 0 || b < 0 || c < 0 || a >= sd.x || b >= sd.y || c >= sd.z) continue;
          const int s = slot[labels(a, b, c)];
          if (s < 0) continue;
          local[s].add(u, output.indexToPhysical({double(i), double(j), double(k)}));
        }
    }
    std::lock_guard lock(m);
    for (size_t s = 0; s < ids.size(); ++s) sums[s].merge(local[s]);
  });
  const std::vector<RigidTransform> requested = jointTransforms(pose, anglesDeg);
  const auto group = [&](const std::vector<uint16_t>& g) {
    RigidFitSums all;
    for (uint16_t id : g) all.merge(sums[slot[id]]);
    return all;
  };
  std::vector<JointMeasure> out;
  for (size_t j = 0; j < pose.joints.size(); ++j) {
    const Joint& joint = pose.joints[j];
    JointMeasure mj;
    mj.name = joint.name;
    mj.requestedDeg = anglesDeg[j];
    const RigidFitSums child = group(joint.child), parent = group(joint.parent);
    mj.childSamples = static_cast<int64_t>(child.weight);
    mj.parentSamples = static_cast<int64_t>(parent.weight);
    const double nan = std::numeric_limits<double>::quiet_NaN();
    mj.achievedDeg = mj.childRotationErrorDeg = mj.childPositionErrorMm = mj.parentRotationDeg = nan;
    // Fewer than 4 samples do not pin a rotation down.
    if (mj.childSamples >= 4) {
      const RigidTransform fc = fitRigid(child);
      const RigidTransform& want = requested[j];
      mj.childRotationErrorDeg = rotationAngleDeg(fc.rotation.transposed() * want.rotation);
      const Vec3 c = child.source / child.weight;  // the child's centroid at rest
      mj.childPositionErrorMm = norm(fc.apply(c) - want.apply(c));
      if (mj.parentSamples >= 4) {
        const RigidTransform fp = fitRigid(parent);
        mj.parentRotationDeg = rotationAngleDeg(fp.rotation);
        // The joint's own turn: the child relative to the parent, about the rest axis.
        mj.achievedDeg = twistDeg(fp.rotation.transposed() * fc.rotation, normalized(joint.axisB - joint.axisA));
      }
    }
    out.push_back(mj);
  }
  return out;
}

}  // namespace vellum::deformation
