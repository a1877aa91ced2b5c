"""Check ``ldbench score --test unbiased`` (ldbench.core.unbiased) on Mitsuba references and an unbiased
in-tree estimator, and draw its power figure (docs/img/unbiased_power.png).

    .venv/bin/python scripts/unbiased_check.py                 # table + figure (about a minute on 2 cores)
    .venv/bin/python scripts/unbiased_check.py --no-figure     # the table only

Table, for ``ao``, ``direct`` and ``indirect`` on ``cornell`` and ``atrium`` at the sizes and spp of the
suites (ao: 128×128, 256 spp as suites/default.toml; direct: 128×128, exact; indirect: 96×96, 1024 spp as
suites/niessner2010-indirect.toml and ldm-indirect-sweep.toml):

- seeds: the reference with seed 1 tested against the reference with seed 0 (must pass);
- biased: the seed-1 reference × 1.005 (a 0.5 % bias; must fail);
- mc-ao: for ``ao``, the brute-force Monte Carlo estimator through the rays oracle
  (:mod:`ldbench.references.mc_ao`, ldbench's own direction streams) against the reference (must pass).

Figure: the smallest relative bias (answer × (1 + b)) the test detects against spp, for ``indirect`` on
both scenes at 64×64 (seed-0 reference, seed-1 answer; b on a grid of 40 log-spaced values in 1e-4 … 1).
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from ldbench.core.effects import Effect
from ldbench.core.scenes import load_scene
from ldbench.core.unbiased import unbiased_test
from ldbench.references.mc_ao import render_mc_ao
from ldbench.references.render import render_reference

SCENES = (("cornell", {}), ("atrium", {"triangles": 20000}))
SUITE = {"ao": (128, 256), "direct": (128, 1), "indirect": (96, 1024)}
BIAS = 0.005


def _ref(scene, effect, size, spp, seed):
    return render_reference(scene, effect, width=size, height=size, spp=spp, cache=False, progress=False,
                            seed=seed)


def _n(spp):
    return spp if spp >= 2 else None


def table():
    print(f"{'scene':8} {'effect':9} {'check':7} {'verdict':7} {'unbiased_p':>10} {'rejected':>9} "
          f"{'p_family':>9} {'p_count':>9} {'p_mean':>9}")
    for name, sp in SCENES:
        scene = load_scene(name, **sp)
        for eff, (size, spp) in SUITE.items():
            e = Effect.parse(eff)
            r0, r1 = _ref(scene, e, size, spp, 0), _ref(scene, e, size, spp, 1)
            checks = {"seeds": (r1.mean, r1.variance, spp),
                      "biased": (r1.mean * (1 + BIAS), r1.variance * (1 + BIAS) ** 2, spp)}
            if eff == "ao":
                m, v, _ = render_mc_ao(scene, e, width=size, height=size, spp=spp, seed=5)
                checks["mc-ao"] = (m, v, spp)
            for check, (a, va, n) in checks.items():
                t = unbiased_test(a, va, r0.mean, r0.variance, n_answer=_n(n), n_reference=_n(spp))
                print(f"{name:8} {eff:9} {check:7} {t.verdict:7} {t.unbiased_p:10.3g} {t.rejected_fraction:9.4f} "
                      f"{t.p_family:9.3g} {t.p_count:9.3g} {t.p_mean:9.3g}", flush=True)


def smallest_detected(a, va, r, vr, n):
    """Smallest b of the grid with a failing verdict for a × (1 + b) (NaN: none)."""
    for b in np.logspace(-4, 0, 40):
        if unbiased_test(a * (1 + b), va * (1 + b) ** 2, r, vr, n_answer=n, n_reference=n).verdict == "fail":
            return float(b)
    return float("nan")


def figure(out: Path, size=64, spps=(16, 64, 256, 1024, 4096)):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5.2, 3.6), dpi=120)
    for name, sp in SCENES:
        scene = load_scene(name, **sp)
        e = Effect.parse("indirect")
        bs = []
        for spp in spps:
            r0, r1 = _ref(scene, e, size, spp, 0), _ref(scene, e, size, spp, 1)
            bs.append(smallest_detected(r1.mean, r1.variance, r0.mean, r0.variance, spp))
            print(f"power {name} indirect {size}x{size} spp={spp}: smallest detected bias {bs[-1]:.4g}", flush=True)
        ax.loglog(spps, bs, "o-", label=f"{name} indirect, {size}×{size}")
    ref_line = np.array(spps, float)
    ax.loglog(ref_line, bs[0] * np.sqrt(spps[0] / ref_line), "k:", label="∝ 1/√spp")
    ax.axhline(BIAS, color="grey", lw=0.8, ls="--")
    ax.set_xlabel("samples per pixel (answer and reference)")
    ax.set_ylabel("smallest detected relative bias")
    ax.set_title("score --test unbiased: power (α = 0.01)", fontsize=10)
    ax.legend(fontsize=8)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out)
    print(f"wrote {out}")


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--no-figure", action="store_true")
    p.add_argument("--no-table", action="store_true")
    p.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "docs" / "img" / "unbiased_power.png"))
    args = p.parse_args(argv)
    t0 = time.time()
    if not args.no_table:
        table()
    if not args.no_figure:
        figure(Path(args.out))
    print(f"({time.time() - t0:.0f} s)")


if __name__ == "__main__":
    main()
