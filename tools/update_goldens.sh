#!/usr/bin/env bash
# Regenerates the rendering goldens in tests/golden/ with `vigil render` (left and right colour
# of the shipped scenarios at fixed times) and records the Mesa version they were made with in
# tests/golden/README.md. Run after an intended change to the renderer or the scenes, or after
# a Mesa/LLVM upgrade, then look at the images before committing them.
#   tools/update_goldens.sh [path/to/vigil]   (default: build/tools/vigil)
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
vigil="${1:-$here/build/tools/vigil}"
[ -x "$vigil" ] || { echo "update_goldens: no vigil binary at $vigil (build first or pass its path)" >&2; exit 2; }
golden="$here/tests/golden"
mkdir -p "$golden"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT

# scenario camera time(s) stem -- keep in step with tests/render_test.cpp (ShippedScenariosMatchGoldens)
cases=(
  "dis_left_bag cam_corridor 12 dis_left_bag_cam_corridor_t12"
  "dis_lab_unauthorised cam_lab 10 dis_lab_unauthorised_cam_lab_t10"
)
for c in "${cases[@]}"; do
  read -r scenario camera t stem <<<"$c"
  out="$tmp/$stem"
  line="$("$vigil" render "$here/scenarios/$scenario.yaml" --camera "$camera" --at "$t" --out "$out")"
  renderer="${line#*written to * (}"; renderer="${renderer%)}"
  cp "$out/left_000000.png" "$golden/${stem}_left.png"
  cp "$out/right_000000.png" "$golden/${stem}_right.png"
  echo "updated $golden/${stem}_{left,right}.png"
done

mesa="$(dpkg-query -W -f='${Version}' libosmesa6 2>/dev/null || echo unknown)"
cat >"$golden/README.md" <<MD
# Rendering goldens

Left and right colour images (640x480 PNG) of the shipped scenarios at fixed times, rendered by
the OSMesa stereo renderer (plugins/stereo_camera) and compared by tests/render_test.cpp
(ShippedScenariosMatchGoldens) within a tolerance: mean absolute difference under 2 grey levels
and 99% of pixels within 16.

| file stem | scenario | camera | time |
|---|---|---|---|
| dis_left_bag_cam_corridor_t12 | scenarios/dis_left_bag.yaml | cam_corridor | 12 s |
| dis_lab_unauthorised_cam_lab_t10 | scenarios/dis_lab_unauthorised.yaml | cam_lab | 10 s |

Made with: libosmesa6 ${mesa}, GL_RENDERER \`${renderer}\` (the LLVM version and the SIMD
width both change the pixels).

Rendered images depend on the Mesa and LLVM versions (llvmpipe's rasterisation and shader code
generation), so these goldens are pinned to the Debian packages above; the analytic checks in
the same test file (depth, projection, disparity, labels) do not depend on them. After an
intended change, or on another Mesa, regenerate with

    tools/update_goldens.sh [build/tools/vigil]

and look at the images before committing them.

Output formats of \`vigil render\`: left/right 8-bit BGR PNG; depth 16-bit PNG in millimetres
(0 = no surface); disparity 16-bit PNG holding disparity * 256 (as KITTI; 0 = invalid); labels
16-bit PNG (0 = background and static structure, then robots, people and objects in scenario
order; labels.txt maps them to entity ids).
MD
echo "wrote $golden/README.md (libosmesa6 $mesa)"
