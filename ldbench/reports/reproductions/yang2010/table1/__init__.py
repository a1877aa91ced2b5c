"""yang2010-table1: linked-list OIT against depth peeling and dual depth peeling, and the first n layers
(Table 1, §4.1.3, Fig. 4(a)). Its suite is ``suite.toml`` beside this file; the paper and its published frame
rates: :mod:`ldbench.reports.reproductions.yang2010`."""
from __future__ import annotations

from ldbench.reports.reproduce import Claim, Reproduction
from ldbench.reports.reproductions.yang2010 import F4, HAIRBALL, ms


#: Table 1's dual against single depth peeling on the dragon, 94 / 45 fps: the gain 1.09 within a factor 2
DDP = (1 + (94 / 45 - 1) / 2, 1 + (94 / 45 - 1) * 2)

_T1 = "Table 1, HD 5770, 512×512"


def _cap(n: int, fps: float, **extra) -> dict:
    label = "all layers (64)" if n == 0 else f"first {n} layers"
    return {"id": f"cap-{n or 'all'}", "label": f"linked list, {label} ({fps:g} fps)",
            "paper_setup": f"{F4}, {'all' if n == 0 else n} of up to 64 layers",
            "match": {"scene": "hairball", "method": "ll-oit", "effect": "oit", "params": {"max_layers": n},
                      "scene_params": HAIRBALL},
            "time_ms": ms(fps), **extra}


