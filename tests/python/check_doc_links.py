#!/usr/bin/env python3
"""Checks the relative links and images of the documentation (standard library only).

Every Markdown link `[text](target)` and image `![alt](target)` in README.md, CHANGELOG.md and
docs/**/*.md whose target is relative (no scheme such as https:, no mailto:) must name a file or
folder that exists, relative to the Markdown file; a `#anchor` into a Markdown file (or into the
file itself) must name one of its headings, slugged as GitHub does. Links inside code blocks and
inline code are not links. Prints every broken one as FILE:LINE: TARGET (reason) and exits 1 if
there is any, 0 otherwise.

Usage: python3 tests/python/check_doc_links.py [REPO_ROOT]
"""

import re
import sys
from pathlib import Path
from urllib.parse import unquote

LINK = re.compile(r"!?\[(?:[^\[\]]|\[[^\[\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
REF_DEF = re.compile(r"^\s{0,3}\[[^\]]+\]:\s*<?(\S+?)>?(?:\s+.*)?$")
FENCE = re.compile(r"^\s{0,3}(```|~~~)")
SCHEME = re.compile(r"^[a-zA-Z][a-zA-Z0-9+.-]*:")


def slug(heading: str) -> str:
    """GitHub's anchor for a heading: lower case, punctuation dropped, spaces to hyphens."""
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", heading)  # links keep their text
    text = re.sub(r"<[^>]+>", "", text)  # inline HTML
    text = text.strip().lower()
    text = re.sub(r"[^\w\- ]", "", text)  # keeps letters, digits, _ and - (Unicode aware)
    return text.replace(" ", "-")


def strip_code(line: str) -> str:
    """The line without its inline code spans."""
    return re.sub(r"(`+)(?:(?!\1).)*?\1", "", line)


def anchors(path: Path, cache: dict) -> set:
    if path not in cache:
        seen = {}
        found = set()
        in_fence = False
        for line in path.read_text(encoding="utf-8").splitlines():
            if FENCE.match(line):
                in_fence = not in_fence
                continue
            if in_fence:
                continue
            m = re.match(r"^\s{0,3}#{1,6}\s+(.*?)\s*#*\s*$", line)
            if not m:
                continue
            base = slug(m.group(1))
            n = seen.get(base, 0)
            seen[base] = n + 1
            found.add(base if n == 0 else f"{base}-{n}")
        for m in re.finditer(r"<a\s+(?:name|id)=\"([^\"]+)\"", path.read_text(encoding="utf-8")):
            found.add(m.group(1))
        cache[path] = found
    return cache[path]


def targets(path: Path):
    """(line number, target) of every link and image outside code."""
    in_fence = False
    for no, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        if FENCE.match(line):
            in_fence = not in_fence
            continue
        if in_fence:
            continue
        m = REF_DEF.match(line)
        if m:
            yield no, m.group(1)
            continue
        for m in LINK.finditer(strip_code(line)):
            yield no, m.group(1)


def check(root: Path) -> list:
    files = [root / "README.md", root / "CHANGELOG.md"]
    files += sorted((root / "docs").rglob("*.md"))
    broken = []
    cache = {}
    for md in files:
        if not md.is_file():
            broken.append(f"{md.relative_to(root)}: missing")
            continue
        for no, target in targets(md):
            if SCHEME.match(target) or target.startswith("//"):
                continue  # absolute URL: not checked here
            where = f"{md.relative_to(root)}:{no}: {target}"
            file_part, _, anchor = target.partition("#")
            dest = (md.parent / unquote(file_part)).resolve() if file_part else md
            if file_part and not dest.exists():
                broken.append(f"{where} (no such file)")
                continue
            if anchor:
                if dest.is_dir() or dest.suffix.lower() != ".md":
                    continue  # anchors into other files (source lines) are not checked
                if unquote(anchor).lower() not in anchors(dest, cache):
                    broken.append(f"{where} (no heading with that anchor)")
    return broken


def main() -> int:
    root = Path(sys.argv[1] if len(sys.argv) > 1 else Path(__file__).resolve().parents[2]).resolve()
    broken = check(root)
    for b in broken:
        print(b)
    count = len(broken)
    print(f"check_doc_links: {count} broken link{'s' if count != 1 else ''}" if count else
          "check_doc_links: every relative link and image resolves")
    return 1 if broken else 0


if __name__ == "__main__":
    sys.exit(main())
