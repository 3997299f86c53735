#!/bin/sh
# Renders the gallery's figures into docs/figures/ (run by `make figures`).
# Each figure is one command line below, so any of them can be re-run or
# tweaked by hand.  Usage: docs/figures.sh [LENSRAY] [OUTDIR]
set -eu
LR=${1:-build/lensray}
OUT=${2:-docs/figures}
mkdir -p "$OUT"

n=0
fig() {
    name=$1
    shift
    n=$((n + 1))
    printf 'figures: [%2d] %s\n' "$n" "$name"
    "$LR" render "$@" -o "$OUT/$name.png" -q
}

# The paper's figure 4: a focal sweep of the bunny with the bracket method,
# unjittered (grid) like the paper's, focal plane at di + f = 5, 9, 15, 23.
for f in 4 8 14 22; do
    fig "sweep-f$f" scenes/bunny.json \
        --set render.width=400 --set render.height=300 --set render.spp=16 \
        --set render.sampler=grid --set camera.model=bracket \
        --set camera.image_plane_distance=1 --set camera.focal_length=$f \
        --set camera.aperture=0.4
done

# Figure 5: grid (the paper's unjittered method) against jittered, same rays.
for s in grid jittered; do
    fig "bunny-$s" scenes/bunny.json \
        --set render.width=400 --set render.height=300 --set render.spp=16 \
        --set render.sampler=$s --set camera.model=bracket \
        --set camera.focal_length=8 --set camera.aperture=0.6
done

# Figures 6 and 7: axial chromatic aberration on distant objects, the
# paper's indices as they are, then exaggerated; and without, to compare.
fig chroma-off scenes/chromatic.json --set camera.chromatic.mode=off \
    --set camera.aperture=0.5
fig chroma-true scenes/chromatic.json --set camera.chromatic.amplify=1 \
    --set camera.aperture=0.5
fig chroma-x50 scenes/chromatic.json --set camera.chromatic.amplify=50 \
    --set camera.aperture=0.5

# Spectral against rgb: the same 50 mm f/1.4 thin lens with BK7 glass,
# 3x the true dispersion, through the lensmaker's equation.
lens="--set camera.model=thinlens --set camera.focal_length_mm=50 \
      --set camera.f_number=1.4 --set camera.focus_distance=30"
# shellcheck disable=SC2086
fig chroma-rgb scenes/chromatic.json $lens --set render.spp=128 \
    --set 'camera.chromatic={"mode": "rgb", "focal_model": "lensmaker", "amplify": 3, "ior": [1.51432, 1.51680, 1.52238]}'
# shellcheck disable=SC2086
fig chroma-spectral scenes/chromatic.json $lens --set render.spp=128 \
    --set 'camera.chromatic={"mode": "spectral", "focal_model": "lensmaker", "amplify": 3, "glass": "BK7", "wavelengths": 8}'

# Bokeh: the aperture's shape in the out-of-focus highlights.
fig bokeh-disk scenes/bokeh.json --set camera.aperture_shape=disk
fig bokeh-hexagon scenes/bokeh.json --set camera.aperture_shape=polygon \
    --set camera.aperture_blades=6
fig bokeh-triangle scenes/bokeh.json --set camera.aperture_shape=polygon \
    --set camera.aperture_blades=3 --set camera.aperture_rotation=90
fig bokeh-square scenes/bokeh.json --set camera.aperture_shape=square \
    --set camera.aperture_rotation=45
fig bokeh-anamorphic scenes/bokeh.json --set camera.aperture_shape=disk \
    --set camera.aperture_ratio=0.5

# The row of spheres: pinhole, then thin lens focused on the third sphere.
fig spheres-pinhole scenes/spheres.json
fig spheres-thinlens scenes/spheres.json --set camera.model=thinlens \
    --set camera.aperture_radius=0.2 --set camera.focus_distance=16.5 \
    --set render.spp=64
fig cornell scenes/cornell.json --set render.spp=64


