"""docs/img/crease-cornell.png: LDM AO along the Cornell box's creases, the plain skip rule (crease = 0)
against the crease window (crease = 0.5 texels), with the Mitsuba reference and |error| maps.

    python scripts/figures/crease.py [OUT.png]       (llvmpipe is enough: 128², 128 LDMs of 128²)
"""
import sys

import numpy as np

from ldbench.core.effects import Effect
from ldbench.core.gpu import Gpu
from ldbench.core.scenes import load_scene
from ldbench.methods.base import View
from ldbench.methods.ldm import Ldm, LdmParams
from ldbench.references import render_reference


def main(out="docs/img/crease-cornell.png", size=128):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scene, eff = load_scene("cornell"), Effect("ao")
    ref = render_reference(scene, eff, width=size, height=size, spp=256, progress=False)
    gpu = Gpu()
    imgs = {}
    for crease in (0.0, 0.5):
        m = Ldm(LdmParams.from_dict({"directions": 128, "resolution": 128, "trace.crease": crease}))
        m.setup(gpu, scene)
        imgs[crease] = m.frame(View(scene.camera, size, size), eff).resolve().image[..., 0]
        m.release()
    gpu.release()
    r = ref.mean[..., 0]
    fig, ax = plt.subplots(2, 3, figsize=(9, 6.3))
    ax[0, 0].imshow(r, cmap="gray", vmin=0, vmax=1)
    ax[0, 0].set_title("Mitsuba reference (256 spp)", fontsize=9)
    for j, c in enumerate((0.0, 0.5), start=1):
        e = np.abs(imgs[c] - r) * ref.mask
        n = int((e[ref.mask] > 0.3).sum())
        ax[0, j].imshow(imgs[c], cmap="gray", vmin=0, vmax=1)
        ax[0, j].set_title(f"ldm, crease = {c:g} texels", fontsize=9)
        ax[1, j].imshow(e, cmap="magma", vmin=0, vmax=0.5)
        ax[1, j].set_title(f"|error| (0 … 0.5): {n} pixels > 0.3", fontsize=9)
    ax[1, 0].axis("off")
    ax[1, 0].text(0.0, 0.5, "classic AO, cornell, 128²\n128 LDMs of 128²\nllvmpipe", fontsize=9, va="center")
    for a in ax.ravel():
        a.set_xticks([])
        a.set_yticks([])
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")


if __name__ == "__main__":
    main(*sys.argv[1:2])
