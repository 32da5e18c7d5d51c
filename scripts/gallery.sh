#!/usr/bin/env bash
# Remakes the figure gallery (docs/gallery.md and docs/images/gallery/*.png) from the built-in
# phantom and a real CT series, recording each figure's exact command next to it.
#
#   scripts/gallery.sh [CT_SERIES_DIR] [VELLUM_BINARY]
#
# CT_SERIES_DIR defaults to ../shared/data/ct-feet-vhf (the Visible Human Female feet, NLM);
# without it only the phantom figures are made. Scratch files go to a temporary folder that
# is removed at the end. Takes a few minutes on 2 cores.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
feet=${1:-$here/../shared/data/ct-feet-vhf}
vellum=${2:-$here/build/ui/vellum}
out=$here/docs/images/gallery
md=$here/docs/gallery.md
work=$(mktemp -d /tmp/vellum-gallery.XXXXXX)
trap 'rm -rf "$work"' EXIT
mkdir -p "$out"
[ -x "$vellum" ] || { echo "gallery.sh: $vellum: not built (cmake --build build)" >&2; exit 2; }

body=$work/body.md
: >"$body"
# run TITLE FIGURE CMD... : runs the command (vellum is "vellum" in the text), records it.
figure() {
  local title=$1 png=$2
  shift 2
  local shown="${*//$vellum/vellum}"
  shown="${shown//$work\//}"
  shown="${shown//$feet/ct-feet-vhf}"
  shown="${shown//$out\//}"
  echo "gallery: $title" >&2
  local t0=$SECONDS
  "$@" >/dev/null
  printf '### %s\n\n![%s](images/gallery/%s)\n\n```sh\n%s\n```\n(%d s on the machine that made it)\n\n' \
    "$title" "$title" "$png" "$shown" $((SECONDS - t0)) >>"$body"
}
step() {  # a preparation command, recorded without a figure
  local shown="${*//$vellum/vellum}"
  shown="${shown//$work\//}"
  shown="${shown//$feet/ct-feet-vhf}"
  "$@" >/dev/null
  printf '```sh\n%s\n```\n\n' "$shown" >>"$body"
}

echo "## The phantom (built in)" >>"$body"; echo >>"$body"
step "$vellum" phantom --size 128 --out "$work/knee.nrrd" --labels "$work/knee-labels.nrrd"
figure "Phantom: bone, lit (shadows and occlusion)" phantom-bone-lit.png \
  "$vellum" render "$work/knee.nrrd" --preset bone --shadows 1 --occlusion 1 --zoom 1.6 --size 640x640 --out "$out/phantom-bone-lit.png"
step "$vellum" shape "$work/knee.nrrd" --labels "$work/knee-labels.nrrd" --segment skin=1,2,3,4,5,6,7,8,9,10,11 \
  --segment muscle=2,3 --segment bone=4,5,6,7,8,9,10,11 --out "$work/knee-shape"
for preset in textbook pen x-ray; do
  figure "Phantom: $preset illustration" "phantom-$preset.png" \
    "$vellum" illustrate "$work/knee.nrrd" --shape "$work/knee-shape" --preset "$preset" --size 640x640 --fov 0 \
    --out "$out/phantom-$preset.png"
done
# The presets plate of docs/illustration-renderer.md (docs/images/illustration-presets.png).
figure "Phantom: the presets plate (textbook, pen, x-ray)" ../illustration-presets.png \
  "$vellum" illustrate "$work/knee.nrrd" --shape "$work/knee-shape" --preset textbook,pen,x-ray --plate --frame segments \
  --size 480x480 --azimuth 30 --elevation 20 --out "$out/../illustration-presets.png"

