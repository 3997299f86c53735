#!/bin/sh
# Prints one line per render of a fixed matrix: every shipped scene, every
# camera model, sampler, chromatic mode, plan/adaptive setting, thread
# count and a crop, each with the SHA-256 of the rendered EXR (stored
# uncompressed, so that the hash is of the pixels, not of the deflate
# coder that packed them).  Run it
# before and after a refactor and diff the outputs: a refactor must keep
# every line.  Usage: tools/pixel-hashes.sh [BUILD_DIR] > hashes.txt
# With KEEP=DIR in the environment the images stay there, named by line
# (tools/isa-matrix.sh compares them).
build=${1:-build}
bin="$build/lensray"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
n=0
r() {  # r SCENE NAME ARGS...: render small and print "name hash"
    scene=$1; name=$2; shift 2
    n=$((n + 1))
    out="$tmp/$n.exr"
    if "$bin" render "scenes/$scene.json" -o "$out" -q --compression none \
        --set render.width=96 --set render.height=64 "$@" 2>"$tmp/err"; then
        echo "$scene $name $(sha256sum < "$out" | cut -c1-16)"
        [ -z "$KEEP" ] || cp "$out" "$KEEP/$scene-$name.exr"
    else
        echo "$scene $name FAILED: $(head -c 200 "$tmp/err")"
    fi
}
for s in spheres cornell bunny bokeh chromatic bench accuracy-focus accuracy-defocus accuracy-chroma; do
    r $s default --set render.spp=8
    r $s depth --set render.spp=4 --set render.depth=true
    r $s full-1thread --set render.spp=8 --set render.plan=false --set render.adaptive=false --set render.threads=1
    r $s region-2thread --set render.spp=8 --set 'render.region=[17,9,80,51]' --set render.threads=2 --set render.tile_size=7
    for smp in grid jittered random sobol; do
        r $s "$smp" --set render.spp=6 --set render.sampler=$smp
        r $s "$smp-noplan" --set render.spp=5 --set render.sampler=$smp --set render.plan=false
    done
done
# Every camera model and chromatic mode on two scenes.
for s in spheres accuracy-defocus; do
    r $s pinhole --set render.spp=4 --set camera.model=pinhole
    for shape in disk square polygon; do
        r $s "thin-$shape" --set render.spp=16 --set camera.model=thinlens --set camera.aperture_radius=0.3 \
          --set camera.focus_distance=5 --set camera.aperture_shape=$shape --set camera.aperture_blades=5 \
          --set camera.aperture_rotation=10
    done
    r $s thin-anamorphic --set render.spp=16 --set camera.model=thinlens --set camera.aperture_radius=0.3 --set camera.focus_distance=5 --set camera.aperture_ratio=2
    r $s thin-fnumber --set render.spp=16 --set camera.model=thinlens --set camera.f_number=0.5 --set camera.focal_length_mm=50 --set camera.focus_distance=3
    r $s thin-autofocus --set render.spp=16 --set camera.model=thinlens --set camera.aperture_radius=0.2 --set 'camera.focus_on=[48,40]'
    r $s bracket --set render.spp=16 --set camera.model=bracket --set camera.focal_length=10 --set camera.aperture=0.4
    for mode in rgb spectral; do
      for fm in paper lensmaker; do
        r $s "thin-$mode-$fm" --set render.spp=16 --set camera.model=thinlens --set camera.aperture_radius=0.3 \
          --set camera.focal_length_mm=50 --set camera.focus_distance=5 \
          --set "camera.chromatic={\"mode\":\"$mode\",\"focal_model\":\"$fm\",\"amplify\":20}"
        r $s "bracket-$mode-$fm" --set render.spp=16 --set camera.model=bracket --set camera.focal_length=10 --set camera.aperture=0.4 \
          --set "camera.chromatic={\"mode\":\"$mode\",\"focal_model\":\"$fm\",\"amplify\":20}"
      done
    done
done
# The light side (lights, glints, an emission texture) and real lenses
# (the traced packets, 1 - R at each surface, the light side through the
# glass), small.
r night light-side --set render.spp=8
r sparkles glints --set render.spp=4 --set render.width=48 --set render.height=32
r textured textured --set render.spp=4
r night-lens real-lens-light-side --set render.spp=4
r lens-chart real-lens --set render.spp=2
r lens-bokeh real-lens-rgb --set render.spp=2
# Adaptive sampling's later rounds through a lens (a pixel's pilot is 16
# samples there, so the lines above never reach a second round).
r lens-chart real-lens-rounds --set render.spp=100
r lens-bokeh real-lens-rgb-rounds --set render.spp=100
# A lens with aspheres (Newton's method in the packets: rx_asph16.c).
r lens-chart real-lens-asphere --set render.spp=2 \
    --set 'camera.lens="zoom-nikkor-z-14-30mm-f4-at-14mm"'
# The orthographic camera (a model with its parameter in lr_camera's
# model block), path traced.
r cornell orthographic --set render.spp=4 --set camera.model=orthographic \
    --set camera.view_height=6 --set render.integrator=path
# The shipped scenes at their own size and samples, as make render/figures do.
for s in spheres chromatic bench; do
    n=$((n + 1))
    "$bin" render "scenes/$s.json" -o "$tmp/full$n.exr" -q --compression none && echo "$s as-shipped $(sha256sum < "$tmp/full$n.exr" | cut -c1-16)"
    [ -z "$KEEP" ] || cp "$tmp/full$n.exr" "$KEEP/$s-as-shipped.exr"
done
