# A focus sweep and an f-number sweep with lensray from Python (docs/python.md;
# `make figures` runs it with SWEEPS_PNG=docs/figures/python-sweeps.png).
import os

import matplotlib.pyplot as plt
import numpy as np

import lensray

# A table-top scene in metres: six 5 cm balls from 0.4 m to 2.8 m away,
# seen through a 50 mm lens on a full-frame sensor (24 mm high: the
# vertical field of view is 2 atan(12 / 50) = 27 degrees).
distances = [0.4, 0.6, 0.9, 1.3, 1.9, 2.8]
colours = [[0.8, 0.15, 0.1], [0.9, 0.6, 0.1], [0.2, 0.7, 0.2],
           [0.1, 0.4, 0.8], [0.6, 0.2, 0.7], [0.85, 0.85, 0.85]]
scene_doc = {
    "camera": {"model": "thinlens", "position": [0, 0.12, 0], "look_at": [0, 0.05, -1],
               "fov": 27, "focal_length_mm": 50, "f_number": 2, "focus_distance": 1},
    "render": {"width": 240, "height": 160, "spp": 64},
    "background": [0.6, 0.7, 0.85],
    "materials": {"table": {"diffuse": [0.55, 0.5, 0.45]},
                  **{f"ball{i}": {"diffuse": c, "specular": 0.3, "shininess": 80}
                     for i, c in enumerate(colours)}},
    "objects": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0], "material": "table"}]
             + [{"type": "sphere", "center": [0.12 * (i - 2.5) * d / 1.5, 0.05, -d], "radius": 0.05,
                 "material": f"ball{i}"} for i, d in enumerate(distances)],
    "lights": [{"type": "point", "position": [1, 2, 1], "intensity": 6},
               {"type": "ambient", "radiance": 0.15}],
}
scene = lensray.load(scene_doc)

# Which pixels show which ball: the Z channel of the scene without the
# table, rendered once through a pinhole.
balls_only = lensray.load({**scene_doc, "objects": scene_doc["objects"][1:]})
_, z = balls_only.render(camera={"model": "pinhole"}, render={"spp": 1}, depth=True)
masks = [np.abs(z - d) < 0.06 for d in distances]

def sharpness(rgb, mask):
    """Mean gradient of luminance over one ball's pixels: falls with blur."""
    lum = rgb @ np.array([0.2126, 0.7152, 0.0722], dtype=np.float32)
    gy, gx = np.gradient(lum)
    return float(np.hypot(gx, gy)[mask].mean())

# Focus sweep at f/2: each ball is sharpest when the focus is at its distance.
focus = np.geomspace(0.25, 4, 16)
focus_imgs = [scene.render(camera={"focus_distance": s}) for s in focus]
focus_sharp = np.array([[sharpness(img, m) for m in masks] for img in focus_imgs])

# f-number sweep focused on the 0.9 m ball: stopping down sharpens the rest.
f_numbers = [1.4, 2, 2.8, 4, 5.6, 8, 11, 16]
f_imgs = [scene.render(camera={"f_number": n, "focus_distance": 0.9}) for n in f_numbers]
f_sharp = np.array([[sharpness(img, m) for m in masks] for img in f_imgs])

def show(ax, img, title):
    ax.imshow(np.clip(img, 0, 1) ** (1 / 2.2))  # linear to display, roughly
    ax.set_title(title, fontsize=9)
    ax.axis("off")

fig = plt.figure(figsize=(11, 8.5), layout="constrained")
top, middle, bottom = fig.subfigures(3, 1, height_ratios=[1, 1, 1.6])
for ax, i in zip(top.subplots(1, 4), [2, 7, 11, 13]):
    show(ax, focus_imgs[i], f"f/2, focus {focus[i]:.2f} m")
for ax, i in zip(middle.subplots(1, 4), [0, 2, 4, 7]):
    show(ax, f_imgs[i], f"f/{f_numbers[i]:g}, focus 0.9 m")
left, right = bottom.subplots(1, 2)
for k, d in enumerate(distances):
    c = colours[k]
    left.plot(focus, focus_sharp[:, k] / focus_sharp[:, k].max(), color=c, label=f"ball at {d} m")
    left.axvline(d, color=c, linestyle=":", linewidth=1)
    right.plot(f_numbers, f_sharp[:, k] / f_sharp[:, k].max(), "o-", color=c, label=f"{d} m")
left.set(xscale="log", xlabel="focus distance (m)", ylabel="sharpness (1 = the ball's best)",
         title="focus sweep at f/2: each ball peaks at its distance")
right.set(xscale="log", xlabel="f-number", title="f-number sweep, focused at 0.9 m")
left.set_xticks([0.25, 0.5, 1, 2, 4], ["0.25", "0.5", "1", "2", "4"], minor=False)
right.set_xticks(f_numbers, [f"{n:g}" for n in f_numbers])
left.minorticks_off()
right.minorticks_off()
left.legend(fontsize=8)
fig.savefig(os.environ.get("SWEEPS_PNG", "sweeps.png"), dpi=80)