if [ -d "$feet" ]; then
  echo "## Real CT: Visible Human Female feet (NLM), 512×512×150, 1 mm" >>"$body"; echo >>"$body"
  view=(--zoom 3.2 --elevation 50 --azimuth 20)
  figure "Feet: bone, plain" feet-bone.png \
    "$vellum" render "$feet" --preset bone "${view[@]}" --size 768x768 --out "$out/feet-bone.png"
  figure "Feet: bone, lit (shadows and occlusion)" feet-bone-lit.png \
    "$vellum" render "$feet" --preset bone --shadows 1 --occlusion 1 "${view[@]}" --size 768x768 --out "$out/feet-bone-lit.png"
  figure "Feet: skin, lit" feet-skin-lit.png \
    "$vellum" render "$feet" --preset skin --shadows 1 --occlusion 1 "${view[@]}" --size 768x768 --out "$out/feet-skin-lit.png"
  # --open: a cord about 2 mm thick (200-400 HU) lies on each foot's skin from the ankle
  # round the toes (a positioning cord of the cadaver, not anatomy). Above air it is a ridge
  # on the skin, whose contour ran beside the skin outline as a second line along the right
  # foot's lateral border; above 200 HU it joins the bones (the heavy ink line along the left
  # foot in pen). An opening of 2 mm (skin) and 1 mm (bone, before its holes are filled)
  # removes it; the skin loses 0.3 % (after --remove-table), the bone 12 % (rough surface bits).
  step "$vellum" segment "$feet" --preset skin-air --open 2 --fill-holes-slices --label-id 1 --label-name skin --out "$work/skin.nrrd"
  # --min-island 2500 mm^3: a one-voxel-thin 1.9 cm^3 piece above 200 HU runs through all 150
  # slices beside the feet (not bone); thinner than a ray step, it drew a dotted grey band
  # inside the skin outline. Each foot's bones are one piece of ~200 cm^3 at this threshold.
  step "$vellum" segment "$feet" --lower 200 --upper 3071 --open 1 --fill-holes-slices --min-island 2500 \
    --into "$work/skin.nrrd" --label-id 2 --label-name bone --out "$work/labels.nrrd"
  step "$vellum" shape "$feet" --labels "$work/labels.nrrd" --segment skin=1,2 --segment bone=2 --remove-table --out "$work/feet-shape"
  for preset in textbook pen x-ray; do
    figure "Feet: $preset illustration" "feet-$preset.png" \
      "$vellum" illustrate "$feet" --shape "$work/feet-shape" --preset "$preset" --remove-table --size 768x768 --fov 0 \
      --labels --annotate --label-name "bone=Foot bones" --label-name "skin=Skin" --out "$out/feet-$preset.png"
  done
  step "$vellum" segment "$feet" --lower 250 --fill-holes-slices --split --out "$work/bones.nrrd"
  figure "Feet: bones split into objects (segment --split), one colour each" feet-split.png \
    "$vellum" render "$feet" --label-colours "$work/bones.nrrd" --label-blend 0.9 --preset bone "${view[@]}" --size 768x768 --out "$out/feet-split.png"
fi

{
  echo "# Gallery"
  echo
  echo "Made by \`scripts/gallery.sh\` (on $(date -u +%Y-%m-%d), $(git -C "$here" rev-parse --short HEAD)); every figure"
  echo "below is followed by the command that made it. Real CT: the Visible Human Project's female"
  echo "feet (US National Library of Medicine). Judged as figures in docs/styles.md and docs/lighting.md."
  echo
  cat "$body"
  # Judged by eye on the figures this script made (s17, s18); update it when a figure changes.
  cat <<'JUDGED'
## How the figures read, and what still falls short

- **The feet's cords.** A cord about 2 mm thick (200-400 HU) lies on each foot's skin from the
  ankle round the toes: the plain renders (`render`, bone and skin) show it, as they show
  everything in the CT, and `--split` makes it objects of its own (the thin coloured loops of
  the split figure). For the illustrations the masks are opened (`--open 2` on the skin,
  `--open 1` on the bone): it was a ridge on the skin whose contour ran beside the skin outline
  as a second line along the right foot's lateral border, and part of the "bone" (the heavy ink
  line along the left foot in `pen`). The price: the bone mask loses 12 % (414 to 365 cm³; rough
  surface bits), the skin 0.3 % once the table is removed (1486 to 1482 cm³).
- **Feet, textbook**: ivory bones, one continuous skin outline per foot. Short of a published
  plate: the rim where the volume cuts the legs is dotted (no ray samples beyond the box); the
  tarsal bones' inner facets stay smooth blobs where the 1 mm CT cannot separate them; the two
  labels sit close together on the right (both leaders reach the left foot). The skin outline
  is named and framed (an outline-only row counts as drawn since s17). This is also the user
  guide's feet figure (docs/user-guide.md points here: one figure, one set of commands; the
  guide's old copy showed the cord as a second skin line and a flat khaki bone).
