#!/usr/bin/env python3
"""Rerun what makes a page of the book's Results part, as configs/results/pages.toml lists it.

    cargo build --release
    python3 scripts/results.py nightly              # its batches, then their provenance lines
    python3 scripts/results.py nightly --dry-run    # print the commands only
    python3 scripts/results.py --list               # the pages and what makes each

Each batch runs `mapbench run CONFIG --out reports/results/<page>/<config stem> --no-history`
with the entry's `--only`, `--repeat` and `--jobs`, and each other command runs as written,
from the repository's root. Then every batch's line of `mapbench provenance` is printed: the
date, revision, config, runs and wall time, machine and calibration to put under the page's
table, all read from the batch's meta.json. A page that needs the shared corpus says so when
MAPBENCH_MESHES is not set. Exit 1 when a command failed (a batch whose runs failed, exit 1
of `mapbench run`, still prints its provenance). Standard library only.
"""

import argparse
import os
import shlex
import subprocess
import sys
import tomllib

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MANIFEST = os.path.join(ROOT, "configs", "results", "pages.toml")


def load(path=MANIFEST):
    """The pages of the manifest, by name, each checked for the keys this script reads."""
    with open(path, "rb") as f:
        doc = tomllib.load(f)
    pages = {}
    for page in doc.get("page", []):
        name = page.get("name")
        if not name or name in pages:
            raise ValueError(f"{path}: a [[page]] without a name, or named twice ({name!r})")
        unknown = set(page) - {"name", "shared", "batch", "command"}
        if unknown:
            raise ValueError(f"{path}: page {name}: unknown keys {sorted(unknown)}")
        for batch in page.get("batch", []):
            extra = set(batch) - {"config", "only", "repeat", "jobs"}
            if "config" not in batch or extra:
                raise ValueError(f"{path}: page {name}: a batch needs `config` (and only only/repeat/jobs): {batch}")
        for command in page.get("command", []):
            if set(command) != {"run"} or not command["run"]:
                raise ValueError(f"{path}: page {name}: a command is `run = [argv...]`: {command}")
        if not page.get("batch") and not page.get("command"):
            raise ValueError(f"{path}: page {name}: nothing makes it (no batch, no command)")
        pages[name] = page
    return pages


def batch_out(out, page, batch):
    """Where a batch of a page writes: <out>/<page>/<config stem>[-<n>] (n when a config runs twice)."""
    stem = os.path.splitext(os.path.basename(batch["config"]))[0]
    return os.path.join(out, page["name"], stem)


def batch_argv(mapbench, out_dir, batch):
    """The `mapbench run` command of one batch, writing into out_dir."""
    argv = [mapbench, "run", batch["config"], "--out", out_dir, "--no-history"]
    for glob in batch.get("only", []):
        argv += ["--only", glob]
    if "repeat" in batch:
        argv += ["--repeat", str(batch["repeat"])]
    if "jobs" in batch:
        argv += ["--jobs", str(batch["jobs"])]
    return argv


def plan(pages, name, mapbench, out):
    """Every command of a page, in order: its batches, then its other commands."""
    page = pages[name]
    outs = [batch_out(out, page, b) for b in page.get("batch", [])]
    if len(set(outs)) != len(outs):
        # two batches of one config: number them
        outs = [f"{o}-{i + 1}" for i, o in enumerate(outs)]
    argvs = [batch_argv(mapbench, o, b) for b, o in zip(page.get("batch", []), outs)]
    argvs += [list(c["run"]) for c in page.get("command", [])]
    return argvs, outs


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("page", nargs="?", help="a page of docs/src/results (its file name without .md)")
    parser.add_argument("--list", action="store_true", help="list the pages and what makes each")
    parser.add_argument("--dry-run", action="store_true", help="print the commands, run nothing")
    parser.add_argument("--out", default="reports/results", help="where the batches write (default: %(default)s)")
    parser.add_argument("--mapbench", default="target/release/mapbench", help="the binary (default: %(default)s)")
    args = parser.parse_args(argv)
    os.chdir(ROOT)
    pages = load()
    if args.list or not args.page:
        for name, page in pages.items():
            argvs, _ = plan(pages, name, args.mapbench, args.out)
            print(f"{name}{' (shared corpus)' if page.get('shared') else ''}")
            for a in argvs:
                print("    " + shlex.join(a))
        return 0 if args.list else 2
    if args.page not in pages:
        print(f"no page {args.page!r} in {MANIFEST}; pages: {', '.join(pages)}", file=sys.stderr)
        return 2
    page = pages[args.page]
    if page.get("shared") and not os.environ.get("MAPBENCH_MESHES"):
        print(f"{args.page}: its batches name shared meshes; set MAPBENCH_MESHES (e.g. ../shared/meshes, "
              "or `mapbench corpus fetch`) or their runs are skipped", file=sys.stderr)
    argvs, outs = plan(pages, args.page, args.mapbench, args.out)
    failed = False
    for a in argvs:
        print("$ " + shlex.join(a), flush=True)
        if args.dry_run:
            continue
        code = subprocess.call(a)
        # `mapbench run` exits 1 when a run failed: the batch is whole and its page shows it
        if code != 0 and not (a[:2] == [args.mapbench, "run"] and code == 1):
            print(f"exit {code}: {shlex.join(a)}", file=sys.stderr)
            failed = True
    if outs and not args.dry_run:
        done = [o for o in outs if os.path.exists(os.path.join(o, "meta.json"))]
        if done:
            subprocess.call([args.mapbench, "provenance", *done])
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
