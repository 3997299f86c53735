#!/bin/sh
# Renders docs/lenses.md's ghost pictures: a street light at night, 9.3
# degrees right of and 5.2 up from the axis (40 m out, 0.25 m across),
# through the shipped double Gauss at f/2.8 in chromatic rgb mode, ghosts
# true: with the default MgF2 coating (ghosts-mgf2.png; through the wide
# angle wide-22, ghosts-wide.png), and bare
# (ghosts-bare.png) with the lamp 100 times dimmer, so that its ghosts
# (some 90 times brighter against the lamp) show at about the coated
# ones' level instead of saturating.  Then prints `lensray lens
# --ghosts`'s three brightest ghost paths for each coating, the numbers
# the pictures sit next to.  Between them, a landscape with the sun just
# outside the frame (ghosts-landscape-mgf2.png, ghosts-landscape-bare.png).
# About 12 s of CPU for the street light and 35 s for the landscape
# (the main image, traced through the lens at every pixel in three
# colours, is most of it).
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
# The same lamp through the shipped wide angle, coated (ghosts-wide.png).
echo "ghosts-wide: $("$LR" render "$tmp/street.json" -o "$OUT/ghosts-wide.png" \
    -q --stats --set camera.lens=wide-22)"
# The landscape: late afternoon, the sun (bench/sun_sky.py's map: a disc
# 0.53 degrees across, 23 degrees right of -z and 8 up) just outside the
# frame's right edge (19.8 degrees), the double Gauss at f/8 focused at 60
# m, path traced, the same sun coated and bare.
python3 "$(dirname "$0")/sun_sky.py" "$tmp/sky.exr" 23 8
cat >"$tmp/land.json" <<'EOF'
{"description": "a landscape, the sun just outside the frame's right edge",
 "camera": {"model": "lens", "lens": "double-gauss-50",
  "position": [0, 1.7, 0], "look_at": [0, 2.5, -20], "up": [0, 1, 0],
  "sensor_width_mm": 36, "f_number": 8, "focus_distance": 60,
  "ghosts": true, "chromatic": {"mode": "rgb"}},
 "render": {"width": 240, "height": 160, "spp": 512, "integrator": "path"},
 "environment": {"file": "sky.exr"},
 "materials": {"grass": {"diffuse": [0.16, 0.24, 0.07]},
  "field": {"diffuse": [0.35, 0.3, 0.12]},
  "hill": {"diffuse": [0.18, 0.25, 0.1]},
  "far": {"diffuse": [0.3, 0.34, 0.4]},
  "tree": {"diffuse": [0.05, 0.12, 0.04]}},
 "objects": [
  {"type": "plane", "normal": [0, 1, 0], "material": "grass"},
  {"type": "plane", "point": [6, 0.01, -45], "normal": [0, 1, 0],
   "size": [30, 40], "material": "field"},
  {"type": "sphere", "center": [-150, -420, -1100], "radius": 480,
   "material": "far"},
  {"type": "sphere", "center": [260, -560, -1300], "radius": 620,
   "material": "far"},
  {"type": "sphere", "center": [-60, -150, -300], "radius": 170,
   "material": "hill"},
  {"type": "sphere", "center": [90, -200, -380], "radius": 220,
   "material": "hill"},
  {"type": "sphere", "center": [-14, 3.0, -60], "radius": 2.8,
   "material": "tree"},
  {"type": "sphere", "center": [-18, 2.4, -66], "radius": 2.2,
   "material": "tree"},
  {"type": "sphere", "center": [-10.5, 2.0, -70], "radius": 1.8,
   "material": "tree"},
  {"type": "sphere", "center": [16, 2.6, -85], "radius": 2.4,
   "material": "tree"},
  {"type": "sphere", "center": [4, 1.4, -40], "radius": 1.2,
   "material": "tree"}]}
EOF
echo "ghosts-landscape-mgf2: $("$LR" render "$tmp/land.json" \
    -o "$OUT/ghosts-landscape-mgf2.png" -q --stats)"
echo "ghosts-landscape-bare: $("$LR" render "$tmp/land.json" \
    -o "$OUT/ghosts-landscape-bare.png" -q --stats --set camera.coating=none)"
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