- **Feet, pen**: bones in ink with cross-contour hatching in their shadows, tarsal joint lines
  and phalanx outlines, one skin outline. The knots of ink on rough bone (s17) were mostly
  silhouettes of its voxel-sized rough bits, and partly crease specks. Since s18 silhouette ink
  of a filled row (the bone; an outline-only skin keeps every line) fades for features under
  two voxels round (the distance one voxel before and after a line's
  closest approach along the ray curves as 1/radius; measured at the vertex, not at the
  samples, so lines do not break into stipple as a per-sample measure did), and the crease
  measure's inner probes are at least a voxel apart (they were half a line width plus half a
  pixel, 0.33 mm here, and sampled the voxel noise): [before | after
  crops](images/illustration-pen-creases.png) (left foot's lateral tarsus above: the heavy
  band and the knot below it lighter; right foot's tarsus below: fewer specks). Short: the
  rough patches still read busier than an illustrator's single outline; a bone thinner than a
  voxel gets no outline in `pen` (its fill is paper-white); the hatching planes follow the
  grid, not each bone's axis; the skin outline breaks for a few pixels in places (the left
  foot's lateral border).
- **Feet, x-ray**: translucent bones with glowing edges, no block artefacts. Fine.
- **Phantom, pen**: the skin's outline and the bones in ink, hatched by tone (the preset leaves
  muscle and fat out: the fallback row drew them as an opaque hatched cylinder). Short: the
  skin's outline stops at the volume's top and bottom (no cut line), scratchy crease marks
  where the mesh keeps faint terraces (the femur's top and condyles).
- **Phantom, textbook and x-ray**: textbook: ivory bones through translucent red muscle;
  x-ray: blue-white glow, no blocks. In both the skin's cut ends show as pale discs. The
  phantom's cartilage steps are in the phantom, not the renderer.
- **Thin structures**: they drew beaded mainly because of the distance field, not the march:
  exact distances at voxel centres lose a structure thinner than a voxel wherever it passes
  between two centres (trilinear interpolation never goes below the nearer one), so the
  visible part came and went with the grid's phase; a finer ray step made it worse (the
  coverage ramp is a step wide). `vellum shape` now gives the voxels on either side of such a
  valley minus half its chord (docs/shape.md, "Thin structures"): a 0.9 mm rod on a 1 mm grid
  went from 35 of 62 columns empty at a 0.1-voxel step (weakest column 0.31 at the default
  step) to full coverage along its length (0.57 at the default step; the rest of the variation
  is each ray's samples falling differently across the rod). These figures change little (their
  masks are opened, and the one-voxel sheet beside the feet goes with `--min-island 2500`); at
  1536 px the rough spurs on the left foot's lateral tarsus, grainy and broken before, are
  solid ([main | s18, textbook](images/illustration-thin-before-after.png)).

JUDGED
  # The cinematic figures: scripts/gallery-cinematic.sh makes them (about 15 minutes).
  echo 
  echo '## Cinematic (path traced)'
  echo 
  echo 'Made by `scripts/gallery-cinematic.sh` (not by this page'\''s script: about 15 minutes), the'
  echo 'commands and an illustrator'\''s judgement of each in [lighting.md](lighting.md#cinematic-gallery):'
  echo 'plain (left) next to cinematic (right): the phantom with `--quality cinematic --trace-scale 0.5'
  echo '--volume-shadows --exposure -0.5 --sky-light 0.35`, the feet with traced shadows (`--quality'
  echo 'cinematic`, 60 s). In short: the bone gains soft contact shadows in the joint spaces and loses'
  echo 'the CT speckle and the plastic highlights; skin is softer but loses its relief; soft tissue'
  echo 'stays grainy at these sample counts.'
  echo 
  echo '![feet: plain | cinematic, bone and skin](images/cinematic-feet.png)'
  echo 
  echo '![phantom: plain | cinematic, bone, skin, soft tissue](images/cinematic-phantom.png)'
  echo 
  echo 'The knee bend as a 30-frame cinematic movie, bones rigid, shadows following the bend:'
  echo '[images/cinematic-knee.mp4](images/cinematic-knee.mp4).'
} >"$md.tmp"
mv "$md.tmp" "$md"
echo "gallery: wrote $md and $(ls "$out" | wc -l) figures in $out" >&2
