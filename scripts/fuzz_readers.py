"""The long fuzz run (not part of the test suite): N mutants per reader of the command line, each
checked against the CLI contract (tests/fuzzing.py). Prints per reader the count of mutants, of
each exit code and of contract breaks grouped by site; saves one reproducer per site.

    .venv/bin/python scripts/fuzz_readers.py -n 10000 --out /tmp/fuzz [--readers rapid,urdf] [--seed 0]
    [--encodings]
"""

from __future__ import annotations

import argparse
import collections
import random
import resource
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from fuzzing import build_readers, cell_file_readers, check, mutate, program_readers, run_case  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("-n", type=int, default=1000, help="mutants per reader")
    parser.add_argument("--out", type=Path, required=True, help="work folder (seeds, cases, reproducers)")
    parser.add_argument("--readers", help="comma-separated reader names (default: all)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--budget-s", type=float, default=float("inf"), help="stop each reader after this time"
    )
    parser.add_argument("--encodings", action="store_true",
                        help="half the mutants get a byte-level change too (BOM, CRLF/CR, NUL, not UTF-8...)")
    parser.add_argument("--memory-gib", type=float, default=6.0, help="address-space cap of this process")
    args = parser.parse_args()
    cap = int(args.memory_gib * 2**30)
    resource.setrlimit(resource.RLIMIT_AS, (cap, cap))
    names = args.readers.split(",") if args.readers else None
    seeds = args.out / "seeds"
    quick = {**program_readers(seeds), **cell_file_readers(seeds)} if names else {}
    readers = quick if names and set(names) <= set(quick) else build_readers(seeds)
    names = names or list(readers)
    total_bad = 0
    for name in names:
        reader = readers[name]
        rng = random.Random(f"{args.seed}-{name}")
        codes = collections.Counter()
        sites: dict[str, int] = collections.Counter()
        start = time.monotonic()
        done = 0
        for _ in range(args.n):
            if time.monotonic() - start > args.budget_s:
                break
            target, data = mutate(reader, rng, args.encodings)
            case = args.out / "case" / name
            code, stderr = run_case(reader, target, data, case)
            codes[code] += 1
            done += 1
            problem = check(reader, target, data, case, code, stderr)
            if problem:
                if problem not in sites:
                    keep = args.out / "found" / f"{name}-{len(sites)}"
                    keep.mkdir(parents=True, exist_ok=True)
                    (keep / target).write_bytes(data)
                    (keep / "problem.txt").write_text(f"{problem}\n\n{stderr}")
                sites[problem] += 1
        total_bad += sum(sites.values())
        print(
            f"{name}: {done} mutants in {time.monotonic() - start:.0f} s, "
            f"exit codes {dict(sorted(codes.items()))}, "
            f"{sum(sites.values())} contract breaks at {len(sites)} site(s)",
            flush=True,
        )
        for problem, count in sites.most_common():
            print(f"  {count:5d}  {problem}", flush=True)
    return 1 if total_bad else 0


if __name__ == "__main__":
    sys.exit(main())
