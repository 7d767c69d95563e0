"""`python -m learn.evaluate`: the command line of `learn.evaluate`."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from learn.evaluate import DEFAULT_PROTOCOLS, SHIFTS, controller_labels, evaluate, write_outputs
from learn.evaluate.protocols import __doc__ as PROTOCOLS_DOC
from learn.evaluate.results import Results
from learn.evaluate.training_seeds import parse_groups, seed_table
from learn.storage import output_directory
from mbc.errors import ConfigError


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m learn.evaluate", formatter_class=argparse.RawDescriptionHelpFormatter,
                                     description="Run the evaluation protocols on controllers.",
                                     epilog=PROTOCOLS_DOC + "\nShifts (--shifts):\n\n" + "\n".join(
                                         f"* `{s.name}`: {s.describe}" for s in SHIFTS.values()))
    parser.add_argument("--controllers", "--controller", nargs="+", default=None,
                        help="'mbc' or policy checkpoint paths (default: mbc, none with --groups)")
    parser.add_argument("--protocols", nargs="+", default=list(DEFAULT_PROTOCOLS), help="default: all of the paper's")
    parser.add_argument("--shifts", nargs="+", default=["nominal"], help=f"among {list(SHIFTS)} (default: nominal)")
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--workers", type=int, default=None, help="processes (default: every core)")
    parser.add_argument("--out", type=Path, default=None, help="directory for NAME.md, NAME.csv, results.json, *.png")
    parser.add_argument("--backend", choices=["process", "ray"], default="process",
                        help="worker processes on this machine, or tasks of a Ray cluster (default: process)")
    parser.add_argument("--groups", nargs="+", default=[], metavar="NAME=PATHS",
                        help="methods over training seeds: NAME=PATH[,PATH...] (globs allowed), one policy per training "
                             "seed, evaluated as --controllers; adds the table over training seeds (training_seeds.md)")
    parser.add_argument("--ray-address", default=None,
                        help="the Ray cluster to join with --backend ray ('auto' on one of its nodes; docs/cluster.md)")
    parser.add_argument("--from-results", nargs="+", type=Path, default=[], metavar="RESULTS_JSON",
                        help="run nothing: the tables of earlier runs' results.json files together (each training "
                             "seed evaluated as its run finished, say; a job in several files is the last one's); "
                             "--groups then names paths evaluated there")
    args = parser.parse_args(argv)
    try:
        if args.out is not None:
            output_directory(args.out, "--out")  # before the work, not after it
        groups = parse_groups(args.groups)
        if args.from_results:
            results = _load(args.from_results, groups)
            args.shifts = list(dict.fromkeys(r["shift"] for r in results.raw))
        else:
            named = args.controllers if args.controllers is not None else ([] if groups else ["mbc"])
            controllers = list(dict.fromkeys(named + [p for paths in groups.values() for p in paths]))
            results = evaluate(controllers, args.protocols, args.seeds, args.workers, args.shifts, progress=True,
                               backend=args.backend, ray_address=args.ray_address)
    except ConfigError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    print(results.table())
    for shift in args.shifts:
        print(f"\n### At a glance ({shift})\n\n{results.summary(shift)}")
    for shift in args.shifts if groups else ():
        print(f"\n### Over training seeds ({shift})\n\n{seed_table(results, groups, shift)}")
    if args.out is not None:
        written = write_outputs(results, args.out)
        if groups:
            path = args.out / "training_seeds.md"
            path.write_text("\n\n".join(f"### {shift}\n\n{seed_table(results, groups, shift)}" for shift in args.shifts) + "\n")
            written.append(path)
        print(f"\nwrote {len(written)} files to {args.out}")
    return 0


def _load(files: list[Path], groups: dict[str, list[str]]) -> Results:
    """The merged results of `files`, every path of `groups` among their controllers."""
    parts = []
    for file in files:
        try:
            parts.append(Results.from_json(file.read_text()))
        except (OSError, ValueError, KeyError) as error:
            raise ConfigError(f"{file} is not a results.json of learn.evaluate ({error})") from error
    results, replaced = Results.merged(parts, controller_labels)
    if replaced:
        print(f"{replaced} jobs are in several of {[str(f) for f in files]}: each one's figures are the last file's")
    evaluated = {r["path"] for r in results.raw}
    missing = [p for paths in groups.values() for p in paths if p not in evaluated]
    if missing:
        raise ConfigError(f"not evaluated in {[str(f) for f in files]}: {missing}")
    return results


if __name__ == "__main__":
    sys.exit(main())
