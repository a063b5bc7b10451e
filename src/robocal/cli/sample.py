"""``robocal sample [NAME ...]``: copy the small files the how-to pages start from."""

from __future__ import annotations

import argparse
from pathlib import Path


def add_parser(sub) -> None:
    p = sub.add_parser("sample", help="copy a sample file shipped with robocal (a program, a calibration...)",
                       description="Without NAME: the sample files shipped with robocal, each with what it "
                                   "is. With NAME(s): copy them into the current folder (or -o FILE for one "
                                   "sample); an existing file is not overwritten.",
                       epilog="Examples:\n  robocal sample\n  robocal sample weld_cell.mod\n"
                              "  robocal sample calibration.conf -o ur5e.conf",
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("names", nargs="*", metavar="NAME", help="the samples to copy")
    p.add_argument("-o", "--out", type=Path, help="where to write the sample (one NAME only)")
    p.set_defaults(func=run)


def run(args) -> int:
    from robocal.core.errors import DataError
    from robocal.demo import copy_sample, samples

    if not args.names:
        listed = samples()
        width = max(map(len, listed))
        print("\n".join(f"{name:<{width}}  {text}" for name, text in listed.items()))
        return 0
    if args.out is not None and len(args.names) != 1:
        raise DataError("-o names one file: give one NAME with it")
    for name in args.names:
        print(f"wrote {copy_sample(name, args.out or Path.cwd()).name}")
    return 0
