#!/usr/bin/env bash
# The real-CT pose bench of docs/benchmarks-deformation.md: plantar flexion of the right foot of
# ct-feet-vhf (512×512×150) by 20° about a hand axis (--axis-hint: the axis the motion search
# places near it, the pose's "axis_hint"), the left foot still. Makes the label map
# (one id per bone, soft tissue 100) and the pose file from the scan, then (unless --no-run)
# poses it and prints the report's key numbers.
#   scripts/feet-pose-bench.sh [OUT_DIR] [--no-run] [--axis-hint] [-- extra `vellum pose` arguments]
# Environment: VELLUM (default build/ui/vellum), CT (default the shared ct-feet-vhf series).
# Writes OUT_DIR/{bones.nrrd, bones-named.nrrd, labels.nrrd, feet-flex.json, pose.nrrd,
# pose.json, time.txt}. Ids: docs/benchmarks-segmentation.md, "s18 feet labels".
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
V=${VELLUM:-$here/build/ui/vellum}
CT=${CT:-$here/../shared/data/ct-feet-vhf}
out=${1:-/tmp/feet-pose-bench}
shift || true
run=1
hint=0
if [ "${1:-}" = "--no-run" ]; then run=0; shift; fi
if [ "${1:-}" = "--axis-hint" ]; then hint=1; shift; fi
[ "${1:-}" = "--" ] && shift
mkdir -p "$out"
cd "$out"

if [ ! -f labels.nrrd ]; then
  # Bones: one id per bone (the cord on the skin removed first), then the right hindfoot's pieces
  # made whole bones (s18: tibia 10+22, fibula 18, talus body 9 + head 16, calcaneus 2+19+32+34,
  # navicular 25+26+27).
  "$V" segment "$CT" --lower 250 --close 2 --fill-holes-slices --split --split-fill --split-open-joints \
      --split-joint-contrast 120 --split-joint-width 4 --split-neck 3 --split-thin 1.5 \
      --out bones.nrrd --report bones.json > /dev/null
  "$V" labels bones.nrrd --out bones-named.nrrd --report bones-named.json \
      --assign 10,22=60 --assign 18=61 --assign 9,16=62 --assign 2,19,32,34=63 --assign 25,26,27=64 \
      --name 60="right tibia" --name 61="right fibula" --name 62="right talus" \
      --name 63="right calcaneus" --name 64="right navicular" > /dev/null
  # Soft tissue of both feet (not the table) around the bones.
  "$V" segment "$CT" --preset skin-air --fill-holes-slices --keep-largest \
      --seed 199,243,63 --seed 297,232,86 --into bones-named.nrrd --overlap keep-existing \
      --label-id 100 --label-name "soft tissue" --out labels.nrrd > /dev/null
fi

# The pose: the right foot's bones (centre x < 247 mm) turn with the talus, the tibia and fibula
# stay, the left foot's bones and the box x >= 253 mm are fixed.
python3 - bones-named.json "$hint" > feet-flex.json <<'PY'
import json, sys
after = json.load(open(sys.argv[1]))["after"]
hand = [[190, 285, 112], [230, 285, 112]]  # x through (·, 285, 112) mm, placed by eye (s16)
parent = [60, 61]
right = [e["id"] for e in after if e["centre_mm"][0] < 247 and e["id"] not in parent]
left = [e["id"] for e in after if e["centre_mm"][0] >= 247]
pose = {"units": "mm",
        "joints": [{"name": "ankle", "parent": parent, "child": right,
                    **({"axis": "estimate", "axis_hint": hand} if sys.argv[2] == "1" else {"axis": hand})}],
        "fixed_labels": left,
        "fixed_boxes": [[253, 0, 0, 511, 511, 149]],
        "interpolation": "smooth",
        "keyframes": [{"duration": 1.5, "angles": {"ankle": 0}}, {"duration": 1.5, "angles": {"ankle": 20}}]}
print(json.dumps(pose, indent=1))
PY

((run)) || exit 0
/usr/bin/time -f "wall %e user %U sys %S rss %M" -o time.txt \
    "$V" pose "$CT" --labels labels.nrrd --pose feet-flex.json --pad-mm -1 \
    --out pose.nrrd --report pose.json --force "$@"
cat time.txt
python3 - pose.json <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
a = r["deform"]["rigidity"]["after"]
print(f"folds in tissue {100 * a['fold_fraction']:.5f} % of {a['tissue_samples']} (min det J {a['min_jacobian']:.4f} "
      f"at {a['min_jacobian_at_mm']} mm)")
print(f"bone RMS {a['bone_rms_residual_mm']:.3f} mm (max {a['bone_max_residual_mm']:.2f}); fixed regions moved max "
      f"{a['fixed']['max_displacement_mm']} mm, their content shown elsewhere {a['fixed']['content_moved_elsewhere_samples']}")
names = {60: "tibia", 61: "fibula", 62: "talus", 63: "calcaneus", 64: "navicular"}
for b in a["bodies"]:
    if b["ids"][0] in names:
        print(f"  {names[b['ids'][0]]}: RMS {b['rms_residual_mm']:.3f} mm, max {b['max_residual_mm']:.2f}, "
              f"turned {b['rotation_deg']:.2f} deg")
for j in r["deform"].get("twist", {}).get("joints", []):
    print(f"  twist {j['name']}: soft rim voxels {j['softened_bone_voxels']}, collisions {j['collision_voxels']}")
PY