REPRODUCTION = Reproduction(
    key="yang2010-table1",
    paper="yang2010",
    title="Linked-list OIT vs depth peeling and dual depth peeling; first n layers (Table 1, §4.1.3)",
    source="Table 1 and §4.1.3; Fig. 4(a) for the layer cap",
    hardware="ATI Radeon HD 5770 (Table 1; dual depth peeling scaled from a GTX 280); HD 5870 (Fig. 4)",
    resolution="512x512",
    paper_scene="a teapot and the Stanford dragon (Table 1); the mecha, up to ~64 layers (Fig. 4)",
    rows=(
        {"id": "teapot-ll", "label": "teapot, linked list (743 fps)", "paper_setup": _T1,
         "match": {"scene": "teapot", "method": "ll-oit", "effect": "oit", "params": {"max_layers": 0}},
         "time_ms": ms(743)},
        {"id": "teapot-dp", "label": "teapot, depth peeling (579 fps)", "paper_setup": _T1,
         "match": {"scene": "teapot", "method": "depth-peeling", "effect": "oit"}, "time_ms": ms(579)},
        {"id": "teapot-ddp", "label": "teapot, dual depth peeling (N/A)", "paper_setup": f"{_T1} (not published)",
         "match": {"scene": "teapot", "method": "dual-depth-peeling", "effect": "oit"}},
        {"id": "dragon-ll", "label": "dragon, linked list (338 fps)", "paper_setup": _T1,
         "match": {"scene": "transparent_dragon", "method": "ll-oit", "effect": "oit", "params": {"max_layers": 0}},
         "time_ms": ms(338)},
        {"id": "dragon-dp", "label": "dragon, depth peeling (45 fps)", "paper_setup": _T1,
         "match": {"scene": "transparent_dragon", "method": "depth-peeling", "effect": "oit"}, "time_ms": ms(45)},
        {"id": "dragon-ddp", "label": "dragon, dual depth peeling (94 fps)", "paper_setup": f"{_T1} (from a GTX 280)",
         "match": {"scene": "transparent_dragon", "method": "dual-depth-peeling", "effect": "oit"},
         "time_ms": ms(94)},
        _cap(0, 112),
        _cap(2, 165),
        _cap(4, 160),
        _cap(8, 153, psnr=13.5),
        _cap(16, 143),
        _cap(32, 129),
    ),
    claims=(
        Claim("Teapot: the linked list is faster than depth peeling", "teapot-ll", "teapot-dp", ("time_ms",),
              "less", where="Table 1"),
        Claim("Dragon: the linked list is faster than depth peeling", "dragon-ll", "dragon-dp", ("time_ms",),
              "less", where="Table 1"),
        Claim("Dragon: the linked list is faster than dual depth peeling", "dragon-ll", "dragon-ddp", ("time_ms",),
              "less", where="Table 1"),
        Claim(f"Dragon: dual depth peeling is about twice as fast as depth peeling (94 vs 45 fps = 2.09×: "
              f"{DDP[0]:.2f}–{DDP[1]:.2f}×)", "dragon-dp", "dragon-ddp", ("time_ms",), "ratio",
              ratio=(round(DDP[0], 2), round(DDP[1], 2)), where="Table 1 (dual depth peeling from a GTX 280, "
              "scaled by 1/1.23)", published="22.22 / 10.64 ms (45 vs 94 fps) = 2.09×",
              why="Table 1's 94 / 45 fps = 2.09×, a gain of 1.09; a published ratio with no tolerance is its "
                  "effect within a factor 2 (docs/reference/reports.md): 1 + 1.09 / 2 = 1.54× to 1 + 1.09 × 2 = 3.18×; "
                  "Bavoil & Myers' pass count bounds it near 2× (each pass peels two layers)",
              reason="on an H200 (docs/reference/methods/oit.md, 'Why dual depth peeling is not faster here'): about half the "
                     "passes, but each shades every fragment still to peel into three 32-bit float targets "
                     "with MAX blending, where a depth-peeling pass writes one depth-tested target"),
        Claim("The gap grows with depth complexity: depth peeling's time over the linked list's is larger on the "
              "dragon than on the teapot", "dragon-dp", "dragon-ll", ("time_ms",), "gap", c="teapot-dp",
              d="teapot-ll", where="Table 1; §2 'performance decreases as the number of depth layers increases'"),
        *(Claim(f"Fig. 4(a): the frame time grows with the layers displayed: {n} layers are faster than {m}",
                f"cap-{n}", f"cap-{m}", ("time_ms",), "less",
                where="Fig. 4(a) (average frame rates 165, 160, 153, 143, 129, 112 fps for 2 … 64 layers)",
                why="direction only: consecutive rows of Fig. 4(a)'s table; the sizes are the first-8 claim below")
          for n, m in ((2, 4), (4, 8), (8, 16), (16, 32), (32, "all"))),
        Claim("Rendering only the first 8 layers is almost 36 % faster than all layers", "cap-all", "cap-8",
              ("time_ms",), "ratio", ratio=(1.18, 1.73),
              where="§4.1.3 'rendering only the first 8 layers is almost 36% faster than rendering all layers'",
              published="112 vs 153 fps (Fig. 4(a)): all layers take 1.37× the time of 8",
              why="'almost 36 % faster' = Fig. 4(a)'s 153 / 112 fps = 1.37× the frame rate, i.e. all layers "
                  "take 1.37× the time of the first 8; the gain (0.37) within a factor 2 either way: 1.18–1.73×"),
        Claim("…at a loss of accuracy: the first 8 layers are only 13.5 dB PSNR from all 64", "cap-8", "cap-8",
              ("psnr",), "within", ratio=(10.5, 16.5), where="§4.1.3 'the peak signal-to-noise ratio between "
              "rendering all 64 layers and only the first 8 layers is only 13.5 dB'",
              published="13.5 dB between the first 8 and all 64 layers",
              why="13.5 dB ± 3 dB, i.e. the mean squared error within a factor 2 of the paper's; against the "
                  "all-layer composite a PSNR is always finite only with a loss, so the size is the claim",
              reason="our stand-in's tubes have opacity 0.3: the first 8 layers pass at most 0.7^8 = 5.8 % of the "
                     "light of the layers behind, so the 8-layer image differs from all layers by at most 5.8 % "
                     "of the image's peak, PSNR ≥ 24.8 dB, whatever the view. The paper's 13.5 dB needs layers that let "
                     "through about a fifth of the light after 8 of them (opacity ≤ 0.18); the mecha's opacity is "
                     "not published",
              # Paper scale only: §4.1.3 measures the loss on a view with "almost 64 layers" at 1280×720; what
              # 8 of them lose depends on how many lie beyond the 8th, and ci's 6,000-triangle hairball at
              # 64×64 has far fewer layers than the 60,000-triangle stand-in for the mecha.
              scales=("paper",)),
    ),
    scales={"paper": {},
            "ci": {"size": "64x64", "warmup": 1, "frames": 3,
                   "scene_params": {"hairball": {"triangles": 6000}, "teapot": {"segments": 16}}}},
    notes=(
        "Times are 1000 / fps of the published frame rates; Table 1 is normalized to an HD 5770, the layer "
        "cap comes from an HD 5870 at 1280×720: only comparisons within our run get verdicts.",
        "Colour is unlit albedo with one opacity per surface (ldbench/core/effects/oit.py); the opaque floor and "
        "walls of the dragon scene are fragments of opacity 1 in the same lists (the paper renders opaque "
        "objects first with a depth test).",
        "Our teapot is procedural (the paper's teapot model is not specified); the dragon is the Stanford "
        "dragon's 202,520-triangle reconstruction (the paper's view is 'comparable', its model size not given).",
        "The mecha is not public: a 60,000-triangle hairball at opacity 0.3 (up to ~70 layers per pixel, like "
        "the mecha's 'almost 64') stands in for the layer cap; its PSNR is against the exact reference, which "
        "equals all layers (so 'all layers are more accurate' cannot fail: the claims test the sizes, 36 % "
        "and 13.5 dB). How much 8 layers lose depends on the stand-in's opacity and layer count.",
        "Settings that differ from the paper (beyond the scenes): unlit albedo with one opacity per surface, "
        "opaque surfaces inside the lists, no MSAA; the layer cap is timed on our hairball at Fig. 4's "
        "1280×720, not over the mecha sequence.",
        "Not implemented: Precalc [Mic10] (285 / 143 fps), bucket depth peeling (256 fps on the dragon), MSAA.",
    ),
)
