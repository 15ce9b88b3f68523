"""Automatic parameters against the best of the paper's sweeps, on generated scene variants.

    python bench/bench_auto.py [--seed 2026]

Prints a Markdown table: z(R) with the automatic choice, with the fixed defaults, and the
best z(R) of the four one-factor sweeps (42 runs per variant), and whether each lands within
1.1 x best + 0.001 (see geostructure.testing.autocheck).
"""

import argparse
import time
import warnings

from geostructure.testing.autocheck import TOLERANCE, VARIANTS, check_variant


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--seed", type=int, default=2026)
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    print(f"seed {args.seed}; pass: z <= 1.1 x best + {TOLERANCE}\n")
    print(
        "| scene | z(R) auto | z(R) fixed defaults | best z(R) of the sweeps | auto within | defaults within | auto's choice |"
    )
    print("|---|---|---|---|---|---|---|")
    for name in VARIANTS:
        t = time.perf_counter()
        c = check_variant(name, args.seed)
        print(
            f"| {name} | {c.z_auto:.2g} ({c.found_auto}/6) | {c.z_default:.2g} ({c.found_default}/6) | {c.z_best:.2g} | "
            f"{'yes' if c.auto_ok else 'NO'} | {'yes' if c.default_ok else 'no'} | {c.choice.removeprefix('auto: ')} |",
            flush=True,
        )
        print(f"<!-- {name}: {time.perf_counter() - t:.0f} s -->", flush=True)


if __name__ == "__main__":
    main()
