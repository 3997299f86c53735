"""The converged references the accuracy harness measures against: two
sobol renders with different seeds per scene, cached in WORK/ref/ under
a hash of the scene's content and the settings; half the relative MSE
between the two is the noise a reference adds to every measurement."""

import hashlib
import json
import os

from common import fmt_e, fmt_t, log

REF_SEEDS = (1000001, 1000002)
REF_VERSION = "1"  # bump to invalidate every cached reference


def load_or_render(harness, sc):
    """Renders (or finds in the cache) the scene's two references."""
    # The key is the scene's content without its description, so that
    # rewording the description does not throw the references away.
    with open(sc["file"]) as f:
        scene = json.load(f)
    scene.pop("description", None)
    scene_bytes = json.dumps(scene, sort_keys=True).encode()
    logical = {"ref_version": REF_VERSION, "spp": sc["ref_spp"],
               "sampler": "sobol", "mode": "full",
               "sets": sorted(sc["ref_sets"].items())}
    h = hashlib.sha256(scene_bytes + json.dumps(logical, sort_keys=True)
                       .encode()).hexdigest()[:16]
    paths, seconds = [], []
    for seed in REF_SEEDS:
        path = os.path.join(harness.work, "ref", "ref-%s-%s-%d.exr"
                            % (sc["name"], h, seed))
        meta = path[:-4] + ".json"
        if os.path.exists(path) and os.path.exists(meta):
            with open(meta) as f:
                seconds.append(json.load(f)["seconds"])
            log("accuracy: [%s] reference seed %d cached (%s)"
                % (sc["name"], seed, os.path.basename(path)))
        else:
            log("accuracy: [%s] rendering reference seed %d at %d spp "
                "(cached for later runs)..." % (sc["name"], seed,
                                                sc["ref_spp"]))
            sets = dict(sc["ref_sets"])
            sets.update({"render.spp": str(sc["ref_spp"]),
                         "render.sampler": "sobol",
                         "render.seed": str(seed)})
            sets.update(harness.mode_sets("full"))
            tmp = path + ".tmp.exr"
            st = harness.render(sc["file"], tmp, sets)
            os.replace(tmp, path)
            with open(meta, "w") as f:
                json.dump({"seconds": st["seconds"], "stats": st,
                           "settings": logical, "seed": seed}, f)
            seconds.append(st["seconds"])
            log("accuracy: [%s] reference seed %d took %s"
                % (sc["name"], seed, fmt_t(st["seconds"])))
        paths.append(path)
    d = harness.diff(paths[0], paths[1])
    # Both references carry the same amount of noise, so relMSE(A, B)
    # is about twice what reference A adds to every measurement.
    ref = {"path": paths[0], "other": paths[1], "hash": h,
           "floor": d["relmse"] / 2, "grad_floor": d["grad_relmse"] / 2,
           "dssim_floor": d["dssim"] / 2, "seconds": seconds,
           "spp": sc["ref_spp"]}
    log("accuracy: [%s] reference noise (half the relMSE of the two "
        "seeds): %s" % (sc["name"], fmt_e(ref["floor"])))
    harness.refs[sc["name"]] = ref
    return ref
