"""Calibration of the doubt warnings (holecli.robust.doubts): their numbers on clean and on triggered scenes.

Runs the scenes of benchmarks/realistic.py (``--seeds`` per class) and the clouds of sample_clouds/,
records the numbers each hole's warnings are judged on (:class:`holecli.robust.doubts.Doubts`), and
prints per class their range and how many holes get each warning with the default thresholds.

Run:  python benchmarks/doubts.py [--seeds 4] [--classes through,...] [--files a.ply,b.csv]
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

import holecli.robust.assemble as assemble  # noqa: E402
from holecli.vocabulary import DOUBT_CODES  # noqa: E402

RECORDED = []
_original = assemble.doubt_warnings


def _recording(doubts, settings):
    warnings = _original(doubts, settings)
    RECORDED.append((doubts, [w.code for w in warnings]))
    return warnings


assemble.doubt_warnings = _recording


def _ratios(d):
    """The numbers against their scales, as the thresholds read them."""
    return {
        "rim_points": d.rim_points,
        "rim_gap_deg": d.rim_gap_deg,
        "inside_frac": d.inside_points / max(d.inside_expected, 1e-300),
        "inside_pts": d.inside_points,
        "surf_sigmas": float("nan") if d.surface_rms is None else d.surface_rms / max(d.height_noise, 1e-300),
        "surf_spacings": float("nan") if d.surface_rms is None else d.surface_rms / d.spacing,
        "border_radii": d.border_gap / d.radius,
        "arc_deg": d.arc_deg,
        "bias_spacings": float("nan") if d.bias_correction is None else abs(d.bias_correction) / d.spacing,
        "bias_diam": float("nan") if d.bias_correction is None else abs(d.bias_correction) / (2 * d.radius),
        "rms_gaps": d.fit_rms / d.gap,
        "fringe_gaps": d.hidden_fringe / d.gap,
    }


def report(name, recorded):
    codes = Counter(code for _, cs in recorded for code in cs if code in DOUBT_CODES)
    rows = [_ratios(d) for d, _ in recorded]
    print(f"{name:<16} holes {len(recorded):3d}  fired: "
          + (", ".join(f"{c} {n}" for c, n in sorted(codes.items())) or "none"))
    if rows:
        for key in rows[0]:
            values = np.array([r[key] for r in rows], dtype=float)
            values = values[np.isfinite(values)]
            if len(values):
                print(f"    {key:<14} min {values.min():9.4g}  median {np.median(values):9.4g}  max {values.max():9.4g}")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=4)
    parser.add_argument("--classes", default=None)
    parser.add_argument("--files", default=None, help="comma-separated clouds (default: sample_clouds/*)")
    args = parser.parse_args(argv)
    import realistic
    from holecli.pipeline import detect_file

    classes = realistic.CLASSES if args.classes is None else args.classes.split(",")
    for kind in classes if args.classes != "" else ():
        RECORDED.clear()
        for seed in range(args.seeds):
            realistic.measure(kind, seed)
        report(kind, list(RECORDED))
    files = sorted(p for p in (ROOT / "sample_clouds").iterdir() if p.suffix in (".ply", ".csv", ".pcd", ".xyz")) \
        if args.files is None else [Path(f) for f in args.files.split(",") if f]
    for path in files:
        RECORDED.clear()
        detect_file(str(path))
        report(path.name[:16], list(RECORDED))


if __name__ == "__main__":
    main()
