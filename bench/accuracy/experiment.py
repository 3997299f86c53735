"""What the accuracy harness renders: the samplers, the four ways of
spending samples, the scenes with their ladders and references, the
colour models of the chroma scene (rgb mode set up to equal the spectral
lens at three wavelengths), and the facts of a scene file it reads."""

import json
import math

# ---- what is measured -------------------------------------------------------

SAMPLERS = ["grid", "jittered", "random", "sobol"]

# The four ways of spending samples.  "full" is the full simulation: lens
# and colours simulated in every pixel, spp samples everywhere.
MODES = [
    ("full", {"render.plan": "false", "render.adaptive": "false"}),
    ("plan", {"render.plan": "true", "render.adaptive": "false"}),
    ("adaptive", {"render.plan": "false", "render.adaptive": "true"}),
    ("plan+adaptive", {"render.plan": "true", "render.adaptive": "true"}),
]
MODE_NAMES = [m for m, _ in MODES]

POW2 = [1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1024]
SQUARES = [1, 4, 16, 64, 256, 1024]

# Each scene: its file, how far its ladders go (grid and jittered need
# square counts, so they get the squares up to the same maximum), and its
# references: two sobol renders with different seeds at ref_spp.
SCENES = [
    {
        "name": "focus",
        "file": "scenes/accuracy-focus.json",
        "title": "mostly in focus",
        "max_spp": 1024,
        "ref_spp": 8192,
        "ref_sets": {},
    },
    {
        "name": "defocus",
        "file": "scenes/accuracy-defocus.json",
        "title": "strongly defocused",
        "max_spp": 1024,
        "ref_spp": 8192,
        "ref_sets": {},
    },
    {
        "name": "chroma",
        "file": "scenes/accuracy-chroma.json",
        "title": "spectral chromatic aberration (8 wavelengths)",
        "max_spp": 128,
        "ref_spp": 512,
        # The reference sees the spectrum with 32 wavelengths per sample
        # (the ladders use the scene's 8): it stands for the continuous
        # spectrum, against which every wavelength count is judged.
        "ref_sets": {"camera.chromatic.wavelengths": "32"},
    },
]

# rgb against spectral on the chroma scene, sobol, each colour model with
# and without planning plus adaptive sampling.  The ladders are cut so
# that every model gets about the same render time at the top.
COLOUR_SCENE = "chroma"
COLOUR_MODELS = [
    ("rgb", None, 512),
    ("spectral-3", 3, 512),
    ("spectral-5", 5, 256),
    ("spectral-8", 8, 128),
    ("spectral-16", 16, 64),
]
COLOUR_MODES = ["full", "plan+adaptive"]

# The dominant wavelengths of the sRGB primaries (nm): rgb mode traces the
# glass at these three, with the lens and the sensor of the spectral
# render (see colour_sets()).
RGB_WAVELENGTHS = (611.3, 549.1, 464.3)


def ladder(sampler, max_spp):
    steps = SQUARES if sampler in ("grid", "jittered") else POW2
    return [n for n in steps if n <= max_spp]


def scene_wavelengths(path):
    with open(path) as f:
        chrom = json.load(f).get("camera", {}).get("chromatic", {})
    return chrom.get("wavelengths", 8) if chrom.get("mode") == "spectral" else None


def scene_size(path):
    with open(path) as f:
        r = json.load(f).get("render", {})
    return r.get("width", 640), r.get("height", 480)


# ---- rgb mode as three wavelengths of the spectral lens ---------------------

def sellmeier_sf11(nm):
    """SF11's index (Schott's Sellmeier coefficients, as lib/optics/lens.c)."""
    b = (1.73759695, 0.313747346, 1.89878101)
    c = (0.013188707, 0.0623068142, 155.23629)
    l2 = (nm / 1000.0) ** 2
    return math.sqrt(1 + sum(bi * l2 / (l2 - ci) for bi, ci in zip(b, c)))


def rgb_mode_sets(scene_file):
    """rgb mode made physically equal to the spectral render at three
    wavelengths.  The spectral thin lens has power P = 1000 / F at the d
    line and the sensor where the d line is sharp at s.  rgb mode's
    reference is green: so give it green's power, P (n_g - 1) / (n_d - 1)
    (lensmaker), with the aperture radius kept, and the focus distance at
    which green is sharp on that same sensor; red and blue then get
    exactly the spectral lens's power at their wavelengths."""
    with open(scene_file) as f:
        cam = json.load(f)["camera"]
    chrom = cam["chromatic"]
    assert chrom.get("glass") == "SF11" and chrom.get("focal_model") == "lensmaker"
    F = cam["focal_length_mm"]
    s = cam["focus_distance"]
    radius = F / 1000.0 / (2 * cam["f_number"])
    nd = sellmeier_sf11(587.5618)
    nr, ng, nb = (sellmeier_sf11(w) for w in RGB_WAVELENGTHS)
    P = 1000.0 / F
    a = (ng - 1) / (nd - 1)
    s_green = 1.0 / (1.0 / s + P * (a - 1))
    chromatic = {"mode": "rgb", "focal_model": "lensmaker",
                 "ior": [round(nr, 7), round(ng, 7), round(nb, 7)]}
    return {"camera.chromatic": json.dumps(chromatic),
            "camera.f_number": "0",
            "camera.aperture_radius": repr(radius),
            "camera.focal_length_mm": repr(F / a),
            "camera.focus_distance": repr(s_green)}
