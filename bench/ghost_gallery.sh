#!/bin/sh
# Renders docs/lenses.md's ghost pictures: a street light at night, 9.3
# degrees right of and 5.2 up from the axis (40 m out, 0.25 m across),
# through the shipped double Gauss at f/2.8 in chromatic rgb mode, ghosts
# true: with the default MgF2 coating (ghosts-mgf2.png), and bare
# (ghosts-bare.png) with the lamp 100 times dimmer, so that its ghosts
# (some 90 times brighter against the lamp) show at about the coated
# ones' level instead of saturating.  Then prints `lensray lens
# --ghosts`'s three brightest ghost paths for each coating, the numbers
# the pictures sit next to.  About 40 s of CPU in all (the main image, traced through the lens
# at every pixel in three colours, is most of it).
# Usage: bench/ghost_gallery.sh [LENSRAY] [OUTDIR]
set -eu
LR=${1:-build/lensray}
OUT=${2:-docs/figures}
mkdir -p "$OUT"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cat >"$tmp/street.json" <<'EOF'
{"description": "a street light at night through the double Gauss",
 "camera": {"model": "lens", "lens": "double-gauss-50",
  "position": [0, 1.6, 0], "look_at": [0, 1.6, -1], "up": [0, 1, 0],
  "sensor_width_mm": 36, "f_number": 2.8, "focus_distance": 30,
  "ghosts": true, "chromatic": {"mode": "rgb"}},
 "render": {"width": 240, "height": 160, "spp": 128},
 "background": 0,
 "materials": {"lamp": {"emission": [1e5, 8e4, 5e4]}},
 "objects": [{"type": "sphere", "center": [6.5, 5.2, -40], "radius": 0.25,
  "material": "lamp"}]}
EOF
echo "ghosts-mgf2: $("$LR" render "$tmp/street.json" -o "$OUT/ghosts-mgf2.png" \
    -q --stats)"
echo "ghosts-bare: $("$LR" render "$tmp/street.json" -o "$OUT/ghosts-bare.png" \
    -q --stats --set camera.coating=none \
    --set 'materials.lamp.emission=[1e3, 8e2, 5e2]')"
for c in mgf2 none; do
    "$LR" lens double-gauss-50 --ghosts --coating $c | python3 -c '
import json, sys
d = json.load(sys.stdin)
print("lensray lens double-gauss-50 --ghosts --coating %s: total_flux %.3g"
      % (sys.argv[1], d["total_flux"]))
for g in d["ghosts"][:3]:
    print("  surfaces %s: flux %.2g, rms radius %.1f mm"
          % (g["surfaces"], g["flux"], g["rms_radius_mm"]))
' $c
done
