#!/usr/bin/env python3
"""test_docs_help: every command's --help agrees with docs/GUIDE.md.

Runs `edgefuse --help`, `edgefuse <command> --help` for every command it lists (and the variants
`fuse --sensors`, `eval poses`, `eval segments`) and `edgefused --help`, and fails when the guide
lacks a section for a command or an option that a --help prints.

usage: docs_help.py EDGEFUSE EDGEFUSED GUIDE.md
"""
import re
import subprocess
import sys


def help_text(argv):
    r = subprocess.run(argv, capture_output=True, text=True, timeout=30)
    if r.returncode != 0:
        raise SystemExit(f"{' '.join(argv)}: exit {r.returncode}\n{r.stderr}")
    return r.stdout


def main():
    edgefuse, edgefused, guide_path = sys.argv[1:4]
    guide = open(guide_path, encoding="utf-8").read()
    top = help_text([edgefuse, "--help"])
    commands = re.findall(r"^  ([a-z]+) ", top, re.M)
    if len(commands) < 5:
        raise SystemExit(f"edgefuse --help lists too few commands:\n{top}")
    calls = [[c] for c in commands] + [["fuse", "--sensors", "x"], ["eval", "poses"], ["eval", "segments"]]
    missing = []
    for c in commands:
        if not re.search(rf"^##+ `edgefuse {c}`", guide, re.M):
            missing.append(f"no section '## `edgefuse {c}`' for the command {c}")
    helps = [(f"edgefuse {' '.join(c)} --help", help_text([edgefuse] + c + ["--help"])) for c in calls]
    helps.append(("edgefused --help", help_text([edgefused, "--help"])))
    if not re.search(r"^##+ `edgefused`", guide, re.M):
        missing.append("no section '## `edgefused`'")
    checked = 0
    for name, text in helps:
        for opt in sorted(set(re.findall(r"(?<![\w-])--[a-z][a-z0-9-]*", text))):
            checked += 1
            if not re.search(rf"(?<![\w-]){re.escape(opt)}(?![\w-])", guide):
                missing.append(f"{name} prints {opt}, docs/GUIDE.md does not mention it")
    if missing:
        print("\n".join(missing))
        print(f"docs/GUIDE.md disagrees with --help ({len(missing)} findings): add the options to the guide")
        return 1
    print(f"docs/GUIDE.md covers {len(commands)} commands and edgefused, {checked} options of {len(helps)} --help texts")
    return 0


if __name__ == "__main__":
    sys.exit(main())