# glTF (docs/gltf.md): a scene written by tests/gltf_writer.py (textured
# floor and crates, a gold sphere, small lamps far behind), lit by a dusk
# sky (docs/gltf-sky.py), path traced through the file's own camera (a
# thin lens: 85 mm f/1.4 focused on the sphere, from its extras), then
# the same view through the double Gauss at its widest; the lamps turn
# into bokeh, round through the thin lens, cat's eyes at the real lens's
# edges.
G=$(mktemp -d)
python3 tests/gltf_writer.py gallery "$G/gallery.glb"
python3 docs/gltf-sky.py "$G/sky.exr"
fig gltf-thinlens "$G/gallery.glb" --set render.width=600 --set render.spp=192 \
    --set 'environment={"file": "sky.exr"}'
cat >"$G/lens.json" <<'EOF2'
{"camera": {"model": "lens", "lens": "double-gauss-50"},
 "render": {"width": 600, "height": 400, "spp": 192, "integrator": "path"},
 "environment": {"file": "sky.exr"},
 "objects": [{"type": "gltf", "file": "gallery.glb", "camera": true}]}
EOF2
fig gltf-lens "$G/lens.json"
rm -rf "$G"

# Real lenses (docs/lenses.md): a checkerboard 10 m away (100 m for the
# telephoto) through the fisheye, the wide angle and the telephoto.
fig lens-chart-fisheye scenes/lens-chart.json --set camera.lens=fisheye-10 \
    --set camera.sensor_width_mm=24 --set render.width=480 --set render.height=480
fig lens-chart-wide scenes/lens-chart.json --set camera.lens=wide-22
fig lens-chart-tele scenes/lens-chart.json --set camera.lens=telephoto-250 \
    --set camera.position='[0, 0, 100]' --set camera.focus_distance=100
# Lateral colour: the telephoto's top-right corner, spectral, at full size.
fig lens-fringe-tele scenes/lens-chart.json --set camera.lens=telephoto-250 \
    --set camera.position='[0, 0, 100]' --set camera.focus_distance=100 \
    --set render.width=1440 --set render.height=960 --set render.spp=128 \
    --set 'render.region=[1200, 0, 1440, 160]' \
    --set 'camera.chromatic={"mode": "spectral", "wavelengths": 8}'
fig lens-fringe-tele-off scenes/lens-chart.json --set camera.lens=telephoto-250 \
    --set camera.position='[0, 0, 100]' --set camera.focus_distance=100 \
    --set render.width=1440 --set render.height=960 --set render.spp=128 \
    --set 'render.region=[1200, 0, 1440, 160]'
# Bokeh across the frame: the double Gauss wide open (cat's eyes at the
# edges) and at f/4 (round everywhere); the Petzval's swirl.
fig lens-bokeh-f2 scenes/lens-bokeh.json --set render.spp=512
fig lens-bokeh-f4 scenes/lens-bokeh.json --set render.spp=512 --set camera.f_number=4
fig lens-bokeh-petzval scenes/lens-bokeh.json --set render.spp=512 \
    --set camera.lens=petzval
# Focus breathing: the chart 30 m away through the double Gauss at f/16,
# focused at 30 m and at 0.4 m (unit focusing moves the lens out 8 mm:
# the view narrows, the chart's squares grow).
fig lens-breathe-far scenes/lens-chart.json --set camera.lens=double-gauss-50 \
    --set camera.position='[0, 0, 30]' --set camera.focus_distance=30 --set camera.f_number=16
fig lens-breathe-near scenes/lens-chart.json --set camera.lens=double-gauss-50 \
    --set camera.position='[0, 0, 30]' --set camera.focus_distance=0.4 --set camera.f_number=16
# Textures (scenes/textured.json, images from scenes/make-textures.py):
# a tiled floor, a lat-long map on a sphere, roughness in bands on metal,
# and an emission texture that lights the scene; path traced.
fig textured scenes/textured.json --set render.spp=256
# The orthographic camera: the spheres row from above and to the side, a
# view 9 units tall; every sphere keeps its size at any distance.
fig spheres-orthographic scenes/spheres.json --set camera.model=orthographic \
    --set camera.view_height=9 --set 'camera.position=[-12, 9, -4]' \
    --set 'camera.look_at=[0, 0.5, -20]' --set render.spp=64

echo "figures: $n images in $OUT"
