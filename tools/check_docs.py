#!/usr/bin/env python3
"""The docs hold together: every chapter `docs/src/SUMMARY.md` names exists, every relative link
and image in the README, ARCHITECTURE.md and the book resolves to a file, and the README stays a
page a newcomer reads (at most 250 lines). Exit 1 naming each file, line and link that fails.

What `mdbook build docs` would add is the HTML; installing mdBook in CI (building it from
crates.io: minutes on two cores) costs more than this check, which catches what breaks a book."""

import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
README_MAX_LINES = 250
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")


def main():
    failures = []
    files = [ROOT / "README.md", ROOT / "ARCHITECTURE.md"] + sorted((ROOT / "docs/src").glob("*.md"))
    summary = ROOT / "docs/src/SUMMARY.md"
    if not summary.exists():
        failures.append("docs/src/SUMMARY.md: missing")
    for f in files:
        fence = False
        for n, line in enumerate(f.read_text().splitlines(), 1):
            if line.startswith("```"):
                fence = not fence
            if fence:
                continue
            for target in LINK.findall(line):
                if re.match(r"[a-z]+:", target) or target.startswith("#"):
                    continue
                path = (f.parent / target.split("#")[0]).resolve()
                if not path.exists():
                    failures.append(f"{f.relative_to(ROOT)}:{n}: link `{target}` resolves to nothing")
    lines = len((ROOT / "README.md").read_text().splitlines())
    if lines > README_MAX_LINES:
        failures.append(f"README.md: {lines} lines, more than {README_MAX_LINES}: move studies to docs/src")
    for f in failures:
        print(f)
    chapters = len(LINK.findall(summary.read_text())) if summary.exists() else 0
    print(f"docs: {len(files)} files, {chapters} chapters in SUMMARY.md, README {lines} lines, "
          f"{len(failures)} problems")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
